"""Numba step loops on several threads: the lattice cut into row blocks, one block per thread.

The Runge-Kutta methods (any table, ``sim.integrators.butcher``) on lattices thick enough run one
wavefront per block with halo rows (``runge_kutta_blocks``, see ``sim.loops.wavefront``): one
parallel sweep per step.  The other loops (Euler, damped or linear Verlet, and the Runge-Kutta
methods on lattices too thin for halos) run each force
evaluation as one phase over all row blocks in parallel (``prange`` over blocks,
``numba.set_num_threads`` sets how many threads): a phase reads only arrays that no block writes
during it and writes only its own rows, so the blocks need no synchronisation inside a phase.
Stage states therefore live in full (dim, ny, nx) arrays.  Per particle the arithmetic is the
same functions as the one-thread loops (``sim.loops.stage_updates``), so positions and velocities agree
with one thread to round-off (usually bitwise); the dissipated energy is summed block by block
and differs in the last bits.  The undamped leapfrog has its own blocks (``sim.loops.leapfrog``).

``block_starts`` (blocks + 1,) int64: block b is rows block_starts[b] .. block_starts[b + 1] - 1.
Arguments otherwise as in ``sim.loops.row_sweep`` (``terms`` a ``sim.forces.terms.Terms``).  The
``prange`` bodies only call functions of whole arrays: numba's parallel transformation of bodies
that use the unpacked (x, y, z) components read stale out-of-plane components in 3-D.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sim.forces.drive_table import EVERY_KIND, drive_row
from sim.forces.springs import BUFFER_ROWS, row_accelerations, vertical_springs
from sim.loops.stage_updates import (
    Fields,
    components,
    dissipated_energy,
    euler_update,
    force_rows,
    stage_time,
    stage_update,
    stages,
    sweep_buffers,
    verlet_drift,
)
from sim.loops.wavefront import block_work, wavefront, write_deferred

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(parallel=True, **_JIT)
def accelerations_parallel(terms, parameters, position, velocity, acceleration, block_starts):
    """``accelerations`` with the row blocks on numba's threads; returns the dissipated power (W)."""
    blocks = block_starts.size - 1
    powers = np.zeros(blocks)
    for b in prange(blocks):
        powers[b] = force_rows(block_starts[b], block_starts[b + 1], terms, parameters, position,
                               velocity, acceleration, None, velocity)
    return powers.sum()


@njit(**_JIT)
def _euler_rows(j0, j1, dt, position, velocity, acceleration):
    for j in range(j0, j1):
        euler_update(j, dt, position, velocity, acceleration, j)


@njit(parallel=True, **_JIT)
def euler_steps_parallel(n, dt, terms, parameters, position, velocity, acceleration, block_starts):
    """``euler_steps`` in two phases per step: accelerations of all row blocks in parallel into
    ``acceleration`` (dim, ny, nx), then x += dt v; v += dt a over the blocks in parallel."""
    blocks = block_starts.size - 1
    powers = np.zeros(blocks)
    dissipated = 0.0
    for _ in range(n):
        for b in prange(blocks):
            powers[b] = force_rows(block_starts[b], block_starts[b + 1], terms, parameters,
                                   position, velocity, acceleration, None, velocity)
        for b in prange(blocks):
            _euler_rows(block_starts[b], block_starts[b + 1], dt, position, velocity, acceleration)
        dissipated += dt * powers.sum()
    return dissipated


@njit(**_JIT)
def _verlet_drift_rows(j0, j1, dt, position, velocity, acceleration, predicted_velocity, damped):
    for j in range(j0, j1):
        verlet_drift(j, dt, position, velocity, acceleration, predicted_velocity, damped)


@njit(parallel=True, **_JIT)
def verlet_steps_parallel(n, dt, terms, parameters, position, velocity, acceleration,
                          previous_power, predicted_velocity, block_starts):
    """Velocity Verlet steps (damped scenes and linearised springs) in two phases per step: half
    kick and drift of every row (and the predicted velocity v + dt a when damped), then the new
    accelerations and the second half kick, each phase over the row blocks in parallel.
    ``acceleration`` holds a(x, v) on entry and on exit, as for ``verlet_steps``.
    Returns (dissipated, power)."""
    damped = terms.damped is not None
    force_velocity = predicted_velocity if damped else velocity
    blocks = block_starts.size - 1
    powers = np.zeros(blocks)
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    power = previous_power
    for _ in range(n):
        for b in prange(blocks):
            _verlet_drift_rows(block_starts[b], block_starts[b + 1], dt, position, velocity,
                               acceleration, predicted_velocity, damped)
        for b in prange(blocks):
            powers[b] = force_rows(block_starts[b], block_starts[b + 1], terms, parameters,
                                   position, force_velocity, acceleration, half, velocity)
        new_power = powers.sum()
        dissipated += half * (power + new_power)
        power = new_power
    return dissipated, power


