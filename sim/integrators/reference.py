"""Plain vectorised numpy versions of the force law and of the integrators.

Written from the physics, independently of the numba kernels, for two uses: the tests check the
kernels against them, and ``oscillators bench`` measures how much faster the kernels are.  Arrays
are (dim, ny, nx) as in ``sim.model.state``; the wall anchors are a ring of fixed points around the
lattice (padding), which makes every spring an array slice.  ``METHODS`` holds one small
function per integrator written out by hand; any other Runge-Kutta method runs from its Butcher
table in the textbook form (``runge_kutta``: every stage from the full matrix A, none of the
compiled loops' low-storage bookkeeping).  ``step`` and ``run`` take a registry name or a table.
"""

from __future__ import annotations

import numpy as np

from sim.forces import registry
from sim.integrators.butcher import ButcherTable
from sim.integrators.splitting import SplittingTable
from sim.model.lattice import Model


def _padded(model: Model, field: np.ndarray, rest: bool) -> np.ndarray:
    """(dim, ny + 2, nx + 2): the field with the wall ring around it (rest positions or zeros)."""
    padded = np.zeros((model.dim, model.ny + 2, model.nx + 2))
    if rest:
        origin_x, origin_y = model.origin
        a = model.spacing
        padded[0] = (origin_x + (np.arange(model.nx + 2) - 1) * a)[None, :]
        padded[1] = (origin_y + (np.arange(model.ny + 2) - 1) * a)[:, None]
        if model.dim == 3:
            padded[2] = 0.0
    padded[:, 1:-1, 1:-1] = field
    return padded


def accelerations(model: Model, positions: np.ndarray, velocities: np.ndarray) -> np.ndarray:
    """(dim, ny, nx) accelerations (m/s^2) of every particle, for either spring law."""
    r = _padded(model, positions, rest=True)
    v = _padded(model, velocities, rest=False)
    k, length, c = model.stiffness, model.rest_length, model.damping
    force = np.zeros_like(positions)
    present = registry.present(model)
    axial_terms = [term for term in present if term.numpy_axial is not None]

    # separation vectors of horizontal (dim, ny, nx + 1) and vertical (dim, ny + 1, nx) springs,
    # pointing from the first end (left / lower) to the second end (right / upper)
    horizontal = r[:, 1:-1, 1:] - r[:, 1:-1, :-1]
    vertical = r[:, 1:, 1:-1] - r[:, :-1, 1:-1]
    horizontal_velocity = v[:, 1:-1, 1:] - v[:, 1:-1, :-1]
    vertical_velocity = v[:, 1:, 1:-1] - v[:, :-1, 1:-1]

    def spring_forces(separation, relative_velocity, axis):
        """Force on the first end of each spring, (dim, ...)."""
        if model.linear:
            tension_stiffness = model.tension_stiffness
            displacement = separation.copy()
            displacement[axis] -= model.spacing
            result = tension_stiffness * displacement
            result[axis] = k * displacement[axis]
            rest = model.spacing - model.rest_length
            for term in axial_terms:  # about the rest extension, less the rest tension
                result[axis] += (term.numpy_axial(model, rest + displacement[axis])[0]
                                 - term.numpy_axial(model, np.array(rest))[0])
            if c > 0:
                result[axis] += c * relative_velocity[axis]
            return result
        distance = np.sqrt((separation**2).sum(axis=0))
        safe = np.maximum(distance, 1e-12)
        stretch = distance - length
        along = k * stretch
        for term in axial_terms:
            along = along + term.numpy_axial(model, stretch)[0]
        result = along / safe * separation
        if c > 0:
            rate = (separation * relative_velocity).sum(axis=0)
            result += c * rate / safe**2 * separation
        return result

    on_left = spring_forces(horizontal, horizontal_velocity, 0)
    on_lower = spring_forces(vertical, vertical_velocity, 1)
    force += on_left[:, :, 1:] - on_left[:, :, :-1]
    force += on_lower[:, 1:, :] - on_lower[:, :-1, :]
    for term in present:  # the other terms' numpy twins: diagonal springs, drag, gravity, ...
        if term.numpy_force is not None:
            force += term.numpy_force(model, positions, velocities)
    return force / model.masses


# Each method advances (x, v) by one step dt and returns (x, v, carried): ``carried`` is what
# the method keeps from one step to the next (velocity Verlet: the acceleration at the new
# state), None for one-step methods; it is passed back in as ``carried`` (None on the first step).


def _euler(model: Model, x, v, dt: float, carried=None):
    a = accelerations(model, x, v)
    return x + dt * v, v + dt * a, None


