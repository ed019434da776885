"""Numba kernels of the driven particles inside the step, read from one small table (the absorbing
layer inside the step is ``sim.forces.absorbing_layer``).

**The drive table** (``DRIVE_FIELDS`` columns, one row per driven particle, float64): row j and
column i of the particle, its unit direction (dx, dy, dz), amplitude (N for a force, m for a
displacement), angular frequency omega (rad/s), phase (rad), start (s), ramp (s), kind
(``FORCE`` or ``DISPLACEMENT``), inverse mass (1/kg) and rest position (x, y, z) (m).  The drive
of a particle is A s(t) sin(omega (t - start) + phase) along its direction, s the start-up
envelope (1 - cos(pi (t - start) / ramp)) / 2 during the ramp, 1 after it and 0 before ``start``.
A force is added to the particle's acceleration after the lattice forces; a prescribed
displacement replaces its acceleration by the prescription's second derivative, so that every
integrator moves it along the prescription to its own order and its neighbours feel a position
and velocity consistent with that motion inside the step.  The kernels return the power (W) the
drive feeds in, F . v with F the drive's force (for a displacement, the force that makes the
particle follow: m a_prescribed - F_lattice).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_JIT = dict(cache=True, nogil=True, error_model="numpy")

FORCE = 0
DISPLACEMENT = 1
ROW, COLUMN, DIRECTION, AMPLITUDE, OMEGA, PHASE, START, RAMP, KIND, INVERSE_MASS, REST = (
    0, 1, 2, 5, 6, 7, 8, 9, 10, 11, 12
)
DRIVE_FIELDS = 15
"""Columns of the drive table (the last three are the rest position x, y, z)."""
EVERY_KIND = np.int64(-1)
"""``kinds`` for every drive, as every caller passes it: a value, not the constant -1, which
numba would compile as a type of its own (Literal[int]) beside a caller's int64."""


@njit(**_JIT)
def drive_signal(time, table, d):
    """(value, rate, second derivative) of s(t) sin(omega (t - start) + phase) of driven
    particle d at ``time`` (s); multiply by the amplitude."""
    elapsed = time - table[d, START]
    if elapsed < 0.0:
        return 0.0, 0.0, 0.0
    omega = table[d, OMEGA]
    ramp = table[d, RAMP]
    angle = omega * elapsed + table[d, PHASE]
    sine = math.sin(angle)
    cosine = math.cos(angle)
    if ramp <= 0.0 or elapsed >= ramp:
        return sine, omega * cosine, -omega * omega * sine
    turn = math.pi * elapsed / ramp
    envelope = 0.5 * (1.0 - math.cos(turn))
    envelope_rate = 0.5 * math.pi / ramp * math.sin(turn)
    envelope_second = 0.5 * (math.pi / ramp) ** 2 * math.cos(turn)
    return (envelope * sine, envelope_rate * sine + envelope * omega * cosine,
            envelope_second * sine + 2.0 * envelope_rate * omega * cosine
            - envelope * omega * omega * sine)


@njit(**_JIT)
def _drive_one(d, time, table, kinds, row, vx, vy, vz, r, lead=0.0):
    """``drive_row`` for driven particle d alone."""
    kind = int(table[d, KIND])
    if kinds >= 0 and kind != kinds:
        return 0.0
    i = int(table[d, COLUMN])
    value, _, second = drive_signal(time, table, d)
    inverse_mass = table[d, INVERSE_MASS]
    power = 0.0
    # float64 whatever the state's precision (numba's float() keeps a float32 a float32)
    speeds = (np.float64(vx[r, i]), np.float64(vy[r, i]), np.float64(0.0))
    count = 2
    if vz is not None:
        speeds = (speeds[0], speeds[1], np.float64(vz[r, i]))
        count = 3
    for c in range(count):
        speed = speeds[c]
        direction = table[d, DIRECTION + c]
        if kind == FORCE:
            force = table[d, AMPLITUDE] * value * direction
            row[c, i] += force * inverse_mass
            power += force * (speed + lead * float(row[c, i]))
        else:
            prescribed = table[d, AMPLITUDE] * second * direction
            power += (prescribed - float(row[c, i])) * (speed + lead * prescribed) / inverse_mass
            row[c, i] = prescribed
    return power


