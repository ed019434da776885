"""Numba step loops of the four integrators: explicit Euler, Heun, velocity Verlet, classic RK4.

Each ``*_steps`` function advances a state by ``n`` steps of size ``dt`` entirely in compiled code
(no Python between steps) and returns the energy dissipated by dashpots and drag over those steps
(J), integrated with the integrator's own quadrature so that kinetic + potential + dissipated is
conserved to the integrator's order.

Arrays: ``position``, ``velocity`` and the work arrays are C-contiguous ``(dim, ny, nx)`` float
arrays (m, m/s, m/s^2).  ``out_of_plane`` is None for planar scenes (dim == 2) and any value for
dim == 3; ``dashpot``, ``drag``, ``gravity`` are None when the scene has none of them, which
selects a kernel without those terms (see ``sim.kernels``).  ``parameters`` is the tuple
``(stiffness, rest_length, tension_stiffness, spacing, origin_x, origin_y)``.
"""

from __future__ import annotations

from numba import njit

from sim.kernels import linear_accelerations, nonlinear_accelerations

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def accelerations(
    linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag, gravity,
    acceleration,
):
    """Write the acceleration of every particle into ``acceleration``; return dissipated power (W)."""
    stiffness, rest_length, tension_stiffness, spacing, origin_x, origin_y = parameters
    if out_of_plane is None:
        if linear:
            return linear_accelerations(
                position[0], position[1], None, velocity[0], velocity[1], None, inverse_mass,
                stiffness, tension_stiffness, spacing, origin_x, origin_y, dashpot, drag, gravity,
                acceleration[0], acceleration[1], None,
            )
        return nonlinear_accelerations(
            position[0], position[1], None, velocity[0], velocity[1], None, inverse_mass,
            stiffness, rest_length, spacing, origin_x, origin_y, dashpot, drag, gravity,
            acceleration[0], acceleration[1], None,
        )
    if linear:
        return linear_accelerations(
            position[0], position[1], position[2], velocity[0], velocity[1], velocity[2],
            inverse_mass, stiffness, tension_stiffness, spacing, origin_x, origin_y, dashpot, drag,
            gravity, acceleration[0], acceleration[1], acceleration[2],
        )
    return nonlinear_accelerations(
        position[0], position[1], position[2], velocity[0], velocity[1], velocity[2],
        inverse_mass, stiffness, rest_length, spacing, origin_x, origin_y, dashpot, drag, gravity,
        acceleration[0], acceleration[1], acceleration[2],
    )


@njit(**_JIT)
def euler_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
    gravity, acceleration,
):
    """Explicit Euler: x += dt v(t); v += dt a(t).  First order."""
    x = position.reshape(-1)
    v = velocity.reshape(-1)
    a = acceleration.reshape(-1)
    dissipated = 0.0
    for _ in range(n):
        power = accelerations(
            linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
            gravity, acceleration,
        )
        for k in range(x.shape[0]):
            x[k] += dt * v[k]
            v[k] += dt * a[k]
        dissipated += dt * power
    return dissipated


@njit(**_JIT)
def heun_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
    gravity, acceleration, stage_position, stage_velocity, stage_acceleration,
):
    """Heun's predictor-corrector (explicit trapezoid): Euler predictor, trapezoidal corrector."""
    x = position.reshape(-1)
    v = velocity.reshape(-1)
    a = acceleration.reshape(-1)
    xs = stage_position.reshape(-1)
    vs = stage_velocity.reshape(-1)
    a_stage = stage_acceleration.reshape(-1)
    half = 0.5 * dt
    dissipated = 0.0
    for _ in range(n):
        power = accelerations(
            linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
            gravity, acceleration,
        )
        for k in range(x.shape[0]):
            xs[k] = x[k] + dt * v[k]
            vs[k] = v[k] + dt * a[k]
        power_stage = accelerations(
            linear, out_of_plane, stage_position, stage_velocity, inverse_mass, parameters,
            dashpot, drag, gravity, stage_acceleration,
        )
        for k in range(x.shape[0]):
            x[k] += half * (v[k] + vs[k])
            v[k] += half * (a[k] + a_stage[k])
        dissipated += half * (power + power_stage)
    return dissipated


