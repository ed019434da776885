"""The absorbing layer as a perfectly matched layer (PML) of the lattice: graded damping of the
springs' stretch and of the forces along the wall's normal, over the border rows and columns.

Why not a plain drag: a wave meets a fixed wall behind the layer, where its velocity vanishes, so
a drag on the velocity barely touches a wave whose quarter wavelength is as deep as the layer,
and a drag strong enough to stop it reflects shorter ones.  The matched layer is the lattice
form of the stretched coordinate x -> x + (1 / i omega) integral sigma_x dx: in the layer along
the left and right walls

    m u''  =  F_y + F_x* - phi_x,       F_x* = F_x - K (p_right - p_left)    (x-springs relaxed)
    p'     =  sigma'_x (s - p)          for each x-spring: s its stretch u_second - u_first
    phi_x' =  sigma_x (F_x* - phi_x)    for each particle

(u displacement from rest, m; K the spring's small-motion stiffness: k along it, T / a across;
F_x the x-springs' force on the particle, N).  In the frequency domain this is
-omega^2 m u = D_x(K D_x u / s_x) / s_x + F_y, s_x = 1 + sigma_x / (i omega): the continuum's
reflectionless layer, with the lattice's own differences.  The layers along the bottom and top
walls do the same with y; a corner does both.  The rate grows with the depth d into the layer
(0 at its inner edge, 1 next to the wall) as sigma = strength * omega_0 * d^POWER, omega_0 =
sqrt(k / m_mean); sigma' is the same profile at the springs' midpoints.

Stepping (``MatchedLayer.act``): the lattice's integrator moves the particles under their springs
alone; between its steps this module acts over a span tau with the positions frozen (operator
splitting): relax p and phi over tau / 2, kick the velocities by tau (-K (p_right - p_left) -
phi) / m, relax over tau / 2 again.  The relaxations are exact exponentials, so the layer never
limits the stable step.  The kinetic energy a kick takes out is returned (J): the lattice's
energy changes only by those kicks, so kinetic + potential + dissipated stays constant.

Arrays: the state's (dim, ny, nx) positions (m) and velocities (m/s) in float64 or float32; the
layer's own fields in float64: ``stretch`` (dim, ny, nx + 1) p of the x-springs (spring i joins
particle i - 1, or the left anchor, to particle i), ``stretch_y`` (dim, ny + 1, nx) p of the
y-springs, ``relaxed_x`` and ``relaxed_y`` (dim, ny, nx) phi_x and phi_y (N).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim.kernels import gravity_vector, site, spring_force

_JIT = dict(cache=True, nogil=True, error_model="numpy")

POWER = 2
"""Exponent of the rate's growth with depth."""


@njit(**_JIT)
def _displacement(position, rest, c, j, i, ny, nx):
    """Displacement (m) of particle (j, i) along component c; 0 for a wall anchor."""
    if i < 0 or i >= nx or j < 0 or j >= ny:
        return 0.0
    return float(position[c, j, i]) - rest[c, j, i]


@njit(**_JIT)
def _relax_springs(position, rest, stretch, stretch_y, spring_x, spring_y, columns, rows):
    """Relax each spring's p toward its stretch: p = s + (p - s) f (f the span's factor)."""
    dim, ny, nx = position.shape
    for j in range(ny):
        for i in columns:
            f = spring_x[i]
            for c in range(dim):
                s = (_displacement(position, rest, c, j, i, ny, nx)
                     - _displacement(position, rest, c, j, i - 1, ny, nx))
                stretch[c, j, i] = s + (stretch[c, j, i] - s) * f
    for j in rows:
        f = spring_y[j]
        for i in range(nx):
            for c in range(dim):
                s = (_displacement(position, rest, c, j, i, ny, nx)
                     - _displacement(position, rest, c, j - 1, i, ny, nx))
                stretch_y[c, j, i] = s + (stretch_y[c, j, i] - s) * f


@njit(**_JIT)
def _end(position, j, i, parameters):
    """Particle (j, i) as a spring end at rest (``sim.kernels``), or the wall anchor there."""
    dim, ny, nx = position.shape
    zero = type(parameters.spacing)(0.0)
    if 0 <= j < ny and 0 <= i < nx:
        return (position[0, j, i], position[1, j, i], position[2, j, i] if dim == 3 else zero,
                zero, zero, zero)
    return site(i, j, parameters)


@njit(**_JIT)
def _lattice_acceleration(j, i, position, parameters, gravity, mass):
    """Acceleration (m/s^2) of particle (j, i) under its four springs' nonlinear law and
    gravity (``sim.kernels``), as the undamped leapfrog computes it."""
    me = _end(position, j, i, parameters)
    left = spring_force(_end(position, j, i - 1, parameters), me, 0, None, parameters, None)
    right = spring_force(me, _end(position, j, i + 1, parameters), 0, None, parameters, None)
    below = spring_force(_end(position, j - 1, i, parameters), me, 1, None, parameters, None)
    above = spring_force(me, _end(position, j + 1, i, parameters), 1, None, parameters, None)
    pull = gravity_vector(gravity, type(parameters.spacing)(0.0))
    return ((right[0] - left[0] + above[0] - below[0]) / mass + pull[0],
            (right[1] - left[1] + above[1] - below[1]) / mass + pull[1],
            (right[2] - left[2] + above[2] - below[2]) / mass + pull[2])


