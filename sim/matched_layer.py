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
layer's own fields in float64 (N): ``held_x`` (dim, ny, nx + 1) h of the x-springs (spring i
joins particle i - 1, or the left anchor, to particle i), ``held_y`` (dim, ny + 1, nx) h of the
y-springs, ``relaxed_x`` and ``relaxed_y`` (dim, ny, nx) phi_x and phi_y.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim.kernels import gravity_vector, site, spring_force

_JIT = dict(cache=True, nogil=True, error_model="numpy")
_INLINE = dict(_JIT, inline="always")
"""The per-particle and per-spring functions are inlined by numba itself: a call per particle
that passes a dozen arrays costs their reference counting (ten times the arithmetic)."""

POWER = 2
"""Exponent of the rate's growth with depth."""


@njit(**_INLINE)
def _end(position, j, i, parameters):
    """Particle (j, i) as a spring end at rest (``sim.kernels``), or the wall anchor there."""
    dim, ny, nx = position.shape
    zero = type(parameters.spacing)(0.0)
    if 0 <= j < ny and 0 <= i < nx:
        return (position[0, j, i], position[1, j, i], position[2, j, i] if dim == 3 else zero,
                zero, zero, zero)
    return site(i, j, parameters)


@njit(**_INLINE)
def _spring(position, j0, i0, j1, i1, axis, linearised, parameters, tension):
    """Force (N) on the first end of the spring from (j0, i0) to (j1, i1) beyond the one it
    carries at rest (``tension`` along its axis): the lattice's own law."""
    force = spring_force(_end(position, j0, i0, parameters), _end(position, j1, i1, parameters),
                         axis, linearised, parameters, None)
    if axis == 0:
        return float(force[0]) - tension, float(force[1]), float(force[2])
    return float(force[0]), float(force[1]) - tension, float(force[2])


@njit(**_JIT)
def _relax_springs(position, held_x, held_y, spring_x, spring_y, columns, rows, linearised,
                   parameters, tension):
    """Relax each spring's held force toward its force: h = f + (h - f) e (e the factor)."""
    dim, ny, nx = position.shape
    for j in range(ny):
        for i in columns:
            e = spring_x[i]
            force = _spring(position, j, i - 1, j, i, 0, linearised, parameters, tension)
            for c in range(dim):
                held_x[c, j, i] = force[c] + (held_x[c, j, i] - force[c]) * e
    for j in rows:
        e = spring_y[j]
        for i in range(nx):
            force = _spring(position, j - 1, i, j, i, 1, linearised, parameters, tension)
            for c in range(dim):
                held_y[c, j, i] = force[c] + (held_y[c, j, i] - force[c]) * e


@njit(**_INLINE)
def _particle(tau, lead, j, i, position, velocity, masses, held_x, held_y, relaxed_x,
              relaxed_y, node_x, node_y, linearised, parameters, tension, gravity):
    """Relax phi of particle (j, i) over tau / 2, kick it by tau, relax again; returns the
    kinetic energy taken out (J), measured on v + lead * a (a its springs' and gravity's
    acceleration)."""
    dim = position.shape[0]
    ex = node_x[i]
    ey = node_y[j]
    mass = masses[j, i]
    left = _spring(position, j, i - 1, j, i, 0, linearised, parameters, tension)
    right = _spring(position, j, i, j, i + 1, 0, linearised, parameters, tension)
    below = _spring(position, j - 1, i, j, i, 1, linearised, parameters, tension)
    above = _spring(position, j, i, j + 1, i, 1, linearised, parameters, tension)
    pull = gravity_vector(gravity, 0.0)
    before = 0.0
    after = 0.0
    for c in range(dim):
        force_x = right[c] - left[c]
        force_y = above[c] - below[c]
        # the x-springs' relaxed force F_x* and what the relaxation holds of it; y likewise
        holding_x = held_x[c, j, i + 1] - held_x[c, j, i]
        target_x = force_x - holding_x
        phi_x = target_x + (relaxed_x[c, j, i] - target_x) * ex
        holding_y = held_y[c, j + 1, i] - held_y[c, j, i]
        target_y = force_y - holding_y
        phi_y = target_y + (relaxed_y[c, j, i] - target_y) * ey
        v = velocity[c, j, i]
        ahead = lead * ((force_x + force_y) / mass + pull[c])
        before += (float(v) + ahead) ** 2
        v = v + tau * (-holding_x - phi_x - holding_y - phi_y) / mass
        velocity[c, j, i] = v
        after += (float(v) + ahead) ** 2
        relaxed_x[c, j, i] = target_x + (phi_x - target_x) * ex
        relaxed_y[c, j, i] = target_y + (phi_y - target_y) * ey
    return 0.5 * mass * (before - after)


