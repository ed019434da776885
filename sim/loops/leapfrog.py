"""Numba loops of the undamped leapfrog (velocity Verlet between its first and last step, and
every splitting method of ``sim.integrators.splitting``), the fastest loop shape: each row's
forces and its kick and drift fused into one pass over the row.  A sweep kicks by its own kick
weight and drifts by its own drift weight (``sweeps``: (count, 2) kick and drift times dt, s):
Verlet's sweeps are all (dt, dt), a splitting method's follow its table.

Undamped nonlinear springs only (``sim.integrators.steppers.Verlet`` picks this loop for them).  The lattice
is cut into row blocks (``block_starts`` (blocks + 1,) int64: block b is rows block_starts[b] ..
block_starts[b + 1] - 1); each step first computes the springs across every block boundary (and
the wall springs at the bottom and top) from the unmoved positions, then sweeps the blocks
independently, so the result does not depend on how the rows are split into blocks.  Arrays as in
``sim.loops.row_sweep``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from sim.forces.absorbing_kicks import TWICE
from sim.forces.absorbing_layer import act_with, block_act
from sim.forces.drive_table import leapfrog_drive, save_driven
from sim.forces.springs import (
    components,
    horizontal_springs,
    particle_acceleration,
    scalar_terms,
    spring_between,
    vertical_springs,
)
from sim.forces.terms import inverse_mass_at
from sim.loops.stage_updates import kick_drift

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


class LeapfrogWork(NamedTuple):
    """The leapfrog's scratch, one slice per row block: ``boundary`` (blocks + 1, 3, nx) the
    springs below each block and the top wall's, computed before the blocks move; ``below``
    (blocks, 3, nx), ``horizontal`` (blocks, 3, nx + 1) the sweeps' buffers."""

    boundary: np.ndarray
    below: np.ndarray
    horizontal: np.ndarray

@njit(**_JIT)
def leapfrog_rows(j0, j1, kick, drift, x, y, z, vx, vy, vz, terms, parameters, position,
                  velocity, work, b, time, drive, saved, totals):
    """One leapfrog kick and drift (v += kick a(x); x += drift v) of rows j0 .. j1-1 (block b),
    with each row's forces and update fused into one pass over it: the springs and the sum of
    the forces on a particle are ``sim.forces.springs``' (the terms the registry lets ride this
    loop: none that depends on the velocities, ``sim.forces.registry.leapfrog``).

    Of the ``LeapfrogWork`` ``work``: ``below[b]`` holds the forces of the springs below row j0
    on entry (it is reused as the running buffer); ``boundary[b + 1]`` those of the springs above
    row j1 - 1, computed before the sweep moved anything (the top wall springs, or a block
    boundary when the lattice is swept as several row blocks in parallel); ``horizontal[b]`` is
    scratch.  Every other spring is computed here from positions that have not moved yet.
    ``terms``: the scene's ``sim.forces.terms.Terms``; ``x`` .. ``vz`` the state's
    components (``z``, ``vz`` None in a planar scene).  The one kernel with more than 14
    arguments: numba compiles out the third component only when ``z`` is an argument of the
    function that tests it, and the row's pass must stay in this function (as a function of its
    own, called per row, the float32 sweep ran 15 % slower).

    The drive table (``sim.forces.drive_table``, None compiles it out) acts last: the driven
    particles get their drive at ``time`` (s; velocities kept in ``saved`` (drives, 3) before
    their row's pass; Verlet's sweeps only, kick = drift = dt).  ``totals`` (2,) receives the
    drive's work (J).
    """
    below, above_last, horizontal = work.below[b], work.boundary[b + 1], work.horizontal[b]
    zero = type(kick)(0.0)
    scalars = scalar_terms(terms, zero)
    law = scalars[0]  # the springs' law and dashpot, as the spring functions take them
    still = (zero, zero, zero)  # no term that reads the velocities rides this loop
    nx = x.shape[1]
    for j in range(j0, j1):
        if drive is not None:
            save_driven(j, drive, velocity, saved)
        horizontal_springs(j, x, y, z, vx, vy, vz, law[0], parameters, law[1], horizontal)
        given = j + 1 == j1
        for i in range(nx):
            w = inverse_mass_at(terms.uniform_inverse_mass, terms.inverse_mass, j, i)
            if z is None:
                if given:
                    above = (above_last[0, i], above_last[1, i], zero, 0.0)
                else:
                    above = spring_between((x[j, i], y[j, i], zero, zero, zero, zero),
                                           (x[j + 1, i], y[j + 1, i], zero, zero, zero, zero), 1,
                                           law, parameters)
                ax, ay, _ = particle_acceleration(
                    (horizontal[0, i], horizontal[1, i], zero),
                    (horizontal[0, i + 1], horizontal[1, i + 1], zero),
                    (below[0, i], below[1, i], zero), above, still, scalars, w,
                )
            else:
                if given:
                    above = (above_last[0, i], above_last[1, i], above_last[2, i], 0.0)
                else:
                    above = spring_between((x[j, i], y[j, i], z[j, i], zero, zero, zero),
                                           (x[j + 1, i], y[j + 1, i], z[j + 1, i], zero, zero,
                                            zero), 1, law, parameters)
                ax, ay, az = particle_acceleration(
                    (horizontal[0, i], horizontal[1, i], horizontal[2, i]),
                    (horizontal[0, i + 1], horizontal[1, i + 1], horizontal[2, i + 1]),
                    (below[0, i], below[1, i], below[2, i]), above, still, scalars, w,
                )
                z[j, i], vz[j, i] = kick_drift(z[j, i], vz[j, i], az, kick, drift)
                below[2, i] = above[2]
            x[j, i], vx[j, i] = kick_drift(x[j, i], vx[j, i], ax, kick, drift)
            y[j, i], vy[j, i] = kick_drift(y[j, i], vy[j, i], ay, kick, drift)
            below[0, i] = above[0]
            below[1, i] = above[1]
    if drive is not None:
        totals[0] += leapfrog_drive(j0, j1, time, kick, drive, position, velocity, saved)


