"""The matched layer's record, its parts and the kick of one particle given its springs' forces
(``sim.forces.absorbing_layer`` for the layer's equations, the springs it reads and its action).

The layer is four parts: the left and right side strips (the x-layer, over the strips' columns)
and the bottom and top bands (the y-layer, over the bands' rows); a corner particle is in a
strip and a band, and its two kicks add.  A part is a stack of lines: a strip's lines are its
columns, a band's its rows.  Each line is damped along the axis across the lines (x for a strip,
y for a band); its particles' low and high springs along that axis (left and right, or below and
above) join it to the lines on either side, and the springs along the line add their net force.
So one computation, over a line at a time, serves every part.

The action (``sim.forces.absorbing_layer.act_part``) counts the kinetic energy each kick takes
out (J) on the velocities ``lead`` seconds later under the lattice's forces (a leapfrog's
half-step velocities are measured half a step on, at the whole step); kicks applied one after
another measure from the velocity the previous one left, so their takes add up exactly.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from sim.forces.springs import site, spring_force

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

PARTS = ("left", "right", "bottom", "top")

TWICE = np.bool_(True)
"""``second_half`` for the action between two steps (both halves), as the step loops pass it: a
value, not the constant True, which numba would compile as a type of its own (Literal[bool])
beside the False of the single half before and after the steps, the layer's whole action twice."""
"""The layer's parts, in the order they act (rows of ``geometry``)."""
LINES, LENGTH, FIRST, AXIS, HELD, SLOT, FACTOR = range(7)
"""Columns of the layer's ``geometry`` (parts, 7) int64: a part's number of lines (0: no such
part), the particles in a line (ny for a strip, nx for a band), its first line (column or row),
the axis it damps (0: x, 1: y), and where its held forces, its particles (phi, masses) and its
lines' factors start in the flat fields."""


class LayerArguments(NamedTuple):
    """What the layer's kernels read, as one named record (``MatchedLayer.arguments``).

    ``geometry`` (parts, 7) int64 (``LINES`` .. ``FACTOR``); the fields, flat over the parts:
    ``held`` (dim, sum of (lines + 1) * length) the held forces of the springs across the lines,
    line after line (N), ``relaxed`` (dim, particles) phi (N); ``factors`` (2, sum of lines + 1)
    exp(-sigma tau / 2) of the springs across the lines and of the lines' particles; ``mass``,
    ``inverse_mass`` (particles,) kg, 1/kg.  ``out_of_plane``, ``linearised`` compile-time flags
    (None or True); ``gravity`` (3,) or None.  The springs' ``SpringParameters`` are not in it:
    the layer's kernels take the step loop's own (its 1/sqrt variant), so that the loop and the
    half actions around it share one compiled kernel.  Scratch, one per thread: ``block`` (jobs,
    3, lines + 2, length) in the state's precision, a strip's positions and its neighbours',
    column by column (``sim.forces.absorbing_layer``); ``across`` (jobs, 2, 3, length) two lines
    of springs across, ``along`` (jobs, 3, length + 1) one along a line, ``kicks`` (jobs, dim,
    length).
    """

    geometry: object
    held: object
    relaxed: object
    factors: object
    mass: object
    inverse_mass: object
    out_of_plane: object
    linearised: object
    gravity: object
    block: object
    across: object
    along: object
    kicks: object


SHIFT = 0.02
"""The layer's frequency shift, in units of each field's own rate sigma: a held force relaxes as
h' = sigma (f - h) - SHIFT sigma h, toward f / (1 + SHIFT) at the rate (1 + SHIFT) sigma (its
factor e = exp(-(1 + SHIFT) sigma tau / 2), ``MatchedLayer.factors``), and phi likewise.  In the
frequency domain the stretch becomes s = 1 + sigma / (SHIFT sigma + i omega): unchanged for waves
with omega >> SHIFT sigma, and finite at omega = 0.  Without it (0) the layer forgets any static
stress in it (h -> f), so a displacement or velocity put into the layer from outside (an initial
state, a poke) has nothing to restore it: the layer's zero-frequency modes grow linearly in time
and the layer drifts as a piston, feeding energy into the lattice."""
RETAINED = 1.0 / (1.0 + SHIFT)
"""The part of its spring's force a held force tends to (f / (1 + SHIFT))."""


@njit(**_JIT)
def relax(force, held, factor):
    """A held force relaxed toward the part ``RETAINED`` of the spring's force:
    f' + (h - f') e, f' = f / (1 + SHIFT)."""
    target = force * RETAINED
    return target + (held - target) * factor


@njit(**_JIT)
def rest_tension(linearised, parameters):
    """The springs' tension at rest (N): the force of an x-spring between two rest sites."""
    return float(spring_force(site(0, 0, parameters), site(1, 0, parameters), 0, linearised,
                              parameters, None)[0])


@njit(**_JIT)
def half_action(force, h_low, h_high, phi, e_node, tau, inverse_mass):
    """One half action of a particle along one axis, its springs' held forces ``h_low`` and
    ``h_high`` (below or left, above or right) relaxed as it reads them: phi relaxed toward what
    they leave of the net ``force`` over tau / 2, the kick by tau, phi relaxed again.  Returns
    (phi, kick).  The kicks write their half actions out one after the other, not as a loop:
    LLVM vectorises only innermost loops, and a loop over the halves inside the loop over
    particles kept the particles' loop scalar (3.6x slower on the flagship's side strips)."""
    holding = h_high - h_low
    target = force - holding
    phi = relax(target, phi, e_node)
    kick = -tau * (holding + phi) * inverse_mass
    return relax(target, phi, e_node), kick


@njit(**_JIT)
def particle_kick(f_low, f_high, h_low, h_high, phi, e_low, e_high, e_node, tau, inverse_mass,
                  second_half):
    """A particle's kick (m/s) along its part's axis: per half action, its springs' held forces
    ``h_low``, ``h_high`` (N) relaxed toward the springs' ``f_low``, ``f_high`` by their factors
    ``e_low``, ``e_high`` before the kick (a held force relaxes toward a force that stays put, so
    after n relaxations it is f + (h - f) e^n: the second half reads it after three), phi
    relaxed by ``e_node`` around it; twice when ``second_half`` is True, once when False.
    Returns (phi, kick)."""
    force = f_high - f_low
    phi, kick = half_action(force, relax(f_low, h_low, e_low), relax(f_high, h_high, e_high),
                            phi, e_node, tau, inverse_mass)
    if second_half:
        later_low = e_low * e_low * e_low
        later_high = e_high * e_high * e_high
        phi, more = half_action(force, relax(f_low, h_low, later_low),
                                relax(f_high, h_high, later_high), phi, e_node, tau,
                                inverse_mass)
        kick += more
    return phi, kick


@njit(**_JIT)
def held_factor(factor, second_half):
    """What a held force's factor becomes over the whole action: two relaxations per half."""
    total = factor * factor
    if second_half:
        total = total * total
    return total