@njit(**_JIT)
def drive_row(j, time, table, kinds, row, vx, vy, vz, r, lead=0.0):
    """Apply the drives of the particles of row j at ``time`` to that row's accelerations
    ``row`` (3, nx) (m/s^2), the lattice forces' alone on entry: add a force's F / m, or replace
    the acceleration by a prescribed displacement's.  Only drives whose kind is ``kinds``
    (``FORCE``, ``DISPLACEMENT``, or ``EVERY_KIND``) act.  ``vx, vy, vz`` are the velocities of the
    same input (vz None in a planar scene), row j stored at index r; when they lag ``time`` by
    ``lead`` (s), as a leapfrog's half-step velocities do, the particle's velocity at ``time`` is
    taken as v + lead * a with its new acceleration a.  Returns the drive's power (W)."""
    power = 0.0
    for d in range(table.shape[0]):
        if int(table[d, ROW]) == j:
            power += _drive_one(d, time, table, kinds, row, vx, vy, vz, r, lead)
    return power


@njit(**_JIT)
def drive_rows(time, table, kinds, acceleration, velocity, lead=0.0):
    """``drive_row`` on full (dim, ny, nx) arrays, every driven particle; returns the power (W)
    (``lead`` as for ``drive_row``)."""
    power = 0.0
    for d in range(table.shape[0]):
        j = int(table[d, ROW])
        if velocity.shape[0] == 3:
            power += _drive_one(d, time, table, kinds, acceleration[:, j, :], velocity[0],
                                velocity[1], velocity[2], j, lead)
        else:
            power += _drive_one(d, time, table, kinds, acceleration[:, j, :], velocity[0],
                                velocity[1], None, j, lead)
    return power


@njit(**_JIT)
def save_driven(j, table, velocity, saved):
    """Keep the velocities (m/s) of row j's driven particles in ``saved`` (drives, 3) before a
    fused kick and drift that does not know them (``leapfrog_drive``)."""
    for d in range(table.shape[0]):
        if int(table[d, ROW]) == j:
            i = int(table[d, COLUMN])
            for c in range(velocity.shape[0]):
                saved[d, c] = velocity[c, j, i]


@njit(**_JIT)
def leapfrog_drive(j0, j1, time, dt, table, position, velocity, saved):
    """Correct the plain leapfrog kick and drift of the driven particles of rows j0 .. j1 - 1
    (v' = v + dt a, x' = x + dt v', a the lattice's, v in ``saved``) for their drives at
    ``time`` (s): v'' = v + dt a_driven, x'' = x' + dt (v'' - v').  Returns the drive's work
    (J): its force times the mean of the velocities before and after, times dt."""
    work = 0.0
    for d in range(table.shape[0]):
        j = int(table[d, ROW])
        if not j0 <= j < j1:
            continue
        i = int(table[d, COLUMN])
        value, _, second = drive_signal(time, table, d)
        inverse_mass = table[d, INVERSE_MASS]
        for c in range(position.shape[0]):
            lattice_velocity = float(velocity[c, j, i])
            before = saved[d, c]
            direction = table[d, DIRECTION + c]
            if int(table[d, KIND]) == FORCE:
                added = table[d, AMPLITUDE] * value * direction * inverse_mass
            else:
                added = table[d, AMPLITUDE] * second * direction - (lattice_velocity - before) / dt
            after = lattice_velocity + dt * added
            position[c, j, i] += dt * dt * added
            velocity[c, j, i] = after
            work += added / inverse_mass * 0.5 * (before + after) * dt
    return work
