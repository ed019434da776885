"""Physical bodies given in physical units and discretised at any number of particles.

A ``Body`` is a string or a square membrane with fixed edges, given by its length L0 (m), its
mass density (kg/m for a string, kg/m^2 for a membrane), its tension (N for a string, N/m for a
membrane) and an initial ``Shape`` (released at rest).  ``body.model(n)`` discretises it with n
particles per side: spacing a = L0 / (n + 1) (the walls are the ends, one spacing beyond the
outermost particles), masses m = lambda a (string) or sigma a^2 (membrane), and springs chosen
so that the modulus K = k a (the paper's eq. 7) stays fixed: the same body at every n, whose
waves travel at c = sqrt(tension / density) in the continuum limit (the paper's eq. 10).

* **string**: one row of n particles.  A bead string of tension T obeys
  m u_i'' = (T / a) (u_{i+1} - 2 u_i + u_{i-1}) for its transverse displacement u; the
  lattice's rows always have wall springs above and below (``sim.model.boundaries``), which would add
  an on-site force 2 T / a to motion across the row, so the string is run as the row's motion
  *along* its springs with k = T / a and no pre-tension: exactly the same equations (the
  paper's eqs. 1-3), the displacement drawn across the string as usual.
* **membrane**: n x n particles in 3-D, pre-tensioned (rest length a / 10, spring tension
  T = S a for membrane tension S), moving out of the plane (z): m u'' = S (discrete Laplacian
  times a^2) u, the 2-D wave equation with speed sqrt(S / sigma).

Both are linearised (``linear=True``), so the lattice's own exact solution is the normal-mode
solution of ``sim.theory.exact``, and the continuum's is the Fourier series of ``sim.scenes.continuum``.
Shapes and their sine-series coefficients are here; coordinates s run from 0 to L0 along each
side (the lattice itself is centred on the origin, ``sim.model.lattice``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sim.integrators.registry import describe
from sim.model.lattice import Model, ModelError
from sim.scenes.building import Scene
from sim.theory.modes import sine_transform

DEFAULT_COURANT = 0.1
"""c dt / a of the first step tried: for velocity Verlet the time-stepping phase error is this
squared (1 %) of the lattice's dispersion error, mode by mode."""

BODY_KINDS = ("string", "membrane")
SHAPE_KINDS = ("gaussian", "sine", "pluck")
"""Initial shapes: a smooth Gaussian bump, one sine mode, a pluck (a triangle with a kink)."""

GAUSSIAN_WIDTHS = 4
"""A Gaussian's centre must be at least this many widths from each end (there it is below
exp(-8) of its peak; the straight line through its end values is taken off, so it is 0 there)."""

_FINE_POINTS = 4096
"""Fewest intervals of the grid the Gaussian's coefficients are summed on (and 4 per term)."""


