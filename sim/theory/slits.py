"""Where the bright and dark fringes of one or two slits fall on a screen: the theory lines drawn
over the measured intensity.

Slits are openings in a barrier column at x = ``barrier_x`` (m); the screen is the column at
x = ``screen_x`` (m) beyond it; positions along the screen are y (m).  A wave of angular frequency
omega leaves every opening as from a line of point sources.  Two kinds of prediction:

* **far field** (Fraunhofer, the textbook lines): maxima of two slits a distance d apart at
  d q_y = 2 pi m, minima of one slit of width w at w q_y = 2 pi m (m != 0), where q is the
  *lattice's* wave vector at omega (``sim.theory.lattice_waves``) whose group velocity (the ray) points
  from the slits' centre to the screen point at angle theta.  In a continuum q lies along the
  ray and q_y = 2 pi sin(theta) / lambda: the textbook d sin(theta) = m lambda.  On the lattice q
  leans off the ray (on the membrane at lambda = 7.8 a by 1.6 deg at theta = 25 deg, although
  |q| changes by only 1 % with direction), and the lines drawn with lambda along theta instead
  land 4-9 % short of the fringes;
* **ray phase** (no far-field approximation): the phase each opening's centre (or edge) sends to
  the screen point is the lattice's own ray phase (``Polarisation.phase``), so it holds for an
  anisotropic lattice and closer to the slits, where the far-field lines drift off.

Both return y positions (m) of the fringes that land on the screen (|y - centre| < half_height).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from sim.theory.lattice_waves import Polarisation

CONTOUR_SAMPLES = 4001
"""Wave vectors sampled along a quarter of the frequency's contour to find the far-field rays."""


@dataclasses.dataclass(frozen=True)
class Fringe:
    """A predicted fringe: its order m, kind ("maximum" or "minimum") and position y (m)."""

    order: int
    kind: str
    y: float


def two_slit_maxima_far_field(wave: Polarisation, omega: float, separation: float,
                              distance: float, centre: float = 0.0,
                              half_height: float = math.inf) -> list[Fringe]:
    """Maxima of two slits ``separation`` (m) apart at d q_y(theta) = 2 pi m (d sin(theta) = m
    lambda in a continuum), on a screen ``distance`` (m) beyond them; theta (the ray's
    direction) from the slits' centre at y = ``centre``."""
    return _far_field(wave, omega, separation, distance, centre, half_height, "maximum",
                      orders=range(0, 1 + int(separation / wave.wavelength(omega, 0.0)) + 1))


def single_slit_minima_far_field(wave: Polarisation, omega: float, width: float,
                                 distance: float, centre: float = 0.0,
                                 half_height: float = math.inf) -> list[Fringe]:
    """Minima of one slit of ``width`` (m) at w q_y(theta) = 2 pi m (w sin(theta) = m lambda in
    a continuum), m = 1, 2, ..."""
    return _far_field(wave, omega, width, distance, centre, half_height, "minimum",
                      orders=range(1, 1 + int(width / wave.wavelength(omega, 0.0)) + 1))


def two_slit_maxima_ray_phase(wave: Polarisation, omega: float, slit_centres: tuple[float, float],
                              distance: float, half_height: float, samples: int = 400
                              ) -> list[Fringe]:
    """Maxima where the ray phases from the two slits' centres differ by 2 pi m."""
    return _ray_phase_roots(wave, omega, slit_centres, distance, half_height, "maximum", samples)


def _ray_phase_roots(wave: Polarisation, omega: float, points: tuple[float, float],
                     distance: float, half_height: float, kind: str, samples: int
                     ) -> list[Fringe]:
    """Screen positions where the ray phases from the two ``points`` (y, m) on the slits' column
    differ by 2 pi m, as fringes of ``kind``."""
    low, high = points

    def difference(ys: np.ndarray) -> np.ndarray:
        return (ray_phases(wave, omega, distance, ys - low)
                - ray_phases(wave, omega, distance, ys - high))

    return _roots(difference, 0.5 * (low + high), half_height, kind, samples)


def ray_phases(wave: Polarisation, omega: float, dx: np.ndarray, dy: np.ndarray) -> np.ndarray:
    """``Polarisation.phase`` for many points at once (rad): q . r with q the wave vector whose
    ray points along (dx, dy) (m), read off one sampling of the frequency's whole contour."""
    angles = np.linspace(-math.pi, math.pi, 4 * CONTOUR_SAMPLES, endpoint=False)
    qx, qy, rays = wave.contour(omega, angles)
    keep = np.isfinite(rays)
    order = np.argsort(rays[keep])
    rays, qx, qy = rays[keep][order], qx[keep][order], qy[keep][order]
    wanted = np.arctan2(dy, dx)
    period = 2.0 * math.pi
    return (np.interp(wanted, rays, qx, period=period) * dx
            + np.interp(wanted, rays, qy, period=period) * dy)


