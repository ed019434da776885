"""The absorbing layer as a perfectly matched layer (PML) of the lattice: graded damping of the
springs' stretch and of the forces along the wall's normal, over the border rows and columns.

Why not a plain drag: a wave meets a fixed wall behind the layer, where its velocity vanishes, so
a drag on the velocity barely touches a wave whose quarter wavelength is as deep as the layer,
and a drag strong enough to stop it reflects shorter ones.  The matched layer is the lattice
form of the stretched coordinate x -> x + (1 / i omega) integral sigma_x dx: in the layer along
the left and right walls

    m u''  =  F_y + F_x* - phi_x,       F_x* = F_x - (h_right - h_left)    (x-springs relaxed)
    h'     =  sigma'_x (f - h)          for each x-spring: f its force beyond its rest tension
    phi_x' =  sigma_x (F_x* - phi_x)    for each particle

(u displacement from rest, m; F_x = f_right - f_left the x-springs' force on the particle, N,
with the lattice's own law, so large motion in the layer is relaxed, never reversed).  For small
motion, f = K D_x u (K: k along the spring, T / a across) and in the frequency domain this is
-omega^2 m u = D_x(K D_x u / s_x) / s_x + F_y, s_x = 1 + sigma_x / (i omega): the continuum's
reflectionless layer, with the lattice's own differences.  The layers along the bottom and top
walls do the same with y; a corner does both.  The rate grows with the depth d into the layer
(0 at its inner edge, 1 next to the wall) as sigma = strength * omega_0 * d^POWER, omega_0 =
sqrt(k / m_mean); sigma' is the same profile at the springs' midpoints.

Stepping (``MatchedLayer.act``): the lattice's integrator moves the particles under their springs
alone; between its steps this module acts over a span tau with the positions frozen (operator
splitting): relax h and phi over tau / 2, kick the velocities by tau (-(h_right - h_left) - phi) / m,
relax over tau / 2 again.  The relaxations are exact exponentials (at the default strength the
layer does not lower the stable step).  The kinetic energy a kick takes out is returned (J): the lattice's
energy changes only by those kicks, so kinetic + potential + dissipated stays constant.

The layer is four parts (the side strips and the bands), each a stack of lines damped across
them (``sim.forces.absorbing_kicks``, with the kick of one particle).  Velocity Verlet's leapfrog
acts with this module before each sweep, at the positions the sweep kicks with.

Arrays: the state's (dim, ny, nx) positions (m) and velocities (m/s) in float64 or float32; the
layer's own fields in float64 (N), flat over the parts: the held forces of the springs across
the lines and each particle's phi.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim.forces.absorbing_kicks import (
    AXIS,
    FACTOR,
    FIRST,
    HELD,
    LENGTH,
    LINES,
    PARTS,
    SHIFT,
    SLOT,
    LayerArguments,
    held_factor,
    particle_kick,
    relax,
    rest_tension,
)
from sim.forces.gravity import gravity_vector
from sim.forces.springs import components, site, spring_force

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

POWER = 2
"""Exponent of the rate's growth with depth."""
FIRST_BAND = PARTS.index("bottom")
"""The bottom band's part; the top band's is the next."""

# --- a part's lines and their springs -----------------------------------------------------------
#
# Each spring's force is computed once per action: the positions are frozen while the layer acts,
# so its two half actions between steps (and both relaxations of each) read the same forces.  A
# line is read as a tuple of contiguous 1-D arrays (x, y, z; z None in a planar scene): a band's
# rows straight from the state, a strip's columns copied into rows of ``block`` first (and the
# rows of wall anchors beyond a band, the columns beyond a strip, written there), so that every
# spring is read in a long loop of contiguous memory that LLVM vectorises.


@njit(**_JIT)
def _gather(part, start, stop, x, y, z, parameters, geometry, block):
    """Into row m of ``block`` (3, lines + 2, >= stop - start) the positions start .. stop - 1
    along line first - 1 + m of part ``part``: for a strip every such column, transposed; for a
    band only the rows of wall anchors beyond the lattice (its own rows are read in place)."""
    lines, first, axis = geometry[part, LINES], geometry[part, FIRST], geometry[part, AXIS]
    ny, nx = x.shape
    count = nx if axis == 0 else ny  # lines across the lattice
    for m in range(lines + 2):
        line = first - 1 + m
        if line < 0 or line >= count:
            for k in range(stop - start):
                r = np.uint64(k)  # unsigned indices: no negative-index wrap, so LLVM vectorises
                along = start + k
                anchor = site(line, along, parameters) if axis == 0 else site(along, line,
                                                                             parameters)
                block[0, m, r] = anchor[0]
                block[1, m, r] = anchor[1]
                block[2, m, r] = anchor[2]
        elif axis == 0:  # a strip's column
            i = np.uint64(line)
            for k in range(stop - start):
                r = np.uint64(k)
                j = np.uint64(start + k)
                block[0, m, r] = x[j, i]
                block[1, m, r] = y[j, i]
                if z is not None:
                    block[2, m, r] = z[j, i]


