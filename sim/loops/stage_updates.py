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

from typing import NamedTuple

import numpy as np
from numba import njit

from sim.forces.springs import BUFFER_ROWS, components, row_accelerations, vertical_springs

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")
_ROW_UPDATE = dict(_JIT, inline="always")
"""The row updates are inlined into their loops by numba itself: a call per row that passes a
dozen arrays costs their reference counting, which the fused loops cannot afford."""

class Fields(NamedTuple):
    """A (position, velocity) pair of (dim, rows, nx) arrays (m, m/s): the state, a stage's
    input, a method's running sums, or where a new state goes."""

    position: np.ndarray
    velocity: np.ndarray


@njit(**_JIT)
def sweep_buffers(position):
    """Scratch of one force sweep over the rows of ``position`` (dim, ny, nx): the forces of the
    vertical (and diagonal) springs below and above the current row (``BUFFER_ROWS``, nx) each, of its
    horizontal springs (3, nx + 1), and its accelerations (3, nx)."""
    nx = position.shape[2]
    return (np.empty((BUFFER_ROWS, nx), position.dtype), np.empty((BUFFER_ROWS, nx), position.dtype),
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
def force_rows(j0, j1, terms, parameters, position, force_velocity, acceleration, kick, velocity):
    """Accelerations (m/s^2) of rows j0 .. j1-1 of the state (``position``, ``force_velocity``)
    into the full array ``acceleration``, with ``store_acceleration``'s optional kick of
    ``velocity``.  ``terms`` (``sim.forces.terms.Terms``) and ``parameters`` as for
    ``row_accelerations``.  Returns the dissipated power (W) of the springs in and above those
    rows and below row j0 only when j0 == 0 (each spring's power counted by exactly one block of
    rows)."""
    x, y, z = components(terms.out_of_plane, position)
    vx, vy, vz = components(terms.out_of_plane, force_velocity)
    dim, ny, nx = acceleration.shape
    below, above, horizontal, row = sweep_buffers(position)
    power = vertical_springs(j0, ny, x, y, z, vx, vy, vz, terms, parameters, below)
    if j0 > 0:
        power = 0.0
    for j in range(j0, j1):
        power += row_accelerations(j, ny, x, y, z, vx, vy, vz, terms, parameters, below, above,
                                   horizontal, row)
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


# --- the stages of a Runge-Kutta method, from its table ---------------------------------------
#
# ``table`` is a (3, stages) array (``sim.integrators.butcher.ButcherTable.coefficients``): the
# nodes c, the sub-diagonal a_{s+1,s} and the weights b, one row each.
# Each stage reads the accelerations ``row`` of its input state at row j, and the velocity of
# that input (``stage_velocity``) at ``slot``; it adds its slopes times dt b_s to the running sums
# (``sum_*``) and writes the next stage's input x0 + dt a_{s+1,s} k_s (``next_*``) at ``slot``;
# the last stage writes the new state into row k of ``new_position``/``new_velocity`` (the state
# itself with k = j, or rows kept aside).  The state's row j stays as it was until the last
# stage, so the position sum starts at stage 1 from x0 + dt b_0 v0 (one array fewer to write).


@njit(**_ROW_UPDATE)
def _first_stage(j, slot, weight, step_to_next, position, velocity, row, next_position,
                 next_velocity, sum_velocity):
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            v = velocity[c, j, i]
            sum_velocity[c, slot, i] = v + weight * row[c, i]
            next_position[c, slot, i] = position[c, j, i] + step_to_next * v
            next_velocity[c, slot, i] = v + step_to_next * row[c, i]


@njit(**_ROW_UPDATE)
def _second_stage(j, slot, first_weight, weight, step_to_next, position, velocity, row,
                  stage_velocity, next_position, next_velocity, sum_position, sum_velocity):
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            stage_v = stage_velocity[c, slot, i]
            x = position[c, j, i]
            v = velocity[c, j, i]
            sum_position[c, slot, i] = (x + first_weight * v) + weight * stage_v
            sum_velocity[c, slot, i] += weight * row[c, i]
            next_position[c, slot, i] = x + step_to_next * stage_v
            next_velocity[c, slot, i] = v + step_to_next * row[c, i]


@njit(**_ROW_UPDATE)
def _middle_stage(j, slot, weight, step_to_next, position, velocity, row, stage_velocity,
                  next_position, next_velocity, sum_position, sum_velocity):
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            stage_v = stage_velocity[c, slot, i]
            sum_position[c, slot, i] += weight * stage_v
            sum_velocity[c, slot, i] += weight * row[c, i]
            next_position[c, slot, i] = position[c, j, i] + step_to_next * stage_v
            next_velocity[c, slot, i] = velocity[c, j, i] + step_to_next * row[c, i]


@njit(**_ROW_UPDATE)
def _second_and_last_stage(j, slot, first_weight, weight, position, velocity, row,
                           stage_velocity, sum_velocity, new_position, new_velocity, k):
    dim, _, nx = position.shape
    for c in range(dim):
        for i in range(nx):
            x = (position[c, j, i] + first_weight * velocity[c, j, i]) + (
                weight * stage_velocity[c, slot, i])
            new_velocity[c, k, i] = sum_velocity[c, slot, i] + weight * row[c, i]
            new_position[c, k, i] = x


@njit(**_ROW_UPDATE)
def _last_stage(slot, weight, row, stage_velocity, sum_position, sum_velocity, new_position,
                new_velocity, k):
    dim, _, nx = new_position.shape
    for c in range(dim):
        for i in range(nx):
            new_position[c, k, i] = sum_position[c, slot, i] + weight * stage_velocity[c, slot, i]
            new_velocity[c, k, i] = sum_velocity[c, slot, i] + weight * row[c, i]


@njit(**_JIT)
def stages(table):
    """Number of stages (force evaluations per step) of ``table``."""
    return table.shape[1]


@njit(**_ROW_UPDATE)
def stage_update(table, stage, j, slot, dt, state, row, stage_velocity, next_input, sums, new, k):
    """The update of row j by stage ``stage`` of the method of ``table`` (at least 2 stages).

    ``state``, ``next_input``, ``sums`` and ``new`` are ``Fields``: the state x, v (row j), the
    next stage's input and the running sums (row ``slot``), and where the last stage writes the
    new state (row k); ``stage_velocity`` the velocity of this stage's input (row ``slot``).
    Stage 0 starts the velocity sum v + dt b_0 a and forms the next input x + dt a_{1,0} v,
    v + dt a_{1,0} a; each later stage s adds dt b_s of its slopes (v_s, a_s) to the sums (stage 1
    starts the position sum x + dt b_0 v + dt b_1 v_1 from the state) and, before the last, forms
    the next input x + dt a_{s+1,s} v_s, v + dt a_{s+1,s} a_s; the last stage writes
    x_new = sum + dt b_last v_last, v_new = sum + dt b_last a_last.
    """
    position, velocity = state
    next_position, next_velocity = next_input
    sum_position, sum_velocity = sums
    new_position, new_velocity = new
    weight = type(dt)(table[2, stage]) * dt
    first_weight = type(dt)(table[2, 0]) * dt
    if stage == stages(table) - 1:
        if stage == 1:
            _second_and_last_stage(j, slot, first_weight, weight, position, velocity, row,
                                   stage_velocity, sum_velocity, new_position, new_velocity, k)
        else:
            _last_stage(slot, weight, row, stage_velocity, sum_position, sum_velocity,
                        new_position, new_velocity, k)
        return
    step_to_next = type(dt)(table[1, stage]) * dt
    if stage == 0:
        _first_stage(j, slot, weight, step_to_next, position, velocity, row, next_position,
                     next_velocity, sum_velocity)
    elif stage == 1:
        _second_stage(j, slot, first_weight, weight, step_to_next, position, velocity, row,
                      stage_velocity, next_position, next_velocity, sum_position, sum_velocity)
    else:
        _middle_stage(j, slot, weight, step_to_next, position, velocity, row, stage_velocity,
                      next_position, next_velocity, sum_position, sum_velocity)


@njit(**_JIT)
def stage_time(table, stage):
    """Time of stage ``stage``'s input in steps after the step's start: c_stage."""
    return table[0, stage]


@njit(**_JIT)
def dissipated_energy(table, dt, powers):
    """Energy (J) dissipated over one step from the power of each stage (``powers``, W), with
    the method's weights b as the quadrature weights."""
    total = 0.0
    for stage in range(stages(table)):
        total += table[2, stage] * powers[stage]
    return float(dt) * total
