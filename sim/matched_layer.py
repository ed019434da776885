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

Arrays: the state's (dim, ny, nx) positions (m) and velocities (m/s) in float64 or float32; the
layer's own fields in float64 (N): ``held_x`` h of the x-springs (spring i joins particle i - 1,
or the left anchor, to particle i) and ``relaxed_x`` phi_x over the side layers' columns only
(dim, ny, columns): the left layer's, then the right one's, so that a side's rows lie next to
each other; ``held_y`` (dim, ny + 1, nx) h of the y-springs and ``relaxed_y`` (dim, ny, nx)
phi_y.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim.kernels import gravity_vector, site, spring_force
from sim.row_updates import components

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")
_INLINE = dict(_JIT, inline="always")
"""Inlined by numba itself: a call per row that passes a dozen arrays costs their reference
counting, more than a short span's arithmetic."""

POWER = 2
"""Exponent of the rate's growth with depth."""

NONE, SIDES, FULL = 0, 1, 2
"""Which particles of a row the layer acts on: none, the side layers' spans, the whole row."""


# --- the springs the layer reads, a span of a row at a time ------------------------------------
#
# Each spring's force is computed once per action: the positions are frozen while the layer acts,
# so its two half actions between steps (and both relaxations of each) read the same forces.
# Loops over a span of columns with the wall anchors outside them: straight-line bodies that LLVM
# vectorises.


@njit(**_JIT)
def _store(out, i, force, axis, tension, z):
    """Force (N) beyond the rest tension (along ``axis``) into ``out[:, i]``."""
    out[0, i] = force[0] - (tension if axis == 0 else 0.0)
    out[1, i] = force[1] - (tension if axis == 1 else 0.0)
    if z is not None:
        out[2, i] = force[2]


@njit(**_JIT)
def _end(x, y, z, j, i, zero):
    """Particle (j, i) as a spring end at rest."""
    if z is None:
        return (x[j, i], y[j, i], zero, zero, zero, zero)
    return (x[j, i], y[j, i], z[j, i], zero, zero, zero)


@njit(**_JIT)
def _x_springs(j, start, stop, x, y, z, linearised, parameters, tension, out):
    """The x-springs ``start`` .. ``stop - 1`` of row j into ``out`` (3, nx + 1): spring i joins
    particle i - 1 to particle i; 0 and nx reach the left and right wall anchors."""
    nx = x.shape[1]
    zero = type(parameters.spacing)(0.0)
    one = np.uint64(1)
    first_spring = max(start, 1)
    for k in range(min(stop, nx) - first_spring):
        i = np.uint64(first_spring + k)  # unsigned: no negative-index wrap, so LLVM vectorises
        if z is None:
            first = (x[j, i - one], y[j, i - one], zero, zero, zero, zero)
            second = (x[j, i], y[j, i], zero, zero, zero, zero)
        else:
            first = (x[j, i - one], y[j, i - one], z[j, i - one], zero, zero, zero)
            second = (x[j, i], y[j, i], z[j, i], zero, zero, zero)
        _store(out, i, spring_force(first, second, 0, linearised, parameters, None), 0, tension, z)
    if start == 0:
        _store(out, 0, spring_force(site(-1, j, parameters), _end(x, y, z, j, 0, zero), 0,
                                    linearised, parameters, None), 0, tension, z)
    if stop > nx:
        _store(out, nx, spring_force(_end(x, y, z, j, nx - 1, zero), site(nx, j, parameters), 0,
                                     linearised, parameters, None), 0, tension, z)


@njit(**_JIT)
def _y_span(lower, upper, j, start, stop, x, y, z, linearised, parameters, tension, out):
    """The y-springs from row j - 1 (``lower``, None: the bottom anchors) to row j (``upper``,
    None: the top anchors) at columns ``start`` .. ``stop - 1`` into ``out`` (3, nx)."""
    zero = type(parameters.spacing)(0.0)
    for k in range(stop - start):
        i = np.uint64(start + k)
        first = site(i, j - 1, parameters) if lower is None else _end(x, y, z, lower, i, zero)
        second = site(i, j, parameters) if upper is None else _end(x, y, z, upper, i, zero)
        _store(out, i, spring_force(first, second, 1, linearised, parameters, None), 1, tension,
               z)