@njit(**_JIT)
def _line(part, m, x, y, z, geometry, block):
    """Line first - 1 + m of part ``part`` as (x, y, z) rows (z None in a planar scene): a row
    of the state, or of ``block`` (``_gather``)."""
    first, axis = geometry[part, FIRST], geometry[part, AXIS]
    line = first - 1 + m
    if axis == 1 and 0 <= line < x.shape[0]:
        if z is None:
            return x[line], y[line], None
        return x[line], y[line], z[line]
    if z is None:
        return block[0, m], block[1, m], None
    return block[0, m], block[1, m], block[2, m]


@njit(**_JIT)
def _end(x, y, z, r, zero):
    """Position r of a line's rows ``x``, ``y``, ``z`` (None: planar) as a spring end at rest."""
    if z is None:
        return (x[r], y[r], zero, zero, zero, zero)
    return (x[r], y[r], z[r], zero, zero, zero)


@njit(**_JIT)
def _beyond(axis, line, along, x, y, z, parameters):
    """Position ``along`` of line ``line`` (a column when ``axis`` is 0, else a row) as a spring
    end at rest: a particle, or the wall anchor outside the lattice."""
    zero = type(parameters.spacing)(0.0)
    i, j = (line, along) if axis == 0 else (along, line)
    if 0 <= i < x.shape[1] and 0 <= j < x.shape[0]:
        return (x[j, i], y[j, i], zero if z is None else z[j, i], zero, zero, zero)
    return site(i, j, parameters)


@njit(**_JIT)
def _store(out, r, force, tension, axis, z):
    """A spring's force (N) into ``out[:, r]``, beyond the rest ``tension`` along ``axis`` (the
    third component only out of the plane: ``z`` not None)."""
    out[0, r] = force[0] - (tension if axis == 0 else 0.0)
    out[1, r] = force[1] - (tension if axis == 1 else 0.0)
    if z is not None:
        out[2, r] = force[2]


@njit(**_JIT)
def _across(low, high, count, axis, linearised, parameters, tension, out, slot):
    """The ``count`` springs from line ``low`` to line ``high`` into ``out[slot]`` (3, count),
    beyond the rest ``tension`` (N) along ``axis``."""
    zero = type(parameters.spacing)(0.0)
    for k in range(count):
        r = np.uint64(k)  # unsigned: no negative-index wrap, so LLVM vectorises
        force = spring_force(_end(low[0], low[1], low[2], r, zero),
                             _end(high[0], high[1], high[2], r, zero), axis, linearised,
                             parameters, None)
        _store(out[slot], r, force, tension, axis, low[2])


@njit(**_JIT)
def _along(line, before, after, count, axis, linearised, parameters, out):
    """The springs along the ``count`` positions of ``line`` into ``out`` (3, count + 1): spring
    q joins positions q - 1 and q; 0 and ``count`` reach the ends ``before`` and ``after``
    (whole forces, N; their axis is the other one)."""
    zero = type(parameters.spacing)(0.0)
    one = np.uint64(1)
    along = 1 - axis
    x, y, z = line
    for k in range(count - 1):
        r = np.uint64(k + 1)
        force = spring_force(_end(x, y, z, r - one, zero), _end(x, y, z, r, zero), along,
                             linearised, parameters, None)
        _store(out, r, force, 0.0, axis, z)
    first, last = np.uint64(0), np.uint64(count)  # values of one type: one variant of each
    _store(out, first, spring_force(before, _end(x, y, z, first, zero), along, linearised,
                                    parameters, None), 0.0, axis, z)
    _store(out, last, spring_force(_end(x, y, z, last - one, zero), after, along, linearised,
                                   parameters, None), 0.0, axis, z)


# --- the action ---------------------------------------------------------------------------------