def two_slit_intensity(wave: Polarisation, omega: float, slit_centres: tuple[float, float],
                       distance: float, ys: np.ndarray) -> np.ndarray:
    """The intensity (relative to its largest value) at ``ys`` (m) on a screen ``distance`` (m)
    beyond two narrow slits at y = ``slit_centres`` in a barrier of pinned particles: each slit
    a point source of the lattice's ray phase whose amplitude falls as cos(theta) / sqrt(r), as
    the wave of a narrow opening in a wall where the field vanishes does.  Its maxima lie a
    little inside the far-field lines (the falling amplitude pulls them toward the axis)."""
    ys = np.asarray(ys, dtype=float)
    total = np.zeros(ys.shape, complex)
    for centre in slit_centres:
        dy = ys - centre
        r = np.hypot(distance, dy)
        total += distance / r / np.sqrt(r) * np.exp(1j * ray_phases(wave, omega, distance, dy))
    intensity = np.abs(total) ** 2
    return intensity / intensity.max()


def two_source_maxima_far_field(wave: Polarisation, omega: float, separation: float,
                                distance: float, centre: float, half_height: float,
                                phase_difference: float) -> list[Fringe]:
    """Maxima of two point sources ``separation`` (m) apart along y, the upper one
    ``phase_difference`` (rad) ahead of the lower one, on a screen ``distance`` (m) away:
    where d q_y = 2 pi m - phase_difference (the textbook d sin(theta) = (m - dphi / 2 pi)
    lambda), theta (the ray) from the sources' centre at y = ``centre``; antiphase sources put a
    dark line on the bisector and the bright ones swing as the difference changes."""
    shift = math.remainder(phase_difference, 2.0 * math.pi) / (2.0 * math.pi)
    reach = int(separation / wave.wavelength(omega, 0.0)) + 2
    fringes = []
    for order in range(-reach, reach + 1):
        y = _ray_y(wave, omega, 2.0 * math.pi * (order - shift) / separation, distance)
        if y is not None and abs(y) < half_height:
            fringes.append(Fringe(order, "maximum", centre + y))
    return sorted(fringes, key=lambda fringe: fringe.y)


def _ray_y(wave: Polarisation, omega: float, qy: float, distance: float) -> float | None:
    """y (m) a screen ``distance`` (m) away where the ray whose wave vector has this q_y (rad/m)
    lands, or None when the lattice carries no such wave toward the screen."""
    _, contour_qy, rays = wave.contour(omega, np.linspace(0.0, 0.5 * math.pi, CONTOUR_SAMPLES))
    carried = np.isfinite(contour_qy) & np.isfinite(rays)
    contour_qy, rays = contour_qy[carried], rays[carried]
    if not contour_qy.size or abs(qy) > contour_qy[-1]:
        return None
    theta = float(np.interp(abs(qy), contour_qy, rays))
    if theta >= 0.5 * math.pi * (1.0 - 1e-9):
        return None
    return math.copysign(distance * math.tan(theta), qy)


def _far_field(wave: Polarisation, omega: float, size: float, distance: float, centre: float,
               half_height: float, kind: str, orders: range) -> list[Fringe]:
    fringes = []
    for order in orders:
        for sign in ((1,) if order == 0 else (1, -1)):
            y = _ray_y(wave, omega, 2.0 * math.pi * order / size, distance)
            if y is not None and abs(y) < half_height:
                fringes.append(Fringe(sign * order, kind, centre + sign * y))
    return sorted(fringes, key=lambda fringe: fringe.y)


def _roots(difference: Callable[[np.ndarray], np.ndarray], centre: float, half_height: float, kind: str,
           samples: int) -> list[Fringe]:
    """Positions y in (centre - half_height, centre + half_height) where ``difference(ys)`` (all
    samples at once) is a whole multiple of 2 pi, with m the multiple (m > 0 above the centre)."""
    ys = np.linspace(centre - half_height, centre + half_height, samples)
    cycles = np.asarray(difference(ys)) / (2.0 * math.pi)
    fringes = []
    for index in range(samples - 1):
        a, b = cycles[index], cycles[index + 1]
        for order in range(math.ceil(min(a, b)), math.floor(max(a, b)) + 1):
            if order == math.floor(max(a, b)) and order == max(a, b) and index + 1 < samples - 1:
                continue  # lands exactly on the next sample: found there
            fraction = (order - a) / (b - a) if b != a else 0.0
            y = ys[index] + fraction * (ys[index + 1] - ys[index])
            fringes.append(Fringe(order, kind, float(y)))
    return fringes