@njit(**_JIT)
def leapfrog_steps(sweeps, terms, parameters, position, velocity, block_starts, work, time=0.0,
                   drive=None, saved=None, sponge=None, totals=None):
    """One leapfrog sweep per row of ``sweeps`` ((count, 2): kick by sweeps[s, 0], drift by
    sweeps[s, 1], in the state's precision) of undamped nonlinear springs, in row blocks.

    The springs below each block (and the top wall springs) go into ``work.boundary`` before the
    blocks are swept (``leapfrog_rows``; ``work`` a ``LeapfrogWork``).  This one runs the blocks
    one after the other on the calling thread; ``leapfrog_steps_parallel`` runs them on numba's
    threads and computes the same numbers.  The drive as in ``leapfrog_rows`` (the kick of sweep
    s at ``time`` + s dt, Verlet's sweeps); the absorbing layer (``sponge``:
    ``sim.forces.absorbing_layer.MatchedLayer.arguments``) acts over dt / 2 twice between steps
    (as at the end of one step and the start of the next) at the positions each sweep kicks
    with, before the sweep: its kick does not depend on the velocities, so the sweep's drift
    carries it.  ``totals`` (blocks, 2) receives the drive's work (per block) and the layer's
    take (J, in ``totals[0, 1]``).
    """
    blocks = block_starts.size - 1
    for step in range(sweeps.shape[0]):
        kick, drift = sweeps[step, 0], sweeps[step, 1]
        if sponge is not None:
            totals[0, 1] += act_with(0.5 * float(drift), 0.5 * float(drift), TWICE, position,
                                     velocity, sponge, parameters)
        for b in range(blocks + 1):
            _boundary_springs(b, terms, position, velocity, parameters, block_starts,
                              work.boundary)
        for b in range(blocks):
            _leapfrog_block(b, kick, drift, terms, parameters, position, velocity, block_starts,
                            work, time + step * float(drift), drive, saved, totals)


@njit(parallel=True, **_JIT)
def leapfrog_steps_parallel(sweeps, terms, parameters, position, velocity, block_starts, work,
                            time=0.0, drive=None, saved=None, sponge=None, totals=None):
    """``leapfrog_steps`` with the boundary springs and the row blocks spread over numba's
    threads (``prange``; ``numba.set_num_threads`` sets how many), and the layer's action too,
    in the same parallel loop as the boundary springs (nothing moves while it acts): each
    block's side strips, the bands in the first and last blocks (``block_act``; the layer's
    record with scratch for every block, ``MatchedLayer.arguments(jobs=blocks)``, the springs'
    ``parameters`` given apart as everywhere).  The loop bodies are functions of their own:
    numba's parallel transformation of the inlined 3-D body read stale out-of-plane components
    (runs differed from one thread and blew up)."""
    blocks = block_starts.size - 1
    for step in range(sweeps.shape[0]):
        kick, drift = sweeps[step, 0], sweeps[step, 1]
        half = 0.5 * float(drift)
        taken = 0.0
        for b in prange(blocks + 1):  # the layer's part of each block, and the springs below it
            if sponge is not None and b < blocks:
                taken += block_act(b, block_starts, half, half, TWICE, position, velocity, sponge,
                                   parameters)
            _boundary_springs(b, terms, position, velocity, parameters, block_starts,
                              work.boundary)
        if sponge is not None:
            totals[0, 1] += taken
        for b in prange(blocks):
            _leapfrog_block(b, kick, drift, terms, parameters, position, velocity, block_starts,
                            work, time + step * float(drift), drive, saved, totals)


@njit(**_JIT)
def _boundary_springs(b, terms, position, velocity, parameters, block_starts, boundary):
    """The springs below row block_starts[b] into boundary[b] (a function of its own, so that
    numba's parallel transformation leaves its body alone)."""
    x, y, z = components(terms.out_of_plane, position)
    vx, vy, vz = components(terms.out_of_plane, velocity)
    vertical_springs(block_starts[b], position.shape[1], x, y, z, vx, vy, vz, terms, parameters,
                     boundary[b])


@njit(**_JIT)
def _leapfrog_block(b, kick, drift, terms, parameters, position, velocity, block_starts, work,
                    time, drive, saved, totals):
    """Leapfrog kick and drift of row block b (``leapfrog_steps``)."""
    below, boundary = work.below[b], work.boundary[b]
    for c in range(below.shape[0]):  # a copy written out: an array assignment compiles numba's
        for i in range(below.shape[1]):  # shape-mismatch error message, 2 s of compiling
            below[c, i] = boundary[c, i]
    x, y, z = components(terms.out_of_plane, position)
    vx, vy, vz = components(terms.out_of_plane, velocity)
    leapfrog_rows(block_starts[b], block_starts[b + 1], kick, drift, x, y, z, vx, vy, vz, terms,
                  parameters, position, velocity, work, b, time, drive, saved, totals[b])
