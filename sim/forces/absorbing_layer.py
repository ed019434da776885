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

The kicks themselves, given the springs' forces, are ``sim.forces.absorbing_kicks``'s, shared with the
leapfrog sweep, which has those forces at hand and acts inside its pass.

Arrays: the state's (dim, ny, nx) positions (m) and velocities (m/s) in float64 or float32; the
layer's own fields in float64 (N): over the side strips (the left and right layers' columns,
every row; flat (dim, slots), the left strip row by row, then the right one) each particle's
held forces of its left and right x-springs and its phi_x; ``held_y`` (dim, ny + 1, nx) h of
the y-springs and ``relaxed_y`` (dim, ny, nx) phi_y.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim.forces.absorbing_kicks import (
    BAND,
    NONE,
    SHIFT,
    LayerArguments,
    band_act,
    rest_tension,
    sides_act,
    strip,
)
from sim.forces.springs import as_row, components, site, spring_force

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

POWER = 2
"""Exponent of the rate's growth with depth."""

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
    j = as_row(j)  # a literal 0 would compile the spans once more
    ny = x.shape[0]
    start, stop = np.intp(start), np.intp(stop)
    if j == 0:
        _y_span(None, j, j, start, stop, x, y, z, linearised, parameters, tension, out)
    elif j == ny:
        _y_span(j - 1, None, j, start, stop, x, y, z, linearised, parameters, tension, out)
    else:
        _y_span(j - 1, j, j, start, stop, x, y, z, linearised, parameters, tension, out)


@njit(**_JIT)
def _gather_strip(s, x, y, z, parameters, geometry, ends):
    """Side strip s's particles and the columns on either side of it, transposed into ``ends``
    (3, width + 2, ny + 2): ``ends[:, m, r]`` the particle of column first_column - 1 + m, row
    r - 1, or the wall anchor where that is outside the lattice (rows -1 and ny, columns -1
    and nx).  Down the columns, so that the springs are computed in long loops that
    vectorise."""
    width, _, first_column = strip(s, geometry)
    ny, nx = x.shape
    for m in range(width + 2):
        i = first_column - 1 + m
        for r in (0, ny + 1):
            anchor = site(i, r - 1, parameters)
            ends[0, m, r] = anchor[0]
            ends[1, m, r] = anchor[1]
        if i < 0 or i >= nx:
            for r in range(ny):
                anchor = site(i, r, parameters)
                ends[0, m, r + 1] = anchor[0]
                ends[1, m, r + 1] = anchor[1]
                if z is not None:
                    ends[2, m, r + 1] = 0.0
        else:
            for r in range(ny):
                ends[0, m, r + 1] = x[r, i]
                ends[1, m, r + 1] = y[r, i]
                if z is not None:
                    ends[2, m, r + 1] = z[r, i]


@njit(**_JIT)
def _column_end(out_of_plane, ends, m, r, zero):
    """Entry (m, r) of a gathered strip (``_gather_strip``) as a spring end at rest."""
    depth = ends[2, m, r] if out_of_plane is not None else zero
    return (ends[0, m, r], ends[1, m, r], depth, zero, zero, zero)