@njit(**_JIT)
def _stage_rows(table, stage, j0, j1, dt, terms, parameters, state, source, target, sums, time,
                drive, drive_power):
    """One stage of the method of ``table`` on rows j0 .. j1-1: the forces of the stage input
    (``source``, full arrays) and ``stage_update`` with the next input into ``target`` (``state``,
    ``source``, ``target`` and ``sums`` are ``Fields``).  Reads the state's own rows only, except
    as the input of stage 0.  Returns the dissipated power (W) as ``force_rows`` counts it; with a
    drive table the drives act at ``time`` (s) and ``drive_power[0]`` receives their power (W)."""
    xs, ys, zs = components(terms.out_of_plane, source.position)
    vxs, vys, vzs = components(terms.out_of_plane, source.velocity)
    ny = state.position.shape[1]
    below, above, horizontal, row = sweep_buffers(state.position)
    power = vertical_springs(j0, ny, xs, ys, zs, vxs, vys, vzs, terms, parameters, below)
    if j0 > 0:
        power = 0.0
    for j in range(j0, j1):
        power += row_accelerations(j, ny, xs, ys, zs, vxs, vys, vzs, terms, parameters, below,
                                   above, horizontal, row)
        if drive is not None:
            drive_power[0] += drive_row(j, time, drive, EVERY_KIND, row, vxs, vys, vzs, j)
        below, above = above, below
        stage_update(table, stage, j, j, dt, state, row, source.velocity, target, sums, state, j)
    return power


@njit(parallel=True, **_JIT)
def runge_kutta_phases(table, n, dt, terms, parameters, position, velocity, stage_input,
                       next_input, sums, block_starts, time=0.0, drive=None, drive_work=None):
    """n steps of the method of ``table`` (``sim.integrators.butcher.ButcherTable.coefficients``) with
    each stage one parallel phase over the row blocks.

    The work arrays are full (dim, ny, nx) arrays (``Fields``): stage inputs alternate between
    ``stage_input`` and ``next_input`` so that no phase overwrites what another block still reads
    (a 2-stage method never uses ``next_input``); ``sums`` the running sums."""
    blocks = block_starts.size - 1
    count = stages(table)
    state = Fields(position, velocity)
    powers = np.zeros((count, blocks))
    drive_powers = np.zeros((count, blocks, 1))
    dissipated = 0.0
    for step in range(n):
        for stage in range(count):
            source, target = stage_input, next_input  # odd stages
            if stage == 0:
                source, target = state, stage_input
            elif stage % 2 == 0:
                source, target = next_input, stage_input
            # arrays, not records, into the parallel loop: numba's parallel lowering looks for
            # the one place a record it takes was made, and these have three
            source_position, source_velocity = source
            target_position, target_velocity = target
            for b in prange(blocks):
                powers[stage, b] = _stage_rows(
                    table, stage, block_starts[b], block_starts[b + 1], dt, terms, parameters,
                    state, Fields(source_position, source_velocity),
                    Fields(target_position, target_velocity), sums,
                    time + (step + stage_time(table, stage)) * float(dt), drive,
                    drive_powers[stage, b],
                )
        dissipated += dissipated_energy(table, dt, powers.sum(axis=1))
        if drive is not None:
            drive_work[0] += dissipated_energy(table, dt, drive_powers.sum(axis=1)[:, 0])
            drive_powers[:] = 0.0
    return dissipated


@njit(parallel=True, **_JIT)
def runge_kutta_blocks(table, n, dt, terms, parameters, position, velocity, stage_input, sums,
                       deferred, block_starts, time=0.0, drive=None, drive_work=None):
    """n steps of the method of ``table`` with each row block's wavefront (``sim.loops.wavefront``) on one of
    numba's threads: one parallel sweep per step plus the copy of the deferred edge rows.

    Work arrays per block (``Fields`` whose arrays have a leading axis of blocks): the stage
    inputs ``stage_input`` and the running ``sums`` (blocks, dim,
    ``wavefront.block_ring(stages)``, nx), the ``deferred`` rows (blocks, dim, 2 * stages, nx).
    Blocks need at least 2 * stages rows."""
    blocks = block_starts.size - 1
    count = stages(table)
    nx = position.shape[2]
    vertical = np.empty((blocks, count, 2, BUFFER_ROWS, nx), position.dtype)
    horizontal = np.empty((blocks, 3, nx + 1), position.dtype)
    row = np.empty((blocks, 3, nx), position.dtype)
    powers = np.zeros((blocks, count))
    drive_powers = np.zeros((blocks, count))
    dissipated = 0.0
    for step in range(n):
        for b in prange(blocks):
            wavefront(table, block_starts[b], block_starts[b + 1], dt, terms, parameters,
                      position, velocity,
                      block_work(stage_input, sums, deferred, vertical, horizontal, row, b),
                      powers[b], time + step * float(dt), drive, drive_powers[b])
        for b in prange(blocks):
            write_deferred(block_starts[b], block_starts[b + 1], count - 1, position, velocity,
                           Fields(deferred.position[b], deferred.velocity[b]))
        dissipated += dissipated_energy(table, dt, powers.sum(axis=0))
        if drive is not None:
            drive_work[0] += dissipated_energy(table, dt, drive_powers.sum(axis=0))
    return dissipated