@njit(**_JIT)
def _y_springs(j, start, stop, x, y, z, linearised, parameters, tension, out):
    """The y-springs below row j (j = 0: from the bottom anchors; j = ny: to the top ones)."""
    ny = x.shape[0]
    if j == 0:
        _y_span(None, 0, j, start, stop, x, y, z, linearised, parameters, tension, out)
    elif j == ny:
        _y_span(j - 1, None, j, start, stop, x, y, z, linearised, parameters, tension, out)
    else:
        _y_span(j - 1, j, j, start, stop, x, y, z, linearised, parameters, tension, out)


# --- the action on one span of particles ----------------------------------------------------


@njit(**_JIT)
def _relax(force, held, factor):
    """A held force relaxed toward the spring's force: f + (h - f) e."""
    return force + (held - force) * factor


@njit(**_JIT)
def _kick_span(c, j, start, stop, tau, lead, second_half, x_part, y_part, pull, velocity, masses,
               horizontal, below, above, held_x, held_y, relaxed_x, relaxed_y, spring_x, node_x,
               e_below, e_above, e_node_y, held_offset, relaxed_offset):
    """Component c of the particles ``start`` .. ``stop - 1`` of row j: per half action, relax
    their springs' held forces and their phi over tau / 2, kick by tau, relax again (a second
    half when ``second_half`` is True, compiled out when None).  ``x_part`` / ``y_part`` None
    leave out the layer along x / y where its fields stay zero (no x-layer at these columns, no
    y-layer in this row).  Column i's x-fields are at i - ``held_offset`` (its spring on the
    left) and i - ``relaxed_offset`` (phi_x) of the side layers' compact arrays.  The x-springs'
    held forces are stored as relaxed here (springs
    ``start`` .. ``stop``); the y-springs' are the caller's.  Returns the kinetic energy taken
    out (J), measured on v + lead * a."""
    taken = 0.0
    zero = 0.0
    one = np.uint64(1)
    to_held = np.uint64(held_offset)
    to_relaxed = np.uint64(relaxed_offset)
    for k in range(stop - start):
        i = np.uint64(start + k)  # unsigned: no negative-index wrap, so LLVM vectorises
        f_left = horizontal[c, i]
        f_right = horizontal[c, i + one]
        f_below = below[c, i]
        f_above = above[c, i]
        inverse_mass = 1.0 / masses[j, i]
        force_x = f_right - f_left
        force_y = f_above - f_below
        if x_part is not None:
            e_left = spring_x[i]
            e_right = spring_x[i + one]
            e_x = node_x[i]
            h_left = held_x[c, j, i - to_held]
            h_right = held_x[c, j, i + one - to_held]
            phi_x = relaxed_x[c, j, i - to_relaxed]
        if y_part is not None:
            h_below = held_y[c, j, i]
            h_above = held_y[c, j + 1, i]
            phi_y = relaxed_y[c, j, i]
        start_velocity = np.float64(velocity[c, j, i])
        v = start_velocity
        for _ in range(1 if second_half is None else 2):
            # the springs' relaxed force F* and what the relaxation holds of it
            push = zero
            if x_part is not None:
                h_left = _relax(f_left, h_left, e_left)
                h_right = _relax(f_right, h_right, e_right)
                holding_x = h_right - h_left
                target_x = force_x - holding_x
                phi_x = _relax(target_x, phi_x, e_x)
                push -= holding_x + phi_x
            if y_part is not None:
                h_below = _relax(f_below, h_below, e_below)
                h_above = _relax(f_above, h_above, e_above)
                holding_y = h_above - h_below
                target_y = force_y - holding_y
                phi_y = _relax(target_y, phi_y, e_node_y)
                push -= holding_y + phi_y
            v = v + tau * push * inverse_mass
            if x_part is not None:
                phi_x = _relax(target_x, phi_x, e_x)
                h_left = _relax(f_left, h_left, e_left)
                h_right = _relax(f_right, h_right, e_right)
            if y_part is not None:
                phi_y = _relax(target_y, phi_y, e_node_y)
                h_below = _relax(f_below, h_below, e_below)
                h_above = _relax(f_above, h_above, e_above)
        velocity[c, j, i] = v
        if x_part is not None:
            relaxed_x[c, j, i - to_relaxed] = phi_x
            # the spring on the left has served both its particles (this one last)
            held_x[c, j, i - to_held] = h_left
            if k == stop - start - 1:
                held_x[c, j, i + one - to_held] = h_right
        if y_part is not None:
            relaxed_y[c, j, i] = phi_y
        ahead = lead * ((force_x + force_y) * inverse_mass + pull)
        taken += 0.5 * (start_velocity + v + 2.0 * ahead) * (start_velocity - v) / inverse_mass
    return taken


