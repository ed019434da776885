"""The ripple tank: scenes of sources, slits and a screen on the out-of-plane displacement u_z of a
pre-tensioned 3-D membrane, and the fringe theory of any scene with a slit barrier.

Why the membrane: for small displacements u_z obeys the scalar 5-point wave equation with the
springs' tension T / a = k (a - L) / a as the spring constant both along and across the rows
(``sim.theory.lattice_waves``), so its waves are isotropic at long wavelengths (circles from a point
source, speed a sqrt(T / (a m))), which is what a ripple tank shows and what d sin(theta) = m
lambda assumes.  The in-plane components of the same lattice are anisotropic (an ellipse from a
point source: u_y travels at sqrt(T / (a m)) along x but sqrt(k / m) along y).  The presets are
linearised (``linear=True``), so u_z is exactly that scalar equation.

``PARAMETERS`` holds the ``Model.create`` parameters of the presets two-sources, single-slit and
double-slit (``sim.scenes.presets`` makes them presets); ``SlitSetup.of(model)`` reads the slit geometry
of a scene (its first barrier along a column with one or two openings, its sources' frequency and
component) and gives the screen column and the theory lines (``sim.theory.slits``) with the lattice's
own wavelength at the driving frequency.  Lengths in m, frequencies in Hz, angles in rad.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from sim.theory import lattice_waves, slits

STIFFNESS = 35.0
REST_LENGTH = 0.8
SPONGE = 20
"""Depth of the absorbing layer along every wall (particles)."""
SPONGE_STRENGTH = 2.0
"""Its peak rate in units of sqrt(k/m): a deep layer, gentler at its inner edge than the default
thin one, so the strength is the tanks' own."""
FRINGE_FREQUENCY = 0.33
"""Driving frequency of two-sources and double-slit (Hz): lambda = 7.8 a on the membrane."""
SINGLE_SLIT_FREQUENCY = 0.33
"""Driving frequency of single-slit (Hz): lambda = 7.8 a."""


def _membrane(nx: int, ny: int, **extra: Any) -> dict[str, Any]:
    return dict(nx=nx, ny=ny, dim=3, stiffness=STIFFNESS, rest_length=REST_LENGTH, linear=True,
                boundary="absorbing", sponge_width=SPONGE,
                sponge_strength=SPONGE_STRENGTH, **extra)


def _plane_wave(frequency: float) -> list[dict[str, Any]]:
    """A force on every particle of the column just inside the left layer, out of the plane."""
    return [dict(column=SPONGE + 2, row="all", direction="z", amplitude=0.01,
                 frequency=frequency, kind="force", ramp=3.0)]


_POINT = dict(direction="z", amplitude=0.02, frequency=FRINGE_FREQUENCY, kind="force", ramp=3.0)

PARAMETERS: dict[str, dict[str, Any]] = {
    "two-sources": _membrane(140, 140, sources=[dict(_POINT, column=70, row=62),
                                                dict(_POINT, column=70, row=78, phase=0.0)]),
    # 201 rows: the walls' layers start 80 a from the axis, beyond the fringes the screen shows
    "single-slit": _membrane(190, 201, sources=_plane_wave(SINGLE_SLIT_FREQUENCY),
                             barriers=[{"column": 45, "openings": [[91, 109]]}]),
    "double-slit": _membrane(190, 201, sources=_plane_wave(FRINGE_FREQUENCY),
                             barriers=[{"column": 45, "openings": [[89, 91], [109, 111]]}]),
}

DESCRIPTIONS = {
    "two-sources": "Two point sources 16 a apart in the middle of a 140x140 ripple tank (the "
    "out-of-plane u_z of a pre-tensioned membrane, absorbing walls), driven in phase at "
    f"{FRINGE_FREQUENCY} Hz (lambda = 7.8 a): fixed nodal lines fan out between them.  Change "
    "the second source's phase to swing the nodal lines.",
    "single-slit": "A plane wave from the left (lambda = 7.8 a) through one slit 20 a wide in a "
    "barrier of pinned particles; absorbing walls.  The screen near the right wall shows the "
    "central maximum and its first minima at w sin(theta) = lambda.",
    "double-slit": "A plane wave from the left (lambda = 7.8 a) through two slits 20 a apart in "
    "a barrier of pinned particles; absorbing walls.  The screen near the right wall shows the "
    "fringes at d sin(theta) = m lambda, lambda from the lattice's dispersion.",
}


class SlitError(ValueError):
    """The scene has no slit barrier or no source to predict fringes from."""


@dataclasses.dataclass(frozen=True)
class SlitSetup:
    """A barrier column's openings and the drive that lights them.

    ``barrier_x`` (m); ``openings`` ((low, high) y of the pinned particles either side of each
    opening, m: the field vanishes there, so a slit of particles first..last is (last - first +
    2) a wide); ``frequency`` (Hz) and ``component`` ("x", "y" or "z") of the first source.
    """

    barrier_x: float
    openings: tuple[tuple[float, float], ...]
    frequency: float
    component: str

    @classmethod
    def of(cls, model: Any) -> SlitSetup:
        """The setup of ``model``'s first column barrier; raises ``SlitError`` without one."""
        barrier = next((b for b in model.barriers if b.axis == "column" and b.openings), None)
        drivers = ((model.driver,) if model.driver is not None else ()) + tuple(model.sources)
        if barrier is None or not drivers:
            raise SlitError("fringe theory needs a column barrier with openings and a source")
        x0, y0 = model.origin
        a = model.spacing
        openings = tuple((y0 + (first - 1) * a, y0 + (last + 1) * a)
                         for first, last in barrier.openings)
        direction = drivers[0].direction
        component = "xyz"[max(range(model.dim), key=lambda c: abs(direction[c]))]
        return cls(x0 + barrier.index * a, openings, drivers[0].frequency, component)

    @property
    def centre(self) -> float:
        """y of the middle between the outermost openings (m): where angles are measured from."""
        return 0.5 * (self.openings[0][0] + self.openings[-1][1])

    def wavelength(self, model: Any) -> float:
        """The lattice's wavelength (m) at the driving frequency along x."""
        wave = lattice_waves.polarisation(model, self.component)
        return wave.wavelength(2.0 * math.pi * self.frequency, 0.0)

    def theory(self, model: Any, screen_column: int) -> list[slits.Fringe]:
        """The far-field fringes on ``screen_column``: two slits' maxima (the first two
        openings), or one slit's minima."""
        wave = lattice_waves.polarisation(model, self.component)
        omega = 2.0 * math.pi * self.frequency
        x0, _ = model.origin
        distance = x0 + screen_column * model.spacing - self.barrier_x
        if distance <= 0:
            raise SlitError("the screen must stand beyond the barrier")
        half_height = 0.5 * (model.ny - 1) * model.spacing
        if len(self.openings) >= 2:
            low, high = (0.5 * sum(opening) for opening in self.openings[:2])
            return slits.two_slit_maxima_far_field(wave, omega, high - low, distance,
                                                   0.5 * (low + high), half_height)
        low, high = self.openings[0]
        return slits.single_slit_minima_far_field(wave, omega, high - low, distance,
                                                  0.5 * (low + high), half_height)


def default_screen_column(model: Any) -> int:
    """A screen column just inside the right wall's absorbing layer (or 5 from the wall)."""
    inset = model.sponge_width if "right" in model.sponge_sides else 0
    return max(0, model.nx - 1 - inset - 5)