@njit(**_JIT)
def act_part(part, start, stop, job, tau, lead, second_half, position, velocity, layer,
             parameters, tension):
    """Part ``part``'s action on the positions start .. stop - 1 along its lines (a strip's rows;
    a band's every column) from its springs at the frozen positions, a line at a time: the
    line's kicks, then the held forces of the springs below it relaxed (both their lines have
    read them), then the kicks added to the velocities.  ``job`` picks the scratch (one per
    thread).  Returns the kinetic energy taken out (J)."""
    geometry = layer.geometry
    lines, length = geometry[part, LINES], geometry[part, LENGTH]
    if lines == 0 or stop <= start:
        return 0.0
    first, axis = geometry[part, FIRST], geometry[part, AXIS]
    x, y, z = components(layer.out_of_plane, position)
    block, across, along = layer.block[job], layer.across[job], layer.along[job]
    kicks = layer.kicks[job]
    held, relaxed, factors = layer.held, layer.relaxed, layer.factors
    mass, inverse_mass = layer.mass, layer.inverse_mass
    linearised = layer.linearised
    pull = gravity_vector(layer.gravity, 0.0)
    count = stop - start
    _gather(part, start, stop, x, y, z, parameters, geometry, block)
    # indices as values (np.int64), not constants: numba compiles a constant argument as a type
    # of its own (Literal[int]), one more variant of the callee
    this_line = _line(part, np.int64(1), x, y, z, geometry, block)
    _across(_line(part, np.int64(0), x, y, z, geometry, block), this_line, count, axis,
            linearised, parameters, tension, across, np.int64(0))
    taken = 0.0
    stride = np.uint64(length)
    one = np.uint64(1)
    for line in range(lines):
        low, high = line % 2, (line + 1) % 2
        above_line = _line(part, line + 2, x, y, z, geometry, block)
        _across(this_line, above_line, count, axis, linearised, parameters, tension, across,
                high)
        line_index = first + line
        _along(this_line, _beyond(axis, line_index, start - 1, x, y, z, parameters),
               _beyond(axis, line_index, stop, x, y, z, parameters), count, axis, linearised,
               parameters, along)
        this_line = above_line
        springs = geometry[part, FACTOR] + line
        e_low, e_high, e_node = factors[0, springs], factors[0, springs + 1], factors[1, springs]
        # held forces of the springs below the line, and the line's particles, from ``start``
        below = geometry[part, HELD] + line * length + start
        slots = geometry[part, SLOT] + line * length + start
        for c in range(velocity.shape[0]):
            g = pull[0] if c == 0 else (pull[1] if c == 1 else pull[2])
            for k in range(count):
                i = np.uint64(k)  # unsigned indices: no negative-index wrap, so LLVM vectorises
                p = np.uint64(slots + k)
                h = np.uint64(below + k)
                f_low, f_high = across[low, c, i], across[high, c, i]
                w = inverse_mass[p]
                phi, kick = particle_kick(f_low, f_high, held[c, h], held[c, h + stride],
                                          relaxed[c, p], e_low, e_high, e_node, tau, w,
                                          second_half)
                relaxed[c, p] = phi
                kicks[c, i] = kick
                ahead = lead * ((f_high - f_low + along[c, i + one] - along[c, i]) * w + g)
                taken -= 0.5 * mass[p] * kick * (2.0 * ahead + kick)
            total = held_factor(e_low, second_half)
            for k in range(count):
                h = np.uint64(below + k)
                held[c, h] = relax(across[low, c, np.uint64(k)], held[c, h], total)
            if line == lines - 1:
                total = held_factor(e_high, second_half)
                for k in range(count):
                    h = np.uint64(below + length + k)
                    held[c, h] = relax(across[high, c, np.uint64(k)], held[c, h], total)
            if axis == 1:  # a band's row
                for k in range(count):
                    i = np.uint64(k)
                    before = np.float64(velocity[c, line_index, i])
                    velocity[c, line_index, i] = before + kicks[c, i]
                    taken -= mass[np.uint64(slots + k)] * kicks[c, i] * before
            else:  # a strip's column
                for k in range(count):
                    i = np.uint64(k)
                    j = np.uint64(start + k)
                    before = np.float64(velocity[c, j, line_index])
                    velocity[c, j, line_index] = before + kicks[c, i]
                    taken -= mass[np.uint64(slots + k)] * kicks[c, i] * before
    return taken


_WRAPPER = dict(_JIT, inline="always")
"""The layer's entry points: inlined into the loops that call them (each compiled level of a
call costs a compile of the whole layer again, about 0.7 s)."""


@njit(**_WRAPPER)
def act_with(tau, lead, second_half, position, velocity, layer, parameters):
    """The layer's action over ``tau`` seconds at frozen positions (see the module docstring),
    twice in a row when ``second_half`` is True (False: once; ``absorbing_kicks.TWICE``), from the
    springs computed here with ``parameters`` (the step loop's): the side strips', then the
    bands', on the calling thread.

    ``layer``: ``MatchedLayer.arguments``.  Returns the kinetic energy taken out (J), counted
    on the velocities ``lead`` seconds later under the lattice's forces (dt / 2 for a
    leapfrog's half-step velocities before its kick, else 0)."""
    everything = np.bool_(True)  # values, not constants (``absorbing_kicks.TWICE``)
    return act_rows(np.int64(0), position.shape[1], np.int64(0), everything, everything, tau,
                    lead, second_half, position, velocity, layer, parameters)