@njit(**_JIT)
def _kick_row(j, segments, tau, lead, second_half, pull, velocity, masses, horizontal, below,
              above, held_x, held_y, relaxed_x, relaxed_y, spring_x, node_x, e_below, e_above,
              e_node_y):
    """``_kick_span`` over the ``segments`` (k, 5) [start, stop, part, held offset, relaxed
    offset] of row j, every component; part 1: the x-layer only, 2: the y-layer only, 3: both."""
    taken = 0.0
    for s in range(segments.shape[0]):
        start, stop, part = segments[s, 0], segments[s, 1], segments[s, 2]
        held_offset, relaxed_offset = segments[s, 3], segments[s, 4]
        if stop <= start:
            continue
        for c in range(velocity.shape[0]):
            if part == 1:
                taken += _kick_span(c, j, start, stop, tau, lead, second_half, True, None, pull[c],
                                    velocity, masses, horizontal, below, above, held_x, held_y,
                                    relaxed_x, relaxed_y, spring_x, node_x, e_below, e_above,
                                    e_node_y, held_offset, relaxed_offset)
            elif part == 2:
                taken += _kick_span(c, j, start, stop, tau, lead, second_half, None, True, pull[c],
                                    velocity, masses, horizontal, below, above, held_x, held_y,
                                    relaxed_x, relaxed_y, spring_x, node_x, e_below, e_above,
                                    e_node_y, held_offset, relaxed_offset)
            else:
                taken += _kick_span(c, j, start, stop, tau, lead, second_half, True, True, pull[c],
                                    velocity, masses, horizontal, below, above, held_x, held_y,
                                    relaxed_x, relaxed_y, spring_x, node_x, e_below, e_above,
                                    e_node_y, held_offset, relaxed_offset)
    return taken


@njit(**_JIT)
def _relax_row(held, forces, factor, second_half):
    """The held forces ``held`` (dim, n) of a row of springs relaxed toward ``forces`` as the
    particles' loop did: twice per half action, by ``factor``."""
    for c in range(held.shape[0]):
        for k in range(held.shape[1]):
            i = np.uint64(k)
            h = held[c, i]
            f = forces[c, i]
            h = _relax(f, _relax(f, h, factor), factor)
            if second_half is not None:
                h = _relax(f, _relax(f, h, factor), factor)
            held[c, i] = h


@njit(**_JIT)
def _side_strip(j0, j1, start, stop, tau, lead, second_half, x, y, z, velocity, masses, held_x,
                relaxed_x, held_offset, relaxed_offset, spring_x, node_x, linearised, parameters,
                tension, pull, buffers):
    """The side layer's particles ``start`` .. ``stop - 1`` of the rows ``j0`` .. ``j1 - 1``
    between the bands, where the layer has x-fields only: one call for the whole strip (a call
    per row costs more than its short span).  Returns the kinetic energy taken out (J)."""
    ny, nx = x.shape
    zero = type(parameters.spacing)(0.0)
    one = np.uint64(1)
    horizontal, below, above = buffers[0], buffers[1], buffers[2]
    taken = 0.0
    for k in range(stop - start):  # the y-springs below the first row
        i = np.uint64(start + k)
        under = site(i, j0 - 1, parameters) if j0 == 0 else _end(x, y, z, j0 - 1, i, zero)
        _store(below, i, spring_force(under, _end(x, y, z, j0, i, zero), 1, linearised,
                                      parameters, None), 1, tension, z)
    for j in range(j0, j1):
        for k in range(stop - start):  # the y-springs above (the acceleration's rest)
            i = np.uint64(start + k)
            over = site(i, j + 1, parameters) if j == ny - 1 else _end(x, y, z, j + 1, i, zero)
            _store(above, i, spring_force(_end(x, y, z, j, i, zero), over, 1, linearised,
                                          parameters, None), 1, tension, z)
        first_spring = max(start, 1)
        for k in range(min(stop + 1, nx) - first_spring):
            i = np.uint64(first_spring + k)
            _store(horizontal, i, spring_force(_end(x, y, z, j, i - one, zero),
                                               _end(x, y, z, j, i, zero), 0, linearised,
                                               parameters, None), 0, tension, z)
        if start == 0:
            _store(horizontal, 0, spring_force(site(-1, j, parameters), _end(x, y, z, j, 0, zero),
                                               0, linearised, parameters, None), 0, tension, z)
        if stop == nx:
            _store(horizontal, nx, spring_force(_end(x, y, z, j, nx - 1, zero),
                                                site(nx, j, parameters), 0, linearised,
                                                parameters, None), 0, tension, z)
        for c in range(velocity.shape[0]):
            taken += _kick_span(c, j, start, stop, tau, lead, second_half, True, None, pull[c],
                                velocity, masses, horizontal, below, above, held_x, held_x,
                                relaxed_x, relaxed_x, spring_x, node_x, 1.0, 1.0, 1.0,
                                held_offset, relaxed_offset)
        below, above = above, below
    return taken


