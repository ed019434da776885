"""Numba step loops of the integrators on one thread: explicit Euler, velocity Verlet, every
Runge-Kutta method of a table (``sim.integrators.butcher``); and the force sweep ``accelerations``.

Each ``*_steps`` function advances a state by ``n`` steps of size ``dt`` entirely in compiled code
(no Python between steps) and returns the energy dissipated by dashpots and drag over those steps
(J), integrated with the integrator's own quadrature so that kinetic + potential + dissipated is
conserved to the integrator's order.

Every force evaluation is one sweep over the rows (``sim.forces.springs.row_accelerations``) with the
integrator's update of each row (``sim.loops.stage_updates``) fused in right after that row's forces are
known: a row that has been swept is never read again by the same sweep, so it may be overwritten
in place.  Velocity Verlet also drifts each row just before its forces are needed; a Runge-Kutta
method runs its stages as one wavefront (``sim.loops.wavefront``).  One sweep thus touches each array once,
which is what makes the step fast on large lattices.  The same updates on several threads are in
``sim.loops.row_blocks`` and ``sim.loops.leapfrog``.

Arrays: ``position``, ``velocity`` and the work arrays are C-contiguous ``(dim, ny, nx)`` float
arrays (m, m/s, m/s^2).  ``out_of_plane`` is None for planar scenes (dim == 2) and True for
dim == 3; ``dashpot``, ``drag``, ``gravity`` are None when the scene has none of them, which
selects compiled code without those terms (see ``sim.forces.springs``): these and the masses come
in one ``sim.forces.terms.Terms`` record, ``terms``.  ``parameters`` is a
``sim.forces.springs.SpringParameters`` record.  Precision: the arrays, ``dt`` and every parameter are
all float64 or all float32, and so is the arithmetic; dissipated energy sums in float64.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sim.forces.absorbing_kicks import TWICE
from sim.forces.absorbing_layer import act_with
from sim.forces.drive_table import EVERY_KIND, drive_row, drive_rows
from sim.forces.springs import BUFFER_ROWS, row_accelerations, vertical_springs
from sim.loops.stage_updates import (
    Fields,
    components,
    dissipated_energy,
    euler_update,
    force_rows,
    kick_drift,
    kick_drift_row,
    stages,
    store_acceleration,
    sweep_buffers,
    verlet_drift,
)
from sim.loops.wavefront import BlockWork, wavefront

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def accelerations(terms, parameters, position, velocity, acceleration):
    """Write the acceleration of every particle into ``acceleration``; return dissipated power (W)."""
    return force_rows(np.intp(0), position.shape[1], terms, parameters, position, velocity,
                      acceleration, None, velocity)


@njit(**_JIT)
def euler_steps(n, dt, terms, parameters, position, velocity):
    """Explicit Euler: x += dt v(t); v += dt a(t).  First order; no work array needed."""
    x, y, z = components(terms.out_of_plane, position)
    vx, vy, vz = components(terms.out_of_plane, velocity)
    dim, ny, nx = position.shape
    below, above, horizontal, row = sweep_buffers(position)
    row_as_array = row.reshape((3, 1, nx))
    dissipated = 0.0
    for _ in range(n):
        power = vertical_springs(np.intp(0), ny, x, y, z, vx, vy, vz, terms, parameters, below)
        for j in range(ny):
            power += row_accelerations(j, ny, x, y, z, vx, vy, vz, terms, parameters, below,
                                       above, horizontal, row)
            euler_update(j, dt, position, velocity, row_as_array, 0)
            below, above = above, below
        dissipated += dt * power
    return dissipated


@njit(**_JIT)
def runge_kutta_steps(table, n, dt, terms, parameters, position, velocity, stage, sums, time=0.0,
                      drive=None, drive_work=None):
    """n steps of the Runge-Kutta method of ``table`` (``sim.integrators.butcher.ButcherTable.coefficients``)
    on (x, v), each one wavefront over the whole lattice; with a drive table
    (``sim.forces.drive_table``) from ``time`` (s), its work (J) added to ``drive_work[0]``.

    The stages run as a wavefront over the rows (``sim.loops.wavefront``), so a step streams the
    state through the cache once instead of once per stage, and the stage inputs (``stage``) and
    running sums (``sums``, both ``Fields``) only need to hold as many rows as the method has
    stages: they are ring buffers of shape (dim, rows, nx) (full (dim, ny, nx) arrays work too),
    row j being stored at index j % rows.  Numba compiles this loop once for every table: its
    numbers are an ordinary array argument.
    """
    nx = position.shape[2]
    count = stages(table)
    work = BlockWork(stage, sums, Fields(position, velocity),
                     np.empty((count, 2, BUFFER_ROWS, nx), position.dtype),  # (stage, below/above, ...)
                     np.empty((3, nx + 1), position.dtype), np.empty((3, nx), position.dtype))
    powers = np.zeros(count)
    drive_powers = np.zeros(count)
    dissipated = 0.0
    for step in range(n):
        wavefront(table, np.intp(0), position.shape[1], dt, terms, parameters, position,
                  velocity, work, powers, time + step * float(dt), drive, drive_powers)
        dissipated += dissipated_energy(table, dt, powers)
        if drive is not None:
            drive_work[0] += dissipated_energy(table, dt, drive_powers)
    return dissipated


@njit(**_JIT)
def verlet_steps(n, dt, terms, parameters, position, velocity, acceleration, previous_power,
                 predicted_velocity, time=0.0, drive=None, sponge=None, totals=None):
    """Velocity Verlet: half kick, drift, new forces, half kick.  Second order, symplectic.

    ``acceleration`` must hold a(x, v) of the current state on entry (``previous_power`` the
    power that went with it) and holds the new one on exit, so a step costs one force sweep.

    Without damping, consecutive steps run as leapfrog (kick by a full dt, drift) on the
    half-step velocities, each sweep updating a row in place once its forces are known; the first
    sweep drifts each row just before it is needed and the last one kicks by half a step to bring
    the velocities back to whole steps.  That is algebraically velocity Verlet and reads and
    writes only positions and velocities in the steps between.
    With velocity-dependent forces (damping), every step is a full velocity-Verlet step whose new
    forces use the predicted velocity v + dt a, which keeps it explicit and second order.
    Instruments (None compiles them out): a drive table (``sim.forces.drive_table``) acts on the new
    forces of each step at its end time (``time`` is the start, s); the absorbing layer
    (``sponge``: the arguments of ``sim.forces.absorbing_layer.act_with``, frequency-shifted
    relaxations included) acts over dt / 2 at the end of
    each step and the start of the next, the caller before the first and after the last.  ``totals`` (2,)
    receives the drive's work and the layer's take (J), the accelerations of the driven rows
    on entry already hold the drive at ``time``.
    Returns (dissipated, power).
    """
    damped = terms.damped is not None
    out_of_plane = terms.out_of_plane
    x, y, z = components(out_of_plane, position)
    if damped:
        vx, vy, vz = components(out_of_plane, predicted_velocity)
    else:
        vx, vy, vz = components(out_of_plane, velocity)
    dim, ny, nx = position.shape
    below, above, horizontal, row = sweep_buffers(position)
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    power = previous_power
    whole = damped or sponge is not None  # every step a whole velocity-Verlet step
    for step in range(n):
        first = step == 0 or whole
        last = step == n - 1 or whole
        at = time + (step + 1) * float(dt)
        if sponge is not None and step > 0:
            # a step's end and the next one's start, in one pass
            totals[1] += act_with(0.5 * dt, 0.0, TWICE, position, velocity, sponge, parameters)
            if damped:  # the forces depend on the velocities the layer kicked
                power = accelerations(terms, parameters, position, velocity, acceleration)
                if drive is not None:
                    drive_rows(time + step * float(dt), drive, EVERY_KIND, acceleration, velocity,
                               0.0)
        if first:
            verlet_drift(np.intp(0), dt, position, velocity, acceleration, predicted_velocity,
                         damped)
        new_power = vertical_springs(np.intp(0), ny, x, y, z, vx, vy, vz, terms, parameters, below)
        drive_power = 0.0
        for j in range(ny):
            if first and j + 1 < ny:
                verlet_drift(j + 1, dt, position, velocity, acceleration, predicted_velocity,
                             damped)
            new_power += row_accelerations(j, ny, x, y, z, vx, vy, vz, terms, parameters, below,
                                           above, horizontal, row)
            if drive is not None:
                # undamped, the velocities are the half-step ones: v(t) = v(t - dt/2) + dt/2 a
                drive_power += drive_row(j, at, drive, EVERY_KIND, row, vx, vy, vz, j,
                                         0.0 if damped else float(half))
            if last:
                store_acceleration(j, row, acceleration, half, velocity)
            else:
                kick_drift_row(j, dt, position, velocity, row)
            below, above = above, below
        dissipated += half * (power + new_power)
        power = new_power
        if drive is not None:
            totals[0] += half * (totals[2] + drive_power)
            totals[2] = drive_power
    return dissipated, power


@njit(**_JIT)
def kick_drift_all(kick, drift, position, velocity, acceleration):
    """v += kick a; x += drift v over the whole state (in place): a splitting method's kick and
    drift with forces already known (velocity Verlet's opening: kick dt/2, drift dt)."""
    flat_position = position.reshape(-1)
    flat_velocity = velocity.reshape(-1)
    flat_acceleration = acceleration.reshape(-1)
    for k in range(flat_position.size):
        flat_position[k], flat_velocity[k] = kick_drift(flat_position[k], flat_velocity[k],
                                                        flat_acceleration[k], kick, drift)


@njit(**_JIT)
def kick_all(kick, velocity, acceleration):
    """v += kick a over the whole state, a = a(x) just computed (a step's last kick)."""
    flat_velocity = velocity.reshape(-1)
    flat_acceleration = acceleration.reshape(-1)
    for k in range(flat_velocity.size):
        flat_velocity[k] += kick * flat_acceleration[k]