@njit(**_JIT)
def _particle(tau, lead, j, i, position, velocity, rest, masses, along, across, stretch,
              stretch_y, relaxed_x, relaxed_y, node_x, node_y, parameters, gravity):
    """Relax phi of particle (j, i) over tau / 2, kick it by tau, relax again; returns the
    kinetic energy taken out (J), measured on v + lead * a (a its springs' acceleration: the
    nonlinear law's with ``parameters``, else the small-motion one)."""
    dim, ny, nx = position.shape
    fx = node_x[i]
    fy = node_y[j]
    mass = masses[j, i]
    before = 0.0
    after = 0.0
    exact = (0.0, 0.0, 0.0)
    if parameters is not None and lead != 0.0:
        exact = _lattice_acceleration(j, i, position, parameters, gravity, mass)
    for c in range(dim):
        kx = along if c == 0 else across
        ky = along if c == 1 else across
        u = _displacement(position, rest, c, j, i, ny, nx)
        # x-springs: the relaxed force F_x* and the relaxation's part of it
        left = u - _displacement(position, rest, c, j, i - 1, ny, nx)
        right = _displacement(position, rest, c, j, i + 1, ny, nx) - u
        held_x = kx * (stretch[c, j, i + 1] - stretch[c, j, i])
        target_x = kx * (right - left) - held_x
        phi_x = target_x + (relaxed_x[c, j, i] - target_x) * fx
        below = u - _displacement(position, rest, c, j - 1, i, ny, nx)
        above = _displacement(position, rest, c, j + 1, i, ny, nx) - u
        held_y = ky * (stretch_y[c, j + 1, i] - stretch_y[c, j, i])
        target_y = ky * (above - below) - held_y
        phi_y = target_y + (relaxed_y[c, j, i] - target_y) * fy
        v = velocity[c, j, i]
        if parameters is not None:
            ahead = lead * float(exact[c])
        else:
            ahead = lead * (kx * (right - left) + ky * (above - below)) / mass
        before += (float(v) + ahead) ** 2
        v = v + tau * (-held_x - phi_x - held_y - phi_y) / mass
        velocity[c, j, i] = v
        after += (float(v) + ahead) ** 2
        relaxed_x[c, j, i] = target_x + (phi_x - target_x) * fx
        relaxed_y[c, j, i] = target_y + (phi_y - target_y) * fy
    return 0.5 * mass * (before - after)


@njit(**_JIT)
def act(tau, lead, position, velocity, rest, masses, along, across, stretch, stretch_y, relaxed_x,
        relaxed_y, spring_x, spring_y, node_x, node_y, columns, rows, widths, parameters=None,
        gravity=None):
    """The layer's action over ``tau`` seconds at frozen positions (see the module docstring).

    ``spring_x`` (nx + 1,), ``spring_y`` (ny + 1,), ``node_x`` (nx,), ``node_y`` (ny,): the
    factors exp(-sigma tau / 2) of the springs and particles (1 outside the layer);
    ``columns`` and ``rows`` the x-spring columns and y-spring rows with sigma' > 0; ``widths``
    (4,) the left, right, bottom and top layer depths.  ``along`` k and ``across`` T / a (N/m).
    ``parameters`` (``sim.kernels.SpringParameters``) and ``gravity`` ((3,) m/s^2 or None):
    the nonlinear law the velocities are led with (None: the small-motion law).
    Returns the kinetic energy taken out (J), counted on the velocities ``lead`` seconds later
    under the springs alone (dt / 2 for a leapfrog's half-step velocities, else 0)."""
    dim, ny, nx = position.shape
    left, right, bottom, top = widths[0], widths[1], widths[2], widths[3]
    _relax_springs(position, rest, stretch, stretch_y, spring_x, spring_y, columns, rows)
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
                taken += _particle(tau, lead, j, i, position, velocity, rest, masses, along,
                                   across, stretch, stretch_y, relaxed_x, relaxed_y, node_x,
                                   node_y, parameters, gravity)
    _relax_springs(position, rest, stretch, stretch_y, spring_x, spring_y, columns, rows)
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
        peak = strength * omega_0
        self.rates = dict(  # 1/s
            node_x=peak * depth_profile(nx, left, right, 0.0) ** POWER,
            spring_x=peak * depth_profile(nx, left, right, -0.5) ** POWER,
            node_y=peak * depth_profile(ny, bottom, top, 0.0) ** POWER,
            spring_y=peak * depth_profile(ny, bottom, top, -0.5) ** POWER,
        )
        self.columns = np.flatnonzero(self.rates["spring_x"] > 0).astype(np.int64)
        self.rows = np.flatnonzero(self.rates["spring_y"] > 0).astype(np.int64)
        self.rest = np.ascontiguousarray(model.rest_positions.T.reshape(dim, ny, nx),
                                         dtype=np.float64)
        self.masses = np.ascontiguousarray(model.masses, dtype=np.float64)
        parameters = model.kernel_parameters
        self.along = float(parameters.stiffness)
        self.across = float(parameters.tension_stiffness)
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

    def arguments(self, span: float) -> tuple:
        """Everything ``act`` takes after the state's arrays, for spans of ``span``."""
        return (self.rest, self.masses, self.along, self.across, *self.fields,
                *self.factors(span), self.columns, self.rows, self.widths)

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
                                *self.arguments(span))


@njit(**_JIT)
def act_on(tau, lead, position, velocity, layer, parameters=None, gravity=None):
    """``act`` with its arguments after the state's arrays as one tuple ``layer``
    (``MatchedLayer.arguments``), for the compiled step loops."""
    return act(tau, lead, position, velocity, layer[0], layer[1], layer[2], layer[3], layer[4],
               layer[5], layer[6], layer[7], layer[8], layer[9], layer[10], layer[11],
               layer[12], layer[13], layer[14], parameters, gravity)
