"""What each integrator does to a row of the state once that row's accelerations are known.

Every update is one small compiled function, called from every loop shape that runs the
integrator: the one-thread sweeps (``sim.loops.row_sweep``), the wavefronts over row blocks
(``sim.loops.wavefront``) and the parallel phases (``sim.loops.row_blocks``, ``sim.loops.leapfrog``).  So the
arithmetic per particle is written once, and the loop shapes agree with each other to the bit.

Arrays: ``position``, ``velocity`` are the state, C-contiguous ``(dim, ny, nx)`` (m, m/s);
``row`` holds the accelerations (m/s^2) of row j just computed, ``(3, nx)``; the stage arrays of
the Runge-Kutta methods are ``(dim, rows, nx)``, row j kept at index ``slot`` (j itself in full
arrays, j % rows in a ring buffer).  ``dt`` and the arrays share one precision.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sim.forces.diagonal import ROWS
from sim.forces.springs import components, row_accelerations, vertical_springs

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")
_ROW_UPDATE = dict(_JIT, inline="always")
"""The row updates are inlined into their loops by numba itself: a call per row that passes a
dozen arrays costs their reference counting, which the fused loops cannot afford."""

RK4 = None
"""``method`` of the classic fourth-order Runge-Kutta stages (4 stages).  The method is a
compile-time choice like the optional terms: None or True, so that numba compiles one version of
the loops per method."""
HEUN = True
"""``method`` of Heun's predictor-corrector (2 stages)."""


@njit(**_JIT)
def sweep_buffers(position):
    """Scratch of one force sweep over the rows of ``position`` (dim, ny, nx): the forces of the
    vertical (and diagonal) springs below and above the current row (``ROWS``, nx) each, of its
    horizontal springs (3, nx + 1), and its accelerations (3, nx)."""
    nx = position.shape[2]
    return (np.empty((ROWS, nx), position.dtype), np.empty((ROWS, nx), position.dtype),
            np.empty((3, nx + 1), position.dtype), np.empty((3, nx), position.dtype))


@njit(**_JIT)
def store_acceleration(j, row, acceleration, kick, velocity):
    """Copy ``row`` into row j of ``acceleration`` (dim, ny, nx) and, with ``kick`` (s) not None,
    kick that row's velocities by kick * a."""
    dim, _, nx = acceleration.shape
    for c in range(dim):
        for i in range(nx):
            acceleration[c, j, i] = row[c, i]
            if kick is not None:
                velocity[c, j, i] += kick * row[c, i]


@njit(**_JIT)
def force_rows(j0, j1, linear, out_of_plane, position, force_velocity, inverse_mass,
               uniform_inverse_mass, parameters, dashpot, drag, gravity, acceleration, kick,
               velocity):
    """Accelerations (m/s^2) of rows j0 .. j1-1 of the state (``position``, ``force_velocity``)
    into the full array ``acceleration``, with ``store_acceleration``'s optional kick.  Returns
    the dissipated power (W) of the springs in and above those rows and below row j0 only when
    j0 == 0 (each spring's power counted by exactly one block of rows)."""
    x, y, z = components(out_of_plane, position)
    vx, vy, vz = components(out_of_plane, force_velocity)
    dim, ny, nx = acceleration.shape
    below, above, horizontal, row = sweep_buffers(position)
    power = vertical_springs(j0, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, below)
    if j0 > 0:
        power = 0.0
    for j in range(j0, j1):
        power += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear, parameters,
                                   dashpot, drag, gravity, below, above, horizontal, row,
                                   uniform_inverse_mass)
        store_acceleration(j, row, acceleration, kick, velocity)
        below, above = above, below
    return power


# --- explicit Euler and velocity Verlet ---------------------------------------------------------


@njit(**_ROW_UPDATE)
def euler_update(j, dt, position, velocity, acceleration, k):
    """Explicit Euler on row j: x += dt v; v += dt a, with a in row k of ``acceleration``."""
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            position[c, j, i] += dt * velocity[c, j, i]
            velocity[c, j, i] += dt * acceleration[c, k, i]


@njit(**_JIT)
def kick_drift(position, velocity, acceleration, kick, drift):
    """One particle coordinate kicked, then drifted: v += kick a; x += drift v.  Returns (x, v)."""
    velocity = velocity + kick * acceleration
    return position + drift * velocity, velocity


@njit(**_ROW_UPDATE)
def kick_drift_row(j, dt, position, velocity, row):
    """Leapfrog on row j: v(t + dt/2) = v(t - dt/2) + dt a(t); x(t + dt) = x(t) + dt v."""
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            position[c, j, i], velocity[c, j, i] = kick_drift(position[c, j, i], velocity[c, j, i],
                                                              row[c, i], dt, dt)


@njit(**_JIT)
def verlet_drift(j, dt, position, velocity, acceleration, predicted_velocity, damped):
    """Velocity Verlet's half kick and drift of row j (and the predicted velocity v + dt a when
    damped), with a the cached accelerations (dim, ny, nx)."""
    dim, _, nx = position.shape
    half = type(dt)(0.5) * dt
    for c in range(dim):
        for i in range(nx):
            if damped:
                predicted_velocity[c, j, i] = velocity[c, j, i] + dt * acceleration[c, j, i]
            position[c, j, i], velocity[c, j, i] = kick_drift(
                position[c, j, i], velocity[c, j, i], acceleration[c, j, i], half, dt
            )