@dataclasses.dataclass(frozen=True)
class Shape:
    """An initial displacement along one side, as a function of s / L0 in [0, 1].

    ``kind``: "gaussian" (exp(-(s - centre)^2 / (2 width^2)), lengths as fractions of L0, less
    the straight line through its values at the ends),
    "sine" (sin(mode pi s / L0)) or "pluck" (a triangle rising from both ends to its peak at
    ``centre``).  ``amplitude`` (m) is the largest displacement.  A membrane's shape is the
    product of the shape along x and the same shape along y (its mode is (mode, mode)).
    """

    kind: str = "gaussian"
    amplitude: float = 0.01
    centre: float = 0.5
    width: float = 1.0 / 12.0
    mode: int = 1

    def __post_init__(self) -> None:
        if self.kind not in SHAPE_KINDS:
            raise ModelError(f"shape must be one of {', '.join(SHAPE_KINDS)}, got {self.kind!r}")
        if not (math.isfinite(self.amplitude) and self.amplitude != 0.0):
            raise ModelError(f"amplitude must be a non-zero number of metres, got {self.amplitude!r}")
        if not 0.0 < self.centre < 1.0:
            raise ModelError(f"centre must lie strictly between the ends (0 < centre < 1), "
                             f"got {self.centre!r}")
        if not 0.0 < self.width <= 0.25:
            raise ModelError(f"width must be a fraction of the length in (0, 0.25], got {self.width!r}")
        if self.kind == "gaussian" and not (GAUSSIAN_WIDTHS * self.width <= self.centre
                                            <= 1.0 - GAUSSIAN_WIDTHS * self.width):
            raise ModelError(f"a Gaussian must lie {GAUSSIAN_WIDTHS} widths inside the ends: "
                             f"centre {self.centre:g} and width {self.width:g} do not fit")
        if isinstance(self.mode, bool) or int(self.mode) != self.mode or self.mode < 1:
            raise ModelError(f"mode must be a whole number >= 1, got {self.mode!r}")

    @property
    def smooth(self) -> bool:
        """Whether the shape is smooth (its sine coefficients fall faster than any power)."""
        return self.kind != "pluck"

    def values(self, fraction: np.ndarray) -> np.ndarray:
        """The shape (m) at s / L0 = ``fraction`` (any array shape)."""
        x = np.asarray(fraction, dtype=float)
        if self.kind == "sine":
            return self.amplitude * np.sin(self.mode * math.pi * x)
        if self.kind == "pluck":
            c = self.centre
            return self.amplitude * np.where(x <= c, x / c, (1.0 - x) / (1.0 - c))
        bump = np.exp(-((x - self.centre) ** 2) / (2.0 * self.width**2))
        ends = np.exp(-(np.array([self.centre, 1.0 - self.centre]) ** 2) / (2.0 * self.width**2))
        return self.amplitude * (bump - ends[0] * (1.0 - x) - ends[1] * x)  # exactly 0 at the ends

    def coefficients(self, terms: int) -> np.ndarray:
        """(terms,) sine-series coefficients b_1..b_terms (m): shape(s) = sum_n b_n sin(n pi s /
        L0) on 0 < s < L0 (b_n = 2 int_0^1 shape(x) sin(n pi x) dx)."""
        n = np.arange(1, terms + 1, dtype=float)
        if self.kind == "sine":
            return np.where(n == self.mode, self.amplitude, 0.0)
        if self.kind == "pluck":
            c = self.centre
            return 2.0 * self.amplitude * np.sin(n * math.pi * c) / (n**2 * math.pi**2 * c * (1 - c))
        # smooth and (to round-off) vanishing with its derivatives at the ends: the trapezoidal
        # rule of the discrete sine transform on a much finer grid is exact to round-off
        points = max(_FINE_POINTS, 4 * terms)
        x = np.arange(1, points) / points
        fine = sine_transform(self.values(x), 0) * math.sqrt(2.0 / points)
        return fine[:terms]

    def describe(self) -> str:
        if self.kind == "sine":
            return f"sine mode {self.mode}, amplitude {self.amplitude:g} m"
        if self.kind == "pluck":
            return f"pluck at {self.centre:g} L0, amplitude {self.amplitude:g} m"
        return (f"Gaussian at {self.centre:g} L0, width {self.width:.3g} L0, "
                f"amplitude {self.amplitude:g} m")