@njit(**_JIT)
def _strip_springs(s, ends, out_of_plane, linearised, parameters, tension, geometry, forces,
                   column):
    """Side strip s's springs from its gathered positions ``ends`` into the side buffer
    ``forces`` (3, dim, slots): each particle's left and right x-springs beyond the rest
    ``tension`` (N) and the net force of its two y-springs; ``column`` (3, ny + 1) scratch."""
    width, first_slot, _ = strip(s, geometry)
    ny = geometry[3]
    zero = 0.0
    for m in range(width + 1):  # x-spring m joins gathered columns m and m + 1
        for k in range(ny):
            r = np.uint64(k + 1)  # unsigned: no negative-index wrap, so LLVM vectorises
            force = spring_force(_column_end(out_of_plane, ends, m, r, zero),
                                 _column_end(out_of_plane, ends, m + 1, r, zero), 0, linearised,
                                 parameters, None)
            column[0, k] = force[0] - tension
            column[1, k] = force[1]
            column[2, k] = force[2]
        for c in range(forces.shape[1]):
            if m < width:  # the left spring of the strip's column m
                for k in range(ny):
                    forces[0, c, first_slot + m * ny + k] = column[c, k]
            if m > 0:  # the right spring of its column m - 1
                for k in range(ny):
                    forces[1, c, first_slot + (m - 1) * ny + k] = column[c, k]
    for m in range(width):  # y-spring r of column m joins gathered rows r and r + 1
        for k in range(ny + 1):
            r = np.uint64(k)
            force = spring_force(_column_end(out_of_plane, ends, m + 1, r, zero),
                                 _column_end(out_of_plane, ends, m + 1, r + np.uint64(1), zero),
                                 1, linearised, parameters, None)
            column[0, k] = force[0]
            column[1, k] = force[1]
            column[2, k] = force[2]
        for c in range(forces.shape[1]):
            for k in range(ny):
                forces[2, c, first_slot + m * ny + k] = column[c, k + 1] - column[c, k]


@njit(**_JIT)
def act_on(tau, lead, second_half, position, velocity, layer):
    """The layer's action over ``tau`` seconds at frozen positions (see the module docstring),
    twice in a row when ``second_half`` is True (None: once; a compile-time choice): the side
    strips' x-layer, then the band rows' y-layer, each from the springs computed here.

    ``layer``: ``MatchedLayer.arguments``.  Returns the kinetic energy taken out (J), counted
    on the velocities ``lead`` seconds later under the lattice's forces (dt / 2 for a
    leapfrog's half-step velocities before its kick, else 0)."""
    return act_with(tau, lead, second_half, position, velocity, layer, layer.parameters)