@njit(**_JIT)
def act(tau, lead, second_half, position, velocity, masses, held_x, held_y, relaxed_x,
        relaxed_y, spring_x, spring_y, node_x, node_y, spans, needs, out_of_plane, linearised,
        parameters, gravity, buffers):
    """The layer's action over ``tau`` seconds at frozen positions (see the module docstring),
    twice in a row when ``second_half`` is True (None: once; a compile-time choice).

    ``spring_x`` (nx + 1,), ``spring_y`` (ny + 1,), ``node_x`` (nx,), ``node_y`` (ny,): the
    factors exp(-sigma tau / 2) of the springs and particles (1 outside the layer); ``spans``
    (2, 2) the side layers' column ranges [start, stop) (with the first column inside), ``needs``
    (ny,) which particles of each row the layer acts on (``NONE``, ``SIDES``, ``FULL``);
    ``out_of_plane`` True for (3, ny, nx) states, None for planar (2, ny, nx) ones.
    ``linearised`` (None or True), ``parameters`` (``sim.kernels.SpringParameters`` in the
    state's precision) and ``gravity`` ((3,) m/s^2 or None): the lattice's law, as its kernels
    take it; ``buffers`` (3, 3, nx + 1) float64 scratch.  Returns the kinetic energy taken out
    (J), counted on the velocities ``lead`` seconds later under the lattice's forces (dt / 2
    for a leapfrog's half-step velocities, else 0)."""
    dim, ny, nx = position.shape
    x, y, z = components(out_of_plane, position)
    tension = float(spring_force(site(0, 0, parameters), site(1, 0, parameters), 0, linearised,
                                 parameters, None)[0])
    pull = gravity_vector(gravity, 0.0)
    horizontal = buffers[0]
    below = buffers[1]
    above = buffers[2]
    # [start, stop, part) of a band row: it holds y-fields everywhere and x-fields in its
    # corners (part 1: x, 2: y, 3: both); the side strips between the bands hold x-fields only
    # the side layers' x-fields are compact: the left columns, then the right ones
    offsets = np.array([[0, 0], [spans[1, 0] - spans[0, 1] - 1, spans[1, 0] - spans[0, 1]]])
    band_segments = np.array([[spans[0, 0], spans[0, 1], 3, 0, 0],
                              [spans[0, 1], spans[1, 0], 2, 0, 0],
                              [spans[1, 0], spans[1, 1], 3, offsets[1, 0], offsets[1, 1]]])
    taken = 0.0
    fresh = True  # whether ``below`` must be computed (the row below was not a band row)
    j = 0
    while j < ny:
        if needs[j] == SIDES:  # a strip of side rows between the bands
            end = j
            while end < ny and needs[end] == SIDES:
                end += 1
            for s in range(2):
                if spans[s, 1] > spans[s, 0]:
                    taken += _side_strip(j, end, spans[s, 0], spans[s, 1], tau, lead,
                                         second_half, x, y, z, velocity, masses, held_x,
                                         relaxed_x, offsets[s, 0], offsets[s, 1], spring_x,
                                         node_x, linearised, parameters, tension, pull, buffers)
            j = end
            fresh = True
            continue
        if needs[j] == NONE:
            j += 1
            fresh = True
            continue
        if fresh:
            _y_springs(j, 0, nx, x, y, z, linearised, parameters, tension, below)
        _y_springs(j + 1, 0, nx, x, y, z, linearised, parameters, tension, above)
        _x_springs(j, 0, nx + 1, x, y, z, linearised, parameters, tension, horizontal)
        taken += _kick_row(j, band_segments, tau, lead, second_half, pull, velocity, masses,
                           horizontal, below, above, held_x, held_y, relaxed_x, relaxed_y,
                           spring_x, node_x, spring_y[j], spring_y[j + 1], node_y[j])
        # the springs below this row have served both their rows
        if spring_y[j] < 1.0:
            _relax_row(held_y[:, j, :], below, spring_y[j], second_half)
        if j == ny - 1 and spring_y[ny] < 1.0:
            _relax_row(held_y[:, ny, :], above, spring_y[ny], second_half)
        below, above = above, below
        fresh = False
        j += 1
    return taken


