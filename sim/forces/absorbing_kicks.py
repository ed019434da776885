"""The matched layer's kicks and the relaxation of its fields, given the springs' forces
(``sim.forces.absorbing_layer`` for the layer's equations, its fields, the springs it reads and
its action at frozen positions).

The layer splits into two parts whose kicks add: the x-layer of the side strips (the left and
right layers' columns, over every row) and the y-layer of the band rows (the bottom and top
layers' rows, over every column); a corner has both.  The x-layer's fields and forces are laid
out flat, one side strip after the other and column after column (slot first_slot + k ny + j
for column k of the strip, row j), so that its kick is one long loop that vectorises; each
particle keeps its own copy of the held forces of its two x-springs (both copies see the same
forces and factors, so they stay equal).  The y-layer acts a band row at a time.

Each kick returns the kinetic energy it took out (J), measured on the velocities ``lead``
seconds later under the lattice's forces (a leapfrog's half-step velocities are measured half a
step on, at the whole step); kicks applied one after another measure from the velocity the
previous one left, so their takes add up exactly.

Arrays: the state's (dim, ny, nx) positions (m) and velocities (m/s); ``horizontal``
(3, nx + 1) the forces of a row's x-springs (spring i joins particle i - 1, or the left anchor,
to particle i), ``below`` / ``above`` (3, nx) those of the y-springs under and over the row (N);
``layer`` the record ``LayerArguments`` (``MatchedLayer.arguments``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from sim.forces.springs import gravity_vector, site, spring_force

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

NONE, BAND = 0, 1
"""Whether the y-layer acts on a row."""

class LayerArguments(NamedTuple):
    """What the layer's kernels read, as one named record (``MatchedLayer.arguments``).

    ``masses``, ``inverse_masses`` (ny, nx) of the band rows' particles; ``held_y``, ``relaxed_y``,
    ``spring_y``, ``node_y`` the y-layer's held forces, relaxed fields and factors per row;
    ``needs`` which rows the y-layer acts on (``NONE`` or ``BAND``); ``out_of_plane``,
    ``linearised`` compile-time flags (None or True); ``parameters`` the springs'
    ``SpringParameters`` (None on threads, where the sweep passes its own); ``gravity`` (3,) or
    None; ``buffers`` scratch; ``geometry`` (4,) int64: the left strip's width, the right one's,
    its first column, ny; the side strips' fields laid flat: ``held_left``, ``held_right``,
    ``relaxed_x``, ``side_factors``, ``side_inverse_mass``, ``side_forces``, ``side_kicks``,
    ``side_mass``; ``strip_ends`` (3, width + 2, ny + 2) float64 scratch for a side strip's
    positions, transposed, and ``strip_springs`` (3, ny + 1) for a column of its springs.
    """

    masses: object
    held_y: object
    relaxed_y: object
    spring_y: object
    node_y: object
    needs: object
    out_of_plane: object
    linearised: object
    parameters: object
    gravity: object
    buffers: object
    geometry: object
    held_left: object
    held_right: object
    relaxed_x: object
    side_factors: object
    side_inverse_mass: object
    side_forces: object
    side_kicks: object
    side_mass: object
    inverse_masses: object
    strip_ends: object
    strip_springs: object


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


# --- the x-layer: the side strips, flat --------------------------------------------------------


@njit(**_JIT)
def strip(s, geometry):
    """Side strip s (0 left, 1 right): its width, first slot and first column."""
    if s == 0:
        return geometry[0], 0, 0
    return geometry[1], geometry[3] * geometry[0], geometry[2]


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
def held_half(f_left, f_right, force, h_left, h_right, phi, e_left, e_right, e_node, tau,
              inverse_mass):
    """``half_action`` of a side particle, whose held x-spring forces ``h_left``, ``h_right``
    relax toward the springs' ``f_left``, ``f_right`` before the kick and again after it.
    Returns (h_left, h_right, phi, kick)."""
    h_left = relax(f_left, h_left, e_left)
    h_right = relax(f_right, h_right, e_right)
    phi, kick = half_action(force, h_left, h_right, phi, e_node, tau, inverse_mass)
    return relax(f_left, h_left, e_left), relax(f_right, h_right, e_right), phi, kick


@njit(**_JIT)
def side_kick(tau, lead, second_half, pull, forces, held_left, held_right, relaxed, factors,
              inverse_mass, mass, kicks):
    """The x-layer's kick (m/s) of every slot into ``kicks``
    (dim, slots): per half action, relax the held forces of the particle's two x-springs and its
    phi over tau / 2, kick by tau, relax again (twice when ``second_half`` is True, once when
    None: ``held_half``).  ``forces`` (3, dim, slots): the left and right x-springs' forces
    beyond the rest tension and the y-springs' net force; ``factors`` (3, slots):
    exp(-sigma tau / 2) of the left spring, the right one and the particle; ``inverse_mass`` and
    ``mass`` (slots,) 1/kg and kg.  Returns the part of the kinetic energy taken out (J) that
    does not depend on the velocities (``side_apply`` adds the rest)."""
    taken = 0.0
    for c in range(kicks.shape[0]):
        g = pull[0] if c == 0 else (pull[1] if c == 1 else pull[2])
        for k in range(kicks.shape[1]):
            p = np.uint64(k)  # unsigned: no negative-index wrap, so LLVM vectorises
            f_left = forces[0, c, p]
            f_right = forces[1, c, p]
            force = f_right - f_left
            w = inverse_mass[p]
            e_left = factors[0, p]
            e_right = factors[1, p]
            e_node = factors[2, p]
            h_left, h_right, phi, kick = held_half(f_left, f_right, force, held_left[c, p],
                                                   held_right[c, p], relaxed[c, p], e_left,
                                                   e_right, e_node, tau, w)
            if second_half is not None:
                h_left, h_right, phi, more = held_half(f_left, f_right, force, h_left, h_right,
                                                       phi, e_left, e_right, e_node, tau, w)
                kick += more
            held_left[c, p] = h_left
            held_right[c, p] = h_right
            relaxed[c, p] = phi
            kicks[c, p] = kick
            ahead = lead * ((force + forces[2, c, p]) * w + g)
            taken -= 0.5 * mass[p] * kick * (2.0 * ahead + kick)
    return taken


@njit(**_JIT)
def side_apply(velocity, kicks, mass, geometry):
    """Add the side strips' kicks to the velocities.  Returns the part of the kinetic energy
    taken out (J) that depends on the velocities: -m v kick."""
    taken = 0.0
    ny = geometry[3]
    for s in range(2):
        width, first_slot, first_column = strip(s, geometry)
        for c in range(velocity.shape[0]):
            for k in range(width):  # down a column: long loops, not one of ``width`` per row
                i = np.uint64(first_column + k)
                for j in range(ny):
                    p = np.uint64(first_slot + k * ny + j)
                    kick = kicks[c, p]
                    before = np.float64(velocity[c, j, i])
                    velocity[c, j, i] = before + kick
                    taken -= mass[p] * kick * before
    return taken


@njit(**_JIT)
def sides_act(tau, lead, second_half, velocity, layer):
    """The x-layer's action from the forces in the layer's side buffer.  Returns the kinetic
    energy taken out (J)."""
    kicks = layer.side_kicks
    mass = layer.side_mass
    pull = gravity_vector(layer.gravity, 0.0)
    taken = side_kick(tau, lead, second_half, pull, layer.side_forces, layer.held_left,
                      layer.held_right, layer.relaxed_x, layer.side_factors,
                      layer.side_inverse_mass, mass, kicks)
    return taken + side_apply(velocity, kicks, mass, layer.geometry)


# --- the y-layer: the band rows ----------------------------------------------------------------


@njit(**_JIT)
def band_kick(c, j, tau, lead, second_half, pull, layer, horizontal, below, above, shift,
              velocity):
    """Component c of band row j's y-layer kick: per half action relax the held forces of each
    particle's y-springs (``e_below``, ``e_above``: their factors) and its phi (``e_node``) over
    tau / 2, kick by tau, relax again (``layer`` the layer's record).  ``shift`` (N) is taken
    off the y-springs' forces (their rest tension along this component, or 0 when the forces
    given are beyond it).  A held force relaxes toward a force that stays put, so after n
    relaxations it is f + (h - f) e^n: the second half's kick reads it after three.  The held
    forces are stored by the caller (``relax_row``) once both their rows have used them.
    Returns the kinetic energy taken out (J)."""
    masses, inverse_masses = layer.masses, layer.inverse_masses
    held_y, relaxed_y = layer.held_y, layer.relaxed_y
    e_below, e_above, e_node = layer.spring_y[j], layer.spring_y[j + 1], layer.node_y[j]
    taken = 0.0
    one = np.uint64(1)
    later_below = e_below * e_below * e_below  # three relaxations
    later_above = e_above * e_above * e_above
    for k in range(velocity.shape[2]):
        i = np.uint64(k)
        f_below = below[c, i] - shift
        f_above = above[c, i] - shift
        inverse_mass = inverse_masses[j, i]
        force_x = horizontal[c, i + one] - horizontal[c, i]
        force_y = f_above - f_below
        held_below = held_y[c, j, i]
        held_above = held_y[c, j + 1, i]
        phi = relaxed_y[c, j, i]
        before = np.float64(velocity[c, j, i])
        phi, kick = half_action(force_y, relax(f_below, held_below, e_below),
                              relax(f_above, held_above, e_above), phi, e_node, tau,
                              inverse_mass)
        if second_half is not None:
            phi, more = half_action(force_y, relax(f_below, held_below, later_below),
                                  relax(f_above, held_above, later_above), phi, e_node, tau,
                                  inverse_mass)
            kick += more
        v = before + kick
        velocity[c, j, i] = v
        relaxed_y[c, j, i] = phi
        ahead = lead * ((force_x + force_y) * inverse_mass + pull)
        taken += 0.5 * (before + v + 2.0 * ahead) * (before - v) * masses[j, i]
    return taken


@njit(**_JIT)
def relax_row(held, j, forces, factor, second_half, tension):
    """The held forces ``held[:, j]`` (``held`` (dim, rows, n); a view of the row would have
    strides unknown to the compiler, and its loop would not vectorise) of a row of springs
    relaxed toward ``forces`` as the particles' kicks did: twice per half action, by ``factor``
    (in one step: toward a force that stays put, n relaxations by e are one by e^n).
    ``tension`` (N) is taken off the forces' y-components (the springs' rest tension when
    ``forces`` are whole forces, else 0)."""
    total = factor * factor
    if second_half is not None:
        total = total * total
    for c in range(held.shape[0]):
        shift = tension if c == 1 else 0.0
        for k in range(held.shape[2]):
            i = np.uint64(k)
            f = forces[c, i] - shift
            held[c, j, i] = relax(f, held[c, j, i], total)


@njit(**_JIT)
def band_act(j, tau, lead, second_half, velocity, horizontal, below, above, layer, tension):
    """The y-layer's action on band row j from its springs' forces (beyond the rest ``tension``
    when it is 0, whole forces otherwise), then the held forces of the springs under it
    relaxed (and those over it, on the top row).  Returns the kinetic energy taken out (J)."""
    ny = velocity.shape[1]
    spring_y = layer.spring_y
    held_y = layer.held_y
    pull = gravity_vector(layer.gravity, 0.0)
    taken = 0.0
    for c in range(velocity.shape[0]):
        taken += band_kick(c, j, tau, lead, second_half, pull[c], layer, horizontal, below, above,
                           tension if c == 1 else 0.0, velocity)
    if spring_y[j] < 1.0:  # the springs under j served both rows
        relax_row(held_y, j, below, spring_y[j], second_half, tension)
    if j == ny - 1 and spring_y[ny] < 1.0:
        relax_row(held_y, ny, above, spring_y[ny], second_half, tension)
    return taken