# --- the stages of classic RK4 and Heun ---------------------------------------------------------
#
# Each stage reads the accelerations ``row`` of its input state at row j, and the velocity of
# that input (``stage_velocity``) at ``slot``; it writes the next stage's input (``next_*``) and
# the running sums (``sum_*``) at ``slot``, and the last stage writes the new state into row k of
# ``new_position``/``new_velocity`` (the state itself with k = j, or rows kept aside).


@njit(**_ROW_UPDATE)
def _rk4_first(j, slot, dt, position, velocity, row, next_position, next_velocity, sum_position,
               sum_velocity):
    dim, _, nx = position.shape
    sixth = dt / type(dt)(6.0)
    half = type(dt)(0.5) * dt
    for c in range(dim):
        for i in range(nx):
            v = velocity[c, j, i]
            sum_position[c, slot, i] = position[c, j, i] + sixth * v
            sum_velocity[c, slot, i] = v + sixth * row[c, i]
            next_position[c, slot, i] = position[c, j, i] + half * v
            next_velocity[c, slot, i] = v + half * row[c, i]


@njit(**_ROW_UPDATE)
def _rk4_middle(j, slot, dt, step_to_next, position, velocity, row, stage_velocity, next_position,
                next_velocity, sum_position, sum_velocity):
    dim, _, nx = position.shape
    third = dt / type(dt)(3.0)
    for c in range(dim):
        for i in range(nx):
            stage_v = stage_velocity[c, slot, i]
            sum_position[c, slot, i] += third * stage_v
            sum_velocity[c, slot, i] += third * row[c, i]
            next_position[c, slot, i] = position[c, j, i] + step_to_next * stage_v
            next_velocity[c, slot, i] = velocity[c, j, i] + step_to_next * row[c, i]


@njit(**_ROW_UPDATE)
def _rk4_last(slot, dt, row, stage_velocity, sum_position, sum_velocity, new_position,
              new_velocity, k):
    dim, _, nx = new_position.shape
    sixth = dt / type(dt)(6.0)
    for c in range(dim):
        for i in range(nx):
            new_position[c, k, i] = sum_position[c, slot, i] + sixth * stage_velocity[c, slot, i]
            new_velocity[c, k, i] = sum_velocity[c, slot, i] + sixth * row[c, i]


@njit(**_ROW_UPDATE)
def _heun_predict(j, slot, dt, position, velocity, row, next_position, next_velocity,
                  first_acceleration):
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            first_acceleration[c, slot, i] = row[c, i]
            next_position[c, slot, i] = position[c, j, i] + dt * velocity[c, j, i]
            next_velocity[c, slot, i] = velocity[c, j, i] + dt * row[c, i]


@njit(**_ROW_UPDATE)
def _heun_correct(j, slot, dt, position, velocity, row, stage_velocity, first_acceleration,
                  new_position, new_velocity, k):
    dim, _, nx = position.shape
    half = type(dt)(0.5) * dt
    for c in range(dim):
        for i in range(nx):
            new_position[c, k, i] = position[c, j, i] + half * (
                velocity[c, j, i] + stage_velocity[c, slot, i]
            )
            new_velocity[c, k, i] = velocity[c, j, i] + half * (
                first_acceleration[c, slot, i] + row[c, i]
            )


@njit(**_JIT)
def stages(method):
    """Number of stages (force evaluations per step) of ``method`` (``RK4`` or ``HEUN``)."""
    return 4 if method is None else 2


@njit(**_ROW_UPDATE)
def stage_update(method, stage, j, slot, dt, position, velocity, row, stage_velocity,
                 next_position, next_velocity, sum_position, sum_velocity, new_position,
                 new_velocity, k):
    """The update of row j by stage ``stage`` of ``method``.

    RK4: stage 0 starts the sums x + dt/6 v, v + dt/6 a and the next input x + dt/2 v,
    v + dt/2 a; stages 1 and 2 add dt/3 of their slopes and form the next input (dt/2, then dt);
    stage 3 writes x_new = sum + dt/6 v_3, v_new = sum + dt/6 a_3.  Heun: the predictor keeps
    a(x, v) in ``sum_velocity`` and forms the Euler prediction; the corrector writes the
    trapezoid x + dt/2 (v + v_p), v + dt/2 (a + a_p).  ``sum_position`` is unused by Heun.
    """
    if method is None:  # RK4
        if stage == 0:
            _rk4_first(j, slot, dt, position, velocity, row, next_position, next_velocity,
                       sum_position, sum_velocity)
        elif stage < 3:
            step_to_next = type(dt)(0.5) * dt if stage == 1 else dt
            _rk4_middle(j, slot, dt, step_to_next, position, velocity, row, stage_velocity,
                        next_position, next_velocity, sum_position, sum_velocity)
        else:
            _rk4_last(slot, dt, row, stage_velocity, sum_position, sum_velocity, new_position,
                      new_velocity, k)
    elif stage == 0:
        _heun_predict(j, slot, dt, position, velocity, row, next_position, next_velocity,
                      sum_velocity)
    else:
        _heun_correct(j, slot, dt, position, velocity, row, stage_velocity, sum_velocity,
                      new_position, new_velocity, k)


@njit(**_JIT)
def dissipated_energy(method, dt, powers):
    """Energy (J) dissipated over one step from the power of each stage (``powers``, W), with
    the method's own quadrature weights (RK4: 1/6, 1/3, 1/3, 1/6; Heun: 1/2, 1/2)."""
    if method is None:  # RK4
        sixth = dt / type(dt)(6.0)
        return sixth * (powers[0] + 2.0 * powers[1] + 2.0 * powers[2] + powers[3])
    half = type(dt)(0.5) * dt
    return half * (powers[0] + powers[1])