@njit(**_JIT)
def act_on(tau, lead, second_half, position, velocity, layer):
    """``act`` with its arguments after the state's arrays as one tuple ``layer``
    (``MatchedLayer.arguments``), for the compiled step loops."""
    return act(tau, lead, second_half, position, velocity, layer[0], layer[1], layer[2],
               layer[3], layer[4], layer[5], layer[6], layer[7], layer[8], layer[9], layer[10],
               layer[11], layer[12], layer[13], layer[14], layer[15])


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
        peak = strength * omega_0
        self.rates = dict(  # 1/s
            node_x=peak * depth_profile(nx, left, right, 0.0) ** POWER,
            spring_x=peak * depth_profile(nx, left, right, -0.5) ** POWER,
            node_y=peak * depth_profile(ny, bottom, top, 0.0) ** POWER,
            spring_y=peak * depth_profile(ny, bottom, top, -0.5) ** POWER,
        )
        first_end = min(left + 1, nx) if left > 0 else 0  # with the first column inside
        last_start = max(nx - 1 - right, first_end) if right > 0 else nx
        self.spans = np.array([[0, first_end], [last_start, nx]], dtype=np.int64)
        rows = np.arange(ny)
        band = ((bottom > 0) & (rows <= bottom)) | ((top > 0) & (rows >= ny - 1 - top))
        sides = SIDES if (first_end > 0 or last_start < nx) else NONE
        if first_end >= last_start:  # the side layers meet: whole rows
            sides = FULL
        self.needs = np.where(band, FULL, sides).astype(np.int64)
        self.masses = np.ascontiguousarray(model.masses, dtype=np.float64)
        self._model = model
        # x-fields over the side layers' columns only, compact (the left ones, then the right
        # ones: rows of a side lie next to each other in memory); y-fields over whole rows
        side_columns = first_end + (nx - last_start)
        self.fields = (np.zeros((dim, ny, side_columns + 2)), np.zeros((dim, ny + 1, nx)),
                       np.zeros((dim, ny, side_columns)), np.zeros((dim, ny, nx)))
        self._buffers = np.zeros((3, 3, nx + 1))
        self._factors: dict[float, tuple] = {}
        self._revision: int | None = None

    def factors(self, span: float) -> tuple:
        """exp(-rate span / 2) of the springs and particles, in the order ``act`` takes them."""
        factors = self._factors.get(span)
        if factors is None:
            factors = tuple(np.exp(-0.5 * span * self.rates[name])
                            for name in ("spring_x", "spring_y", "node_x", "node_y"))
            if len(self._factors) > 4:
                self._factors.clear()
            self._factors[span] = factors
        return factors

    def arguments(self, span: float, dtype: type = np.float64) -> tuple:
        """Everything ``act`` takes after the state's arrays, for spans of ``span`` on a state
        in ``dtype``."""
        model = self._model
        gravity = np.array(model.gravity, dtype=dtype) if model.has_gravity else None
        return (self.masses, *self.fields, *self.factors(span), self.spans, self.needs,
                True if model.dim == 3 else None, True if model.linear else None,
                model.kernel_parameters.as_type(dtype), gravity, self._buffers)

    def follow(self, state: Any) -> None:
        """Start the fields from rest when the state was changed from outside."""
        if self._revision != state.revision:
            for field in self.fields:
                field[...] = 0.0
            self._revision = state.revision

    def act(self, state: Any, span: float) -> None:
        """The layer's action over ``span`` seconds; its take adds to ``state.dissipated``."""
        self.follow(state)
        state.dissipated += act_on(span, 0.0, None, state.positions, state.velocities,
                                   self.arguments(span, state.positions.dtype.type))