@dataclasses.dataclass(frozen=True)
class Body:
    """A string or square membrane in physical units (see the module docstring).

    ``length`` L0 (m); ``density`` lambda (kg/m) or sigma (kg/m^2); ``tension`` T (N) or S
    (N/m); ``shape`` the initial displacement, released at rest.
    """

    kind: str = "string"
    length: float = 1.0
    density: float = 0.01
    tension: float = 100.0
    shape: Shape = dataclasses.field(default_factory=Shape)

    def __post_init__(self) -> None:
        if self.kind not in BODY_KINDS:
            raise ModelError(f"body must be one of {', '.join(BODY_KINDS)}, got {self.kind!r}")
        for name in ("length", "density", "tension"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ModelError(f"{name} must be a positive number, got {value!r}")

    @classmethod
    def create(cls, kind: str = "string", shape: str = "gaussian", **values: Any) -> Body:
        """A body from plain values: ``shape`` names the shape kind; ``amplitude``, ``centre``,
        ``width`` and ``mode`` go to the ``Shape``, the rest to the body."""
        shape_fields = {key: values.pop(key) for key in ("amplitude", "centre", "width", "mode")
                        if key in values}
        return cls(kind=kind, shape=Shape(kind=shape, **shape_fields), **values)

    # --- physics of the continuum ---------------------------------------------------------------

    @property
    def dimensions(self) -> int:
        """1 for a string, 2 for a membrane (sides with particles)."""
        return 1 if self.kind == "string" else 2

    @property
    def speed(self) -> float:
        """Wave speed c = sqrt(tension / density) (m/s)."""
        return math.sqrt(self.tension / self.density)

    @property
    def crossing_time(self) -> float:
        """2 L0 / c (s): a wave's way there and back; the string's fundamental period."""
        return 2.0 * self.length / self.speed

    def describe(self) -> str:
        units = ("kg/m", "N") if self.kind == "string" else ("kg/m^2", "N/m")
        return (f"{self.kind} L0 = {self.length:g} m, density {self.density:g} {units[0]}, "
                f"tension {self.tension:g} {units[1]}, c = {self.speed:.4g} m/s; "
                f"{self.shape.describe()}")

    # --- the lattice at n particles per side ----------------------------------------------------

    def spacing(self, particles: int) -> float:
        """a = L0 / (n + 1) (m)."""
        return self.length / (particles + 1)

    def model(self, particles: int) -> Model:
        """The linearised lattice of ``particles`` per side (see the module docstring)."""
        if isinstance(particles, bool) or int(particles) != particles or particles < 1:
            raise ModelError(f"particles must be a whole number >= 1, got {particles!r}")
        n = int(particles)
        a = self.spacing(n)
        if self.kind == "string":
            return Model.create(nx=n, ny=1, dim=2, spacing=a, mass=self.density * a,
                                stiffness=self.tension / a, rest_length=a, linear=True)
        rest = 0.1 * a  # spring tension k (a - L) = S a with k = S a / (a - L)
        return Model.create(nx=n, ny=n, dim=3, spacing=a, mass=self.density * a * a,
                            stiffness=self.tension * a / (a - rest), rest_length=rest, linear=True)

    @property
    def component(self) -> int:
        """The displacement component that carries the wave: x (along the row) for the string,
        z (out of the plane) for the membrane."""
        return 0 if self.kind == "string" else 2

    def coordinates(self, particles: int) -> np.ndarray:
        """(n,) rest coordinates s = a, 2a, ..., n a of the particles along a side (m)."""
        return self.spacing(particles) * np.arange(1, particles + 1)

    def initial_field(self, particles: int) -> np.ndarray:
        """(ny, nx) initial displacement (m) of the lattice: the shape at the particles."""
        f = self.shape.values(self.coordinates(particles) / self.length)
        return f[None, :] if self.kind == "string" else np.outer(f, f) / self.shape.amplitude

    def field(self, model: Model, positions: np.ndarray) -> np.ndarray:
        """(ny, nx) displacement (m) of the wave component from (n_particles, dim) positions."""
        values = np.asarray(positions)[:, self.component] - model.rest_positions[:, self.component]
        return values.reshape(model.ny, model.nx)

    def first_step(self, particles: int, integrator: str = "verlet",
                   courant: float = DEFAULT_COURANT) -> float:
        """The first dt to try (s): courant * a / c, at most half the integrator's stability
        limit on the lattice's fastest mode (``app.study.continuum`` verifies it)."""
        dt = courant * self.spacing(particles) / self.speed
        limit = describe(integrator).stability_factor
        if limit is not None and math.isfinite(limit):
            omega_max = 2.0 * self.speed / self.spacing(particles) * math.sqrt(self.dimensions)
            dt = min(dt, 0.5 * limit / omega_max)
        return dt

    def scene(self, particles: int, integrator: str = "verlet", dt: float | None = None) -> Scene:
        """The body at ``particles`` per side as a scene, released at rest from its shape; the
        default dt is ``first_step``, its duration one crossing time."""
        model = self.model(particles)
        positions = model.rest_positions.copy()
        positions[:, self.component] += self.initial_field(particles).ravel()
        step = dt if dt is not None else self.first_step(particles, integrator)
        return Scene(name=f"{self.kind}-{particles}", model=model, integrator=integrator, dt=step,
                     description=f"{self.describe()}; {particles} particles per side",
                     initial_positions=positions, duration=self.crossing_time)