@njit(**_JIT)
def block_act(b, block_starts, tau, lead, second_half, position, velocity, layer, parameters):
    """The part of the layer's action (``act_with``) that row block b's thread takes on scratch
    b: the side strips over the block's rows, and the bottom band in the first block, the top
    band in the last.  A band's rows belong to the block of its band, strips included, so
    that no two threads kick one particle (a corner).  Returns the kinetic energy taken out
    (J)."""
    geometry = layer.geometry
    blocks = block_starts.size - 1
    ny = position.shape[1]
    bottom_end = geometry[FIRST_BAND, LINES]
    top_start = geometry[FIRST_BAND + 1, FIRST] if geometry[FIRST_BAND + 1, LINES] > 0 else ny
    start = 0 if b == 0 else min(max(block_starts[b], bottom_end), top_start)
    stop = ny if b == blocks - 1 else min(max(block_starts[b + 1], bottom_end), top_start)
    return act_rows(start, stop, b, b == 0, b == blocks - 1, tau, lead, second_half, position,
                     velocity, layer, parameters)


@njit(**_JIT)
def act_rows(start, stop, job, bottom, top, tau, lead, second_half, position, velocity, layer,
             parameters):
    """The side strips' action over rows start .. stop - 1, then the bottom band's and the top
    band's where ``bottom``, ``top``, on scratch ``job`` (``act_part``).  Returns the kinetic
    energy taken out (J)."""
    geometry = layer.geometry
    tension = rest_tension(layer.linearised, parameters)
    taken = 0.0
    for part in range(len(PARTS)):
        band = geometry[part, AXIS] == 1
        if not band:
            taken += act_part(part, start, stop, job, tau, lead, second_half, position,
                              velocity, layer, parameters, tension)
        elif (bottom and part == FIRST_BAND) or (top and part == FIRST_BAND + 1):
            taken += act_part(part, np.int64(0), geometry[part, LENGTH], job, tau, lead,
                              second_half, position, velocity, layer, parameters, tension)
    return taken


def depth_profile(count: int, near: int, far: int, offset: float) -> np.ndarray:
    """Depth (0..1) into the layers at positions index + ``offset`` (0 for particles, -0.5 for
    springs, spring i lying between particles i - 1 and i) of ``count`` particles with a layer
    ``near`` deep at index 0's side and ``far`` deep at the other side."""
    position = np.arange(count + (1 if offset else 0)) + offset
    depth = np.zeros(position.shape)
    if near:
        depth = np.maximum(depth, np.clip((near - position) / near, 0.0, 1.0))
    if far:
        depth = np.maximum(depth, np.clip((position - (count - 1 - far)) / far, 0.0, 1.0))
    return depth


def _span(count: int, near: int, far: int) -> tuple[int, int]:
    """Where the layers along an axis of ``count`` particles end: the near one covers indices
    0 .. near_end - 1 (with its inner edge; 0 without a layer), the far one far_start ..
    count - 1 (count without a layer), never overlapping."""
    near_end = min(near + 1, count) if near > 0 else 0
    far_start = max(count - 1 - far, near_end) if far > 0 else count
    return near_end, far_start


