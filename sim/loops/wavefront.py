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

Arrays as in ``sim.loops.stage_updates``, a block's work arrays in one ``BlockWork`` record;
``powers`` (stages,) receives each stage's dissipated power (W) of the springs of the block's own
rows.  With a drive table (``sim.forces.drive_table``; None
compiles it out) each stage's row accelerations get the drives at the stage's time, and
``drive_powers`` (stages,) receives the power they feed into the block's own rows.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from sim.forces.drive_table import EVERY_KIND, drive_row
from sim.forces.springs import row_accelerations, vertical_springs
from sim.loops.stage_updates import Fields, components, stage_time, stage_update, stages

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

BLOCK_RING = 8
"""Rows kept by a block's ring-buffer stage arrays, at least ``2 * stages`` (``block_ring``); the
one block of a whole lattice needs the number of stages."""


class BlockWork(NamedTuple):
    """The work arrays of one block's wavefront (``block_work`` takes block b's out of arrays for
    every block).

    ``stage`` (``Fields``, each (dim, ring, nx)) the stage inputs as ring buffers; ``sums``
    (``Fields``, likewise) the method's running sums; ``deferred`` (``Fields``, each
    (dim, 2 halo + 2, nx)) the deferred rows (unused when the block is the whole lattice);
    scratch: ``vertical`` (stages, 2, ``BUFFER_ROWS``, nx) the springs below and above each stage's row,
    ``horizontal`` (3, nx + 1), ``row`` (3, nx) accelerations.
    """

    stage: Fields
    sums: Fields
    deferred: Fields
    vertical: np.ndarray
    horizontal: np.ndarray
    row: np.ndarray


@njit(**_JIT)
def block_work(stage_input, sums, deferred, vertical, horizontal, row, b):
    """Block b's ``BlockWork`` out of arrays with a leading axis of blocks (``Fields`` for the
    stage inputs, the sums and the deferred rows)."""
    return BlockWork(Fields(stage_input.position[b], stage_input.velocity[b]),
                     Fields(sums.position[b], sums.velocity[b]),
                     Fields(deferred.position[b], deferred.velocity[b]),
                     vertical[b], horizontal[b], row[b])


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
def write_deferred(j0, j1, halo, position, velocity, deferred):
    """Copy a block's deferred rows (``deferred_slot``; ``deferred`` a ``Fields``) into the
    state."""
    dim, ny, nx = position.shape
    for j in range(j0, j1):
        slot = deferred_slot(j, j0, j1, ny, halo)
        if slot >= 0:
            for c in range(dim):
                for i in range(nx):
                    position[c, j, i] = deferred.position[c, slot, i]
                    velocity[c, j, i] = deferred.velocity[c, slot, i]


@njit(**_JIT)
def _stage_forces(j, first, ny, ends, terms, parameters, below, above, horizontal, row, powers,
                  stage):
    """Accelerations of row j of a stage input (``ends``: its components x, y, z, vx, vy, vz)
    into ``row``; on the stage's first row also the springs below it (their power counted in
    ``powers`` when they are the bottom wall's).  Returns the power of the row's other springs
    and drag (W)."""
    x, y, z, vx, vy, vz = ends
    if j == first:
        p = vertical_springs(j, ny, x, y, z, vx, vy, vz, terms, parameters, below)
        if j == 0:
            powers[stage] += p
    return row_accelerations(j, ny, x, y, z, vx, vy, vz, terms, parameters, below, above,
                             horizontal, row)


@njit(**_JIT)
def wavefront(table, j0, j1, dt, terms, parameters, position, velocity, work, powers, time=0.0,
              drive=None, drive_powers=None):
    """One step of the method of ``table`` (``sim.integrators.butcher.ButcherTable.coefficients``) on
    rows j0 .. j1-1 of the state (``position``, ``velocity``), with the block's ``BlockWork``
    ``work``; ``terms`` and ``parameters`` as for ``sim.forces.springs.row_accelerations``.
    """
    count = stages(table)
    halo = count - 1
    out_of_plane = terms.out_of_plane
    x, y, z = components(out_of_plane, position)
    vx, vy, vz = components(out_of_plane, velocity)
    xs, ys, zs = components(out_of_plane, work.stage.position)
    vxs, vys, vzs = components(out_of_plane, work.stage.velocity)
    state = Fields(position, velocity)
    ny = position.shape[1]
    ring = work.stage.position.shape[1]
    powers[:] = 0.0
    if drive is not None:
        drive_powers[:] = 0.0
    for t in range(max(j0 - halo, 0), j1 + halo):
        for stage in range(count):
            j = t - stage
            first = max(j0 - halo + stage, 0)
            if j < first or j >= min(j1 + halo - stage, ny):
                continue
            below = work.vertical[stage, j % 2]
            above = work.vertical[stage, (j + 1) % 2]
            # one call site per piece (not one per branch): each call site is compiled anew
            if stage == 0:  # the stage input is the state itself
                ends, slot = (x, y, z, vx, vy, vz), j
            else:
                ends, slot = (xs, ys, zs, vxs, vys, vzs), j % ring
            p = _stage_forces(j, first, ny, ends, terms, parameters, below, above,
                              work.horizontal, work.row, powers, stage)
            if drive is not None:
                at = time + stage_time(table, stage) * dt
                q = drive_row(j, at, drive, EVERY_KIND, work.row, ends[3], ends[4], ends[5], slot)
                if j >= j0 and j < j1:
                    drive_powers[stage] += q
            if j >= j0 and j < j1:
                powers[stage] += p
            deferred = deferred_slot(j, j0, j1, ny, halo)
            if deferred < 0:
                new, k = state, j
            else:
                new, k = work.deferred, deferred
            stage_update(table, stage, j, j % ring, dt, state, work.row, work.stage.velocity,
                         work.stage, work.sums, new, k)
