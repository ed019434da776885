"""One step of a Runge-Kutta method over a block of rows, as a wavefront that streams the state once.

The stages run as a wavefront over the rows: at sweep position t, stage s works on row t - s,
which needs rows t - s and t - s + 1 of its input, finished one iteration earlier by stage
s - 1.  Each stage overwrites the stage state of a row with the next stage's input once it no
longer needs it (``sim.loops.stage_updates.stage_update``), and the last stage writes the new (x, v) of
rows every stage has left behind.  So a step streams the state through the cache once instead
of once per stage, and the stage arrays are ring buffers of a few rows, row j kept at j % rows.

The method is its table (``sim.integrators.butcher.ButcherTable.coefficients``: stage times c, the
sub-diagonal a, weights b, one row each); one compiled wavefront serves every table.  The whole lattice
on one thread is the block of all rows.  A block of rows j0 .. j1-1 on one of several threads
extends the wavefront by ``stages - 1`` halo rows: stage s also runs on the ``stages - 1 - s``
rows beyond each inner block edge, so the last stage has its inputs for the block's own rows
without waiting for another block.  A block reads, never writes, the state within ``halo + 1``
rows of an inner edge during the step: those rows' new state goes to the block's deferred rows
(``deferred_slot``), copied into the state once every block is done (``write_deferred``).

Arrays as in ``sim.loops.stage_updates``; ``powers`` (stages,) receives each stage's dissipated power
(W) of the springs of the block's own rows.  With a drive table (``sim.forces.drive_table``; None
compiles it out) each stage's row accelerations get the drives at the stage's time, and
``drive_powers`` (stages,) receives the power they feed into the block's own rows.
"""

from __future__ import annotations

from numba import njit

from sim.forces.drive_table import drive_row
from sim.forces.springs import row_accelerations, vertical_springs
from sim.loops.stage_updates import components, stage_time, stage_update, stages

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

BLOCK_RING = 8
"""Rows kept by a block's ring-buffer stage arrays, at least ``2 * stages`` (``block_ring``); the
one block of a whole lattice needs the number of stages."""


def block_ring(stage_count: int) -> int:
    """Rows of a block's ring-buffer stage arrays for a method of ``stage_count`` stages."""
    return max(BLOCK_RING, 2 * stage_count)


def halo_rows(stage_count: int) -> int:
    """Rows beyond its own that a block's wavefront recomputes on each side (stage s on
    ``stage_count - 1 - s`` of them)."""
    return stage_count - 1


@njit(**_JIT)
def deferred_slot(j, j0, j1, ny, halo):
    """Slot (0 .. 2 halo + 1) in a block's deferred rows of row j, or -1: the new state of the
    halo + 1 rows at each inner block edge is written after all blocks are done, since the
    neighbouring block's halo reads them."""
    if j0 > 0 and j < j0 + halo + 1:
        return j - j0
    if j1 < ny and j >= j1 - halo - 1:
        return halo + 1 + j - (j1 - halo - 1)
    return -1


@njit(**_JIT)
def write_deferred(j0, j1, halo, position, velocity, deferred_position, deferred_velocity):
    """Copy a block's deferred rows (``deferred_slot``) into the state."""
    dim, ny, nx = position.shape
    for j in range(j0, j1):
        slot = deferred_slot(j, j0, j1, ny, halo)
        if slot >= 0:
            for c in range(dim):
                for i in range(nx):
                    position[c, j, i] = deferred_position[c, slot, i]
                    velocity[c, j, i] = deferred_velocity[c, slot, i]


@njit(**_JIT)
def _stage_forces(j, first, ny, x, y, z, vx, vy, vz, linear, inverse_mass, uniform_inverse_mass,
                  parameters, dashpot, drag, gravity, below, above, horizontal, row, powers, stage):
    """Accelerations of row j of a stage input into ``row``; on the stage's first row also the
    springs below it (their power counted in ``powers`` when they are the bottom wall's).
    Returns the power of the row's other springs and drag (W)."""
    if j == first:
        p = vertical_springs(j, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, below)
        if j == 0:
            powers[stage] += p
    return row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear, parameters,
                             dashpot, drag, gravity, below, above, horizontal, row,
                             uniform_inverse_mass)


@njit(**_JIT)
def wavefront(
    table, j0, j1, dt, linear, out_of_plane, position, velocity, inverse_mass,
    uniform_inverse_mass, parameters, dashpot, drag, gravity, stage_position, stage_velocity,
    sum_position, sum_velocity, deferred_position, deferred_velocity, vertical, horizontal, row,
    powers, time=0.0, drive=None, drive_powers=None,
):
    """One step of the method of ``table`` (``sim.integrators.butcher.ButcherTable.coefficients``) on
    rows j0 .. j1-1.

    Stage arrays ``stage_*``, ``sum_*`` (dim, rows, nx) are this block's ring buffers;
    ``deferred_*`` (dim, 2 halo + 2, nx) its deferred rows (unused when the block is the whole
    lattice); ``vertical`` (stages, 2, ``ROWS``, nx), ``horizontal`` (3, nx + 1) and ``row`` (3, nx)
    scratch buffers.
    """
    count = stages(table)
    halo = count - 1
    x, y, z = components(out_of_plane, position)
    vx, vy, vz = components(out_of_plane, velocity)
    xs, ys, zs = components(out_of_plane, stage_position)
    vxs, vys, vzs = components(out_of_plane, stage_velocity)
    ny = position.shape[1]
    ring = stage_position.shape[1]
    powers[:] = 0.0
    if drive is not None:
        drive_powers[:] = 0.0
    for t in range(max(j0 - halo, 0), j1 + halo):
        for stage in range(count):
            j = t - stage
            first = max(j0 - halo + stage, 0)
            if j < first or j >= min(j1 + halo - stage, ny):
                continue
            below = vertical[stage, j % 2]
            above = vertical[stage, (j + 1) % 2]
            # one call site per piece (not one per branch): each call site is compiled anew
            if stage == 0:  # the stage input is the state itself
                sx, sy, sz, svx, svy, svz, slot = x, y, z, vx, vy, vz, j
            else:
                sx, sy, sz, svx, svy, svz, slot = xs, ys, zs, vxs, vys, vzs, j % ring
            p = _stage_forces(j, first, ny, sx, sy, sz, svx, svy, svz, linear, inverse_mass,
                              uniform_inverse_mass, parameters, dashpot, drag, gravity, below,
                              above, horizontal, row, powers, stage)
            if drive is not None:
                at = time + stage_time(table, stage) * dt
                q = drive_row(j, at, drive, -1, row, svx, svy, svz, slot)
                if j >= j0 and j < j1:
                    drive_powers[stage] += q
            if j >= j0 and j < j1:
                powers[stage] += p
            deferred = deferred_slot(j, j0, j1, ny, halo)
            if deferred < 0:
                new_position, new_velocity, k = position, velocity, j
            else:
                new_position, new_velocity, k = deferred_position, deferred_velocity, deferred
            stage_update(table, stage, j, j % ring, dt, position, velocity, row, stage_velocity,
                         stage_position, stage_velocity, sum_position, sum_velocity, new_position,
                         new_velocity, k)