class MatchedLayer:
    """The matched layer of one model and its fields (the memory of the springs' relaxation).

    ``widths`` (left, right, bottom, top) in particles, 0 where a wall has no layer;
    ``strength`` the peak rate in units of sqrt(k / m_mean).  ``act(state, span)`` acts over
    ``span`` seconds and adds what it takes out to ``state.dissipated``; a state changed from
    outside (``State.revision``) starts the fields again from rest.
    """

    def __init__(self, model: Any, widths: tuple[int, int, int, int], strength: float) -> None:
        self.widths = np.array(widths, dtype=np.int64)
        left, right, bottom, top = widths
        nx, ny, dim = model.nx, model.ny, model.dim
        omega_0 = math.sqrt(model.stiffness / float(np.mean(model.masses)))
        peak = strength * omega_0 * (1.0 + SHIFT)  # the fields' rates, frequency shift included
        rates = {  # 1/s, of the particles and of the springs (spring i below particle i)
            0: (peak * depth_profile(nx, left, right, 0.0) ** POWER,
                peak * depth_profile(nx, left, right, -0.5) ** POWER),
            1: (peak * depth_profile(ny, bottom, top, 0.0) ** POWER,
                peak * depth_profile(ny, bottom, top, -0.5) ** POWER),
        }
        left_end, right_start = _span(nx, left, right)
        bottom_end, top_start = _span(ny, bottom, top)
        parts = {"left": (left_end, 0, 0), "right": (nx - right_start, right_start, 0),
                 "bottom": (bottom_end, 0, 1), "top": (ny - top_start, top_start, 1)}
        masses = np.asarray(model.masses, dtype=np.float64)
        geometry, part_masses, spring_rates, node_rates = [], [], [], []
        held = slot = factor = 0
        for name in PARTS:
            lines, first, axis = parts[name]
            length = ny if axis == 0 else nx
            geometry.append((lines, length, first, axis, held, slot, factor))
            span = slice(first, first + lines)
            part_masses.append((masses[:, span].T if axis == 0 else masses[span, :]).ravel())
            node, spring = rates[axis]
            if lines:
                spring_rates.append(spring[first:first + lines + 1])
                node_rates.append(np.append(node[span], 0.0))
                held += (lines + 1) * length
                factor += lines + 1
            slot += lines * length
        self.geometry = np.array(geometry, dtype=np.int64)
        self.rates = np.stack([np.concatenate(spring_rates or [np.zeros(0)]),
                               np.concatenate(node_rates or [np.zeros(0)])])
        self._mass = np.ascontiguousarray(np.concatenate(part_masses))
        self._inverse_mass = 1.0 / self._mass
        self._model = model
        self.fields = (np.zeros((dim, held)), np.zeros((dim, slot)))
        """The held forces of the springs across the parts' lines and each particle's phi (N)."""
        self._longest = max(nx, ny)
        self._scratch: dict[tuple, tuple] = {}
        self._factors: dict[float, np.ndarray] = {}
        self._revision: int | None = None

    def factors(self, span: float) -> np.ndarray:
        """exp(-rate span / 2) of the springs across the parts' lines and of the lines'
        particles (2, springs)."""
        factors = self._factors.get(span)
        if factors is None:
            factors = np.exp(-0.5 * span * self.rates)
            if len(self._factors) > 4:
                self._factors.clear()
            self._factors[span] = factors
        return factors

    def scratch(self, dtype: type, jobs: int) -> tuple:
        """The kernels' scratch for ``jobs`` threads (``LayerArguments``): ``block`` in the
        state's precision (a strip's rows and a band's are read alike), the rest in float64."""
        key = (dtype, jobs)
        if key not in self._scratch:
            longest = self._longest
            lines = int(self.geometry[:, LINES].max())
            self._scratch[key] = (np.zeros((jobs, 3, lines + 2, longest), dtype=dtype),
                                  np.zeros((jobs, 2, 3, longest)), np.zeros((jobs, 3, longest + 1)),
                                  np.zeros((jobs, self._model.dim, longest)))
        return self._scratch[key]

    def arguments(self, span: float, dtype: type = np.float64, jobs: int = 1) -> LayerArguments:
        """The layer's record for spans of ``span`` on a state in ``dtype``, as ``act_with`` and
        the step loops take it, with scratch for ``jobs`` threads."""
        model = self._model
        gravity = np.array(model.gravity, dtype=dtype) if model.has_gravity else None
        held, relaxed = self.fields
        block, across, along, kicks = self.scratch(dtype, jobs)
        return LayerArguments(
            geometry=self.geometry, held=held, relaxed=relaxed, factors=self.factors(span),
            mass=self._mass, inverse_mass=self._inverse_mass,
            out_of_plane=True if model.dim == 3 else None,
            linearised=True if model.linear else None,
            gravity=gravity, block=block, across=across, along=along, kicks=kicks)

    def follow(self, state: Any) -> None:
        """Start the fields from rest when the state was changed from outside."""
        if self._revision != state.revision:
            for field in self.fields:
                field[...] = 0.0
            self._revision = state.revision

    def act(self, state: Any, span: float, parameters: Any = None) -> None:
        """The layer's action over ``span`` seconds; its take adds to ``state.dissipated``.
        ``parameters``: the springs' as the step loop takes them (``act_rows`` is then called
        with the types the loop gives it, and the two share one compiled kernel); by default
        the model's."""
        self.follow(state)
        dtype = state.positions.dtype.type
        if parameters is None:
            parameters = self._model.kernel_parameters.as_type(dtype)
        state.dissipated += act_rows(0, state.positions.shape[1], 0, True, True, span, 0.0, False,
                                     state.positions, state.velocities,
                                     self.arguments(span, dtype), parameters)