@njit(**_JIT)
def act(tau, lead, position, velocity, masses, held_x, held_y, relaxed_x, relaxed_y, spring_x,
        spring_y, node_x, node_y, columns, rows, widths, linearised, parameters, gravity):
    """The layer's action over ``tau`` seconds at frozen positions (see the module docstring).

    ``spring_x`` (nx + 1,), ``spring_y`` (ny + 1,), ``node_x`` (nx,), ``node_y`` (ny,): the
    factors exp(-sigma tau / 2) of the springs and particles (1 outside the layer);
    ``columns`` and ``rows`` the x-spring columns and y-spring rows with sigma' > 0; ``widths``
    (4,) the left, right, bottom and top layer depths.  ``linearised`` (None or True),
    ``parameters`` (``sim.kernels.SpringParameters`` in the state's precision) and ``gravity``
    ((3,) m/s^2 or None): the lattice's law, as its kernels take it.  Returns the kinetic
    energy taken out (J), counted on the velocities ``lead`` seconds later under the lattice's
    forces (dt / 2 for a leapfrog's half-step velocities, else 0)."""
    dim, ny, nx = position.shape
    left, right, bottom, top = widths[0], widths[1], widths[2], widths[3]
    tension = float(spring_force(site(0, 0, parameters), site(1, 0, parameters), 0, linearised,
                                 parameters, None)[0])
    _relax_springs(position, held_x, held_y, spring_x, spring_y, columns, rows, linearised,
                   parameters, tension)
    # the particles the layer acts on: its own and the first row or column inside it, which
    # one relaxing spring touches
    first_end = min(left + 1, nx) if left > 0 else 0
    last_start = max(nx - 1 - right, first_end) if right > 0 else nx
    taken = 0.0
    for j in range(ny):
        if (bottom > 0 and j <= bottom) or (top > 0 and j >= ny - 1 - top):
            spans = ((0, nx), (nx, nx))
        else:
            spans = ((0, first_end), (last_start, nx))
        for span in spans:
            for i in range(span[0], span[1]):
                taken += _particle(tau, lead, j, i, position, velocity, masses, held_x, held_y,
                                   relaxed_x, relaxed_y, node_x, node_y, linearised, parameters,
                                   tension, gravity)
    _relax_springs(position, held_x, held_y, spring_x, spring_y, columns, rows, linearised,
                   parameters, tension)
    return taken


@njit(**_JIT)
def act_on(tau, lead, position, velocity, layer):
    """``act`` with its arguments after the state's arrays as one tuple ``layer``
    (``MatchedLayer.arguments``), for the compiled step loops."""
    return act(tau, lead, position, velocity, layer[0], layer[1], layer[2], layer[3], layer[4],
               layer[5], layer[6], layer[7], layer[8], layer[9], layer[10], layer[11],
               layer[12], layer[13], layer[14])


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
        self.columns = np.flatnonzero(self.rates["spring_x"] > 0).astype(np.int64)
        self.rows = np.flatnonzero(self.rates["spring_y"] > 0).astype(np.int64)
        self.masses = np.ascontiguousarray(model.masses, dtype=np.float64)
        self._model = model
        self.fields = (np.zeros((dim, ny, nx + 1)), np.zeros((dim, ny + 1, nx)),
                       np.zeros((dim, ny, nx)), np.zeros((dim, ny, nx)))
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
        return (self.masses, *self.fields, *self.factors(span), self.columns, self.rows,
                self.widths, True if model.linear else None,
                model.kernel_parameters.as_type(dtype), gravity)

    def follow(self, state: Any) -> None:
        """Start the fields from rest when the state was changed from outside."""
        if self._revision != state.revision:
            for field in self.fields:
                field[...] = 0.0
            self._revision = state.revision

    def act(self, state: Any, span: float) -> None:
        """The layer's action over ``span`` seconds; its take adds to ``state.dissipated``."""
        self.follow(state)
        state.dissipated += act(span, 0.0, state.positions, state.velocities,
                                *self.arguments(span, state.positions.dtype.type))