def _heun(model: Model, x, v, dt: float, carried=None):
    a = accelerations(model, x, v)
    x_predicted, v_predicted = x + dt * v, v + dt * a
    a_predicted = accelerations(model, x_predicted, v_predicted)
    return x + dt / 2 * (v + v_predicted), v + dt / 2 * (a + a_predicted), None


def _verlet(model: Model, x, v, dt: float, carried=None):
    acceleration = accelerations(model, x, v) if carried is None else carried
    return verlet_step(model, x, v, acceleration, dt)


def _rk4(model: Model, x, v, dt: float, carried=None):
    k1x, k1v = v, accelerations(model, x, v)
    k2x = v + dt / 2 * k1v
    k2v = accelerations(model, x + dt / 2 * k1x, k2x)
    k3x = v + dt / 2 * k2v
    k3v = accelerations(model, x + dt / 2 * k2x, k3x)
    k4x = v + dt * k3v
    k4v = accelerations(model, x + dt * k3x, k4x)
    return (
        x + dt / 6 * (k1x + 2 * k2x + 2 * k3x + k4x),
        v + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v),
        None,
    )


def runge_kutta(table: ButcherTable):
    """The step of the explicit Runge-Kutta method of ``table``: k_i = f(y + dt sum_j a_ij k_j)
    for i = 1 .. s with y = (x, v) and f(x, v) = (v, a(x, v)), then y + dt sum_i b_i k_i."""
    a, b = table.matrix, np.array(table.b)

    def method(model: Model, x, v, dt: float, carried=None):
        slopes_x, slopes_v = [], []
        for i in range(table.stages):
            stage_x, stage_v = x.copy(), v.copy()
            for j in range(i):
                stage_x += dt * a[i, j] * slopes_x[j]
                stage_v += dt * a[i, j] * slopes_v[j]
            slopes_x.append(stage_v)
            slopes_v.append(accelerations(model, stage_x, stage_v))
        new_x, new_v = x.copy(), v.copy()
        for i in range(table.stages):
            new_x += dt * b[i] * slopes_x[i]
            new_v += dt * b[i] * slopes_v[i]
        return new_x, new_v, None

    return method


def splitting_method(table: SplittingTable):
    """The step of the splitting method of ``table`` in its textbook form: kick b_1, drift
    a_1, ..., drift a_s, kick b_(s+1), each kick with the forces at the positions it finds
    (velocity-independent forces: a splitting method runs undamped lattices)."""

    def method(model: Model, x, v, dt: float, carried=None):
        for index, kick in enumerate(table.kicks):
            v = v + kick * dt * accelerations(model, x, v)
            if index < table.stages:
                x = x + table.drifts[index] * dt * v
        return x, v, None

    return method


METHODS = {"euler": _euler, "heun": _heun, "verlet": _verlet, "rk4": _rk4}
"""The numpy version of each compiled integrator written out by hand, by its registry name."""


def _method(integrator: str | ButcherTable):
    if isinstance(integrator, ButcherTable):
        return runge_kutta(integrator)
    if integrator in METHODS:
        return METHODS[integrator]
    from sim.integrators.registry import IntegratorError, describe

    try:
        description = describe(integrator)
    except (IntegratorError, KeyError):
        raise ValueError(f"unknown integrator {integrator!r}") from None
    if description.splitting is not None:
        return splitting_method(description.splitting)
    if description.butcher is None:
        raise ValueError(f"unknown integrator {integrator!r}")
    return runge_kutta(description.butcher)


def step(model: Model, integrator: str | ButcherTable, positions, velocities, dt: float):
    """One step of ``integrator`` in numpy; returns new (positions, velocities)."""
    x, v, _ = _method(integrator)(model, positions, velocities, dt)
    return x, v


def verlet_step(model: Model, positions, velocities, acceleration, dt: float):
    """Velocity Verlet with the acceleration carried from the previous step; velocity-dependent
    forces are evaluated at the predicted velocity v + dt a.  Returns (x, v, a) after the step."""
    v_half = velocities + dt / 2 * acceleration
    x_new = positions + dt * v_half
    a_new = accelerations(model, x_new, velocities + dt * acceleration)
    return x_new, v_half + dt / 2 * a_new, a_new


def run(model: Model, integrator: str | ButcherTable, positions, velocities, dt: float, steps: int):
    """``steps`` steps of ``integrator`` in numpy; returns the final (positions, velocities)."""
    method = _method(integrator)
    x, v, carried = positions.copy(), velocities.copy(), None
    for _ in range(steps):
        x, v, carried = method(model, x, v, dt, carried)
    return x, v