@njit(**_JIT)
def verlet_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
    gravity, acceleration, previous_power, predicted_velocity,
):
    """Velocity Verlet: half kick, drift, new forces, half kick.  Second order, symplectic.

    ``acceleration`` must hold a(x, v) of the current state on entry (``previous_power`` the power
    that went with it) and holds the new one on exit, so each step costs one force evaluation.
    With velocity-dependent forces (damping), the new forces use the predicted velocity
    v + dt a, which keeps the scheme explicit and second order.  Returns (dissipated, power).
    """
    x = position.reshape(-1)
    v = velocity.reshape(-1)
    a = acceleration.reshape(-1)
    half = 0.5 * dt
    dissipated = 0.0
    power = previous_power
    damped = dashpot is not None or drag is not None
    if damped:
        v_predicted = predicted_velocity.reshape(-1)
        for _ in range(n):
            for k in range(x.shape[0]):
                v_predicted[k] = v[k] + dt * a[k]
                v[k] += half * a[k]
                x[k] += dt * v[k]
            new_power = accelerations(
                linear, out_of_plane, position, predicted_velocity, inverse_mass, parameters,
                dashpot, drag, gravity, acceleration,
            )
            for k in range(x.shape[0]):
                v[k] += half * a[k]
            dissipated += half * (power + new_power)
            power = new_power
    else:
        for _ in range(n):
            for k in range(x.shape[0]):
                v[k] += half * a[k]
                x[k] += dt * v[k]
            accelerations(
                linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot,
                drag, gravity, acceleration,
            )
            for k in range(x.shape[0]):
                v[k] += half * a[k]
    return dissipated, power


@njit(**_JIT)
def rk4_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
    gravity, acceleration, stage_position, stage_velocity, sum_position, sum_velocity,
):
    """Classic fourth-order Runge-Kutta on (x, v), with three work arrays besides a."""
    x = position.reshape(-1)
    v = velocity.reshape(-1)
    a = acceleration.reshape(-1)
    xs = stage_position.reshape(-1)
    vs = stage_velocity.reshape(-1)
    xa = sum_position.reshape(-1)
    va = sum_velocity.reshape(-1)
    half = 0.5 * dt
    sixth = dt / 6.0
    third = dt / 3.0
    dissipated = 0.0
    size = x.shape[0]
    for _ in range(n):
        p1 = accelerations(
            linear, out_of_plane, position, velocity, inverse_mass, parameters, dashpot, drag,
            gravity, acceleration,
        )
        for k in range(size):
            xs[k] = x[k] + half * v[k]
            vs[k] = v[k] + half * a[k]
            xa[k] = x[k] + sixth * v[k]
            va[k] = v[k] + sixth * a[k]
        p2 = accelerations(
            linear, out_of_plane, stage_position, stage_velocity, inverse_mass, parameters,
            dashpot, drag, gravity, acceleration,
        )
        for k in range(size):
            xa[k] += third * vs[k]
            va[k] += third * a[k]
            xs[k] = x[k] + half * vs[k]
            vs[k] = v[k] + half * a[k]
        p3 = accelerations(
            linear, out_of_plane, stage_position, stage_velocity, inverse_mass, parameters,
            dashpot, drag, gravity, acceleration,
        )
        for k in range(size):
            xa[k] += third * vs[k]
            va[k] += third * a[k]
            xs[k] = x[k] + dt * vs[k]
            vs[k] = v[k] + dt * a[k]
        p4 = accelerations(
            linear, out_of_plane, stage_position, stage_velocity, inverse_mass, parameters,
            dashpot, drag, gravity, acceleration,
        )
        for k in range(size):
            x[k] = xa[k] + sixth * vs[k]
            v[k] = va[k] + sixth * a[k]
        dissipated += sixth * (p1 + 2.0 * p2 + 2.0 * p3 + p4)
    return dissipated
