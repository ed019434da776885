"""Where the bright and dark fringes of one or two slits fall on a screen: the theory lines drawn
over the measured intensity.

Slits are openings in a barrier column at x = ``barrier_x`` (m); the screen is the column at
x = ``screen_x`` (m) beyond it; positions along the screen are y (m).  A wave of angular frequency
omega leaves every opening as from a line of point sources.  Two kinds of prediction:

* **far field** (Fraunhofer, the textbook lines): maxima of two slits a distance d apart at
  d sin(theta) = m lambda, minima of one slit of width w at w sin(theta) = m lambda (m != 0),
  theta measured from the slits' centre, with lambda the *lattice's* wavelength at omega along
  theta (``sim.lattice_waves``), not the continuum's;
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

from sim.lattice_waves import Polarisation


@dataclasses.dataclass(frozen=True)
class Fringe:
    """A predicted fringe: its order m, kind ("maximum" or "minimum") and position y (m)."""

    order: int
    kind: str
    y: float


def two_slit_maxima_far_field(wave: Polarisation, omega: float, separation: float,
                              distance: float, centre: float = 0.0,
                              half_height: float = math.inf) -> list[Fringe]:
    """Maxima of two slits ``separation`` (m) apart at d sin(theta) = m lambda(theta), on a screen
    ``distance`` (m) beyond them; theta from the slits' centre at y = ``centre``."""
    return _far_field(wave, omega, separation, distance, centre, half_height, "maximum",
                      orders=range(0, 1 + int(separation / wave.wavelength(omega, 0.0)) + 1))


def single_slit_minima_far_field(wave: Polarisation, omega: float, width: float,
                                 distance: float, centre: float = 0.0,
                                 half_height: float = math.inf) -> list[Fringe]:
    """Minima of one slit of ``width`` (m) at w sin(theta) = m lambda(theta), m = 1, 2, ..."""
    return _far_field(wave, omega, width, distance, centre, half_height, "minimum",
                      orders=range(1, 1 + int(width / wave.wavelength(omega, 0.0)) + 1))


def two_slit_maxima_ray_phase(wave: Polarisation, omega: float, slit_centres: tuple[float, float],
                              distance: float, half_height: float, samples: int = 400
                              ) -> list[Fringe]:
    """Maxima where the ray phases from the two slits' centres differ by 2 pi m."""
    low, high = slit_centres

    def difference(y: float) -> float:
        return wave.phase(omega, distance, y - low) - wave.phase(omega, distance, y - high)

    centre = 0.5 * (low + high)
    return _roots(difference, centre, half_height, "maximum", samples)


def single_slit_minima_ray_phase(wave: Polarisation, omega: float, edges: tuple[float, float],
                                 distance: float, half_height: float, samples: int = 400
                                 ) -> list[Fringe]:
    """Minima where the ray phases from the slit's two edges differ by 2 pi m (m != 0)."""
    low, high = edges

    def difference(y: float) -> float:
        return wave.phase(omega, distance, y - low) - wave.phase(omega, distance, y - high)

    centre = 0.5 * (low + high)
    return [fringe for fringe in _roots(difference, centre, half_height, "minimum", samples)
            if fringe.order != 0]


def _far_field(wave: Polarisation, omega: float, size: float, distance: float, centre: float,
               half_height: float, kind: str, orders: range) -> list[Fringe]:
    fringes = []
    for order in orders:
        for sign in ((1,) if order == 0 else (1, -1)):
            theta = _solve_angle(lambda angle, m=order: size * math.sin(angle)
                                 - m * wave.wavelength(omega, angle))
            if theta is None:
                continue
            y = centre + sign * distance * math.tan(theta)
            if abs(y - centre) < half_height:
                fringes.append(Fringe(sign * order, kind, y))
    return sorted(fringes, key=lambda fringe: fringe.y)


def _solve_angle(function: Callable[[float], float]) -> float | None:
    """The angle in [0, pi/2) where ``function`` changes sign (bisection), or None."""
    low, high = 0.0, 0.5 * math.pi * (1.0 - 1e-9)
    f_low, f_high = function(low), function(high)
    if f_low == 0.0:
        return 0.0
    if f_low * f_high > 0.0:
        return None
    for _ in range(100):
        middle = 0.5 * (low + high)
        f_middle = function(middle)
        if (f_middle < 0.0) == (f_low < 0.0):
            low, f_low = middle, f_middle
        else:
            high = middle
    return 0.5 * (low + high)


def _roots(difference: Callable[[float], float], centre: float, half_height: float, kind: str,
           samples: int) -> list[Fringe]:
    """Positions y in (centre - half_height, centre + half_height) where ``difference(y)`` is a
    whole multiple of 2 pi, with m the multiple (m > 0 above the centre)."""
    ys = np.linspace(centre - half_height, centre + half_height, samples)
    cycles = np.array([difference(float(y)) for y in ys]) / (2.0 * math.pi)
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