@njit(**_JIT)
def act_with(tau, lead, second_half, position, velocity, layer, parameters):
    """``act_on`` with the springs' ``parameters`` given apart from the layer's record (the
    record a threaded sweep takes has None in their place)."""
    ny, nx = position.shape[1], position.shape[2]
    x, y, z = components(layer.out_of_plane, position)
    linearised = layer.linearised
    tension = rest_tension(linearised, parameters)
    taken = 0.0
    geometry = layer.geometry
    if geometry[0] + geometry[1] > 0:
        for s in range(2):
            if strip(s, geometry)[0] > 0:
                _gather_strip(s, x, y, z, parameters, geometry, layer.strip_ends)
                _strip_springs(s, layer.strip_ends, layer.out_of_plane, linearised, parameters,
                               tension, geometry, layer.side_forces, layer.strip_springs)
        taken += sides_act(tau, lead, second_half, velocity, layer)
    buffers = layer.buffers
    horizontal, below, above = buffers[0], buffers[1], buffers[2]
    needs = layer.needs
    fresh = True  # whether ``below`` must be computed (the row below was not a band row)
    for j in range(ny):
        if needs[j] == NONE:
            fresh = True
            continue
        if fresh:
            _y_springs(j, 0, nx, x, y, z, linearised, parameters, tension, below)
        _y_springs(j + 1, 0, nx, x, y, z, linearised, parameters, tension, above)
        _x_springs(j, np.intp(0), nx + 1, x, y, z, linearised, parameters, tension, horizontal)
        taken += band_act(j, tau, lead, second_half, velocity, horizontal, below, above, layer,
                          0.0)
        below, above = above, below
        fresh = False
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
        self.rates = dict(  # 1/s
            node_x=peak * depth_profile(nx, left, right, 0.0) ** POWER,
            spring_x=peak * depth_profile(nx, left, right, -0.5) ** POWER,
            node_y=peak * depth_profile(ny, bottom, top, 0.0) ** POWER,
            spring_y=peak * depth_profile(ny, bottom, top, -0.5) ** POWER,
        )
        first_end = min(left + 1, nx) if left > 0 else 0  # with the first column inside
        last_start = max(nx - 1 - right, first_end) if right > 0 else nx
        # the side strips' slots (``sim.forces.absorbing_kicks``): the left strip column by
        # column, then the right
        widths_of_strips = (first_end, nx - last_start)
        self.geometry = np.array([*widths_of_strips, last_start, ny], dtype=np.int64)
        columns = np.concatenate([np.repeat(np.arange(first_end), ny),
                                  np.repeat(np.arange(last_start, nx), ny)]).astype(np.int64)
        rows = np.concatenate([np.tile(np.arange(ny), widths_of_strips[0]),
                               np.tile(np.arange(ny), widths_of_strips[1])]).astype(np.int64)
        self._slot_columns = columns
        slots = columns.size
        band_rows = np.arange(ny)
        band = ((bottom > 0) & (band_rows <= bottom)) | ((top > 0) & (band_rows >= ny - 1 - top))
        self.needs = np.where(band, BAND, NONE).astype(np.int64)
        self.masses = np.ascontiguousarray(model.masses, dtype=np.float64)
        self._inverse_masses = 1.0 / self.masses
        self._side_mass = np.ascontiguousarray(self.masses[rows, columns])
        self._side_inverse_mass = 1.0 / self._side_mass
        self._model = model
        # the fields: the side strips' x-fields (each particle's two held x-spring forces and
        # phi_x) and the y-fields over whole rows (held y-spring forces, phi_y)
        self.fields = (np.zeros((dim, slots)), np.zeros((dim, slots)), np.zeros((dim, slots)),
                       np.zeros((dim, ny + 1, nx)), np.zeros((dim, ny, nx)))
        self._side_forces = np.zeros((3, dim, slots))
        self._side_kicks = np.zeros((dim, slots))
        self._buffers = np.zeros((3, 3, nx + 1))
        self._strip_ends = np.zeros((3, max(widths_of_strips) + 2, ny + 2))
        self._strip_springs = np.zeros((3, ny + 1))
        self._factors: dict[float, tuple] = {}
        self._revision: int | None = None

    def factors(self, span: float) -> tuple:
        """exp(-rate span / 2) of the y-springs (ny + 1,) and the particles' rows (ny,), and of
        each side slot's left x-spring, right x-spring and particle (3, slots)."""
        factors = self._factors.get(span)
        if factors is None:
            def factor(name: str) -> np.ndarray:
                return np.exp(-0.5 * span * self.rates[name])
            spring_x, node_x = factor("spring_x"), factor("node_x")
            columns = self._slot_columns
            side = np.stack([spring_x[columns], spring_x[columns + 1], node_x[columns]])
            factors = (factor("spring_y"), factor("node_y"), np.ascontiguousarray(side))
            if len(self._factors) > 4:
                self._factors.clear()
            self._factors[span] = factors
        return factors

    def arguments(self, span: float, dtype: type = np.float64, threads: bool = False) -> LayerArguments:
        """The layer's record for spans of ``span`` on a state in ``dtype``, as ``act_on`` and
        the leapfrog sweep take it (positions in ``sim.forces.absorbing_kicks``); for the sweep on threads
        without the springs' parameters (None in their place)."""
        model = self._model
        gravity = np.array(model.gravity, dtype=dtype) if model.has_gravity else None
        held_left, held_right, relaxed_x, held_y, relaxed_y = self.fields
        spring_y, node_y, side_factors = self.factors(span)
        return LayerArguments(
            masses=self.masses, held_y=held_y, relaxed_y=relaxed_y, spring_y=spring_y,
            node_y=node_y, needs=self.needs, out_of_plane=True if model.dim == 3 else None,
            linearised=True if model.linear else None,
            parameters=None if threads else model.kernel_parameters.as_type(dtype),
            gravity=gravity, buffers=self._buffers, geometry=self.geometry, held_left=held_left,
            held_right=held_right, relaxed_x=relaxed_x, side_factors=side_factors,
            side_inverse_mass=self._side_inverse_mass, side_forces=self._side_forces,
            side_kicks=self._side_kicks, side_mass=self._side_mass,
            inverse_masses=self._inverse_masses, strip_ends=self._strip_ends,
            strip_springs=self._strip_springs)

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
