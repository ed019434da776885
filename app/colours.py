"""The colour maps of every picture the program draws, as one registry.

A ``ColourMap`` is a named (256, 3) uint8 RGB lookup table and the rule that maps values onto it:
signed maps run from -scale (first entry) through zero (the middle) to +scale (last entry),
magnitude maps from 0 to scale.  The web page, the recordings, the movies and the colour bars all
take their maps from here (``get(name)``), so a map is changed or added in one place.

* ``signed-field``: matplotlib's ``RdBu_r`` (white at zero), for field images that fill their own
  pixels (the paper's pictures);
* ``signed-lines``: blue - mid grey - red, for springs and meshes drawn over a light or a dark
  background (a white middle would vanish on a light one);
* ``magnitude``: ``inferno`` (black at zero), for |u| and speeds |v|;
* ``strain``: blue (compressed) - light grey (at rest length) - red (stretched), springs on the
  web page.

A ``Scheme`` says how one *quantity* is coloured everywhere (page, movies, recordings): its
label, units, colour map (for field images and for springs/spheres) and default scale policy.
A scale policy (``SCALES``: ``fixed``, ``adaptive``, ``symlog``) turns values into positions on
the map; ``make_scale(policy, limit)`` gives a ``ColourScale`` that a sequence of pictures
(a movie, the page) feeds frame by frame (``observe``) and that the colour bar reads
(``ticks``, ``describe``), so the bar always shows the scale in use at that moment:

* ``fixed``: linear, the limit chosen once (e.g. from a look-ahead run);
* ``adaptive``: linear, the limit follows the field's current amplitude (the ``PERCENTILE``-th
  percentile of |value| of each frame), smoothed over ``SMOOTHING_SECONDS`` simulated seconds in
  log space so it does not flicker; it rises at once when the field outgrows it;
* ``symlog``: symmetric logarithm with a fixed outer limit: linear within ``limit / SYMLOG_RANGE``
  of zero, logarithmic beyond, so amplitudes over three decades all show;
* ``adaptive-symlog`` (the default of every scheme): both, the limit following the field and
  the map logarithmic, so a wave that fills the lattice shows everywhere it has arrived.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

Colour = tuple[int, int, int]

ENERGY_COLOURS: dict[str, Colour] = {  # RGB of each energy term's line, on the page and in recordings
    "kinetic": (220, 90, 30),
    "potential": (40, 110, 235),
    "spring": (40, 110, 235),
    "gravity": (140, 86, 75),
    "total": (150, 70, 200),
    "dissipated": (150, 120, 30),
    "driven": (0, 140, 140),
}
"""One colour per energy term wherever it is drawn (the page's Energy plot, recordings, movies);
"potential" (springs and gravity together) takes the springs' colour.  Each has a WCAG contrast
of at least 3 on white and on rerun's dark panels (``tests/test_recording.py``)."""


def hex_colour(colour: Colour) -> str:
    """``#rrggbb`` of an RGB colour, for the page's plots."""
    return "#{:02x}{:02x}{:02x}".format(*colour)



@dataclasses.dataclass(frozen=True)
class ColourMap:
    """One colour map: ``matplotlib`` names a matplotlib map, else ``stops`` gives the RGB of the
    low end, the middle and the high end, joined by straight lines."""

    name: str
    label: str
    signed: bool
    matplotlib: str | None = None
    stops: tuple[Colour, Colour, Colour] | None = None

    def table(self) -> np.ndarray:
        """(256, 3) uint8 RGB lookup table (read-only, computed once)."""
        return _table(self)

    def map(self, values: np.ndarray, scale: float) -> np.ndarray:
        """``values`` -> uint8 RGB with the shape of ``values`` plus (3,): signed maps from -scale
        to +scale, magnitude maps |values| from 0 to scale (saturating beyond)."""
        scale = scale if scale > 0 else 1.0
        if self.signed:
            return map_values(values, -scale, scale, self.table())
        return map_values(np.abs(values), 0.0, scale, self.table())


@functools.lru_cache(maxsize=16)
def _table(colour_map: ColourMap) -> np.ndarray:
    x = np.linspace(0.0, 1.0, 256)
    if colour_map.stops is not None:
        low, middle, high = (np.array(c, float) for c in colour_map.stops)
        t = np.where(x < 0.5, x * 2.0, (x - 0.5) * 2.0)[:, None]
        table = np.where((x < 0.5)[:, None], low + (middle - low) * t, middle + (high - middle) * t)
        table = np.round(table).astype(np.uint8)
    else:
        from matplotlib import colormaps

        table = np.round(colormaps[colour_map.matplotlib](x)[:, :3] * 255).astype(np.uint8)
    table.setflags(write=False)
    return table


def map_values(values: np.ndarray, low: float, high: float, table: np.ndarray) -> np.ndarray:
    """Values mapped linearly from [low, high] onto ``table`` (saturating outside): uint8 RGB with
    the shape of ``values`` plus (3,)."""
    indices = np.subtract(values, low, dtype=np.float32)
    indices *= np.float32(255.0 / (high - low))
    np.clip(indices, 0.0, 255.0, out=indices)
    indices += np.float32(0.5)
    return table[indices.astype(np.uint8)]


_REGISTRY: dict[str, ColourMap] = {}


def register(colour_map: ColourMap) -> ColourMap:
    """Add (or replace) a colour map; every view that offers maps sees it."""
    _REGISTRY[colour_map.name] = colour_map
    return colour_map


def get(name: str) -> ColourMap:
    """The colour map called ``name``; a clear error lists the known ones."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown colour map {name!r}; known: {', '.join(_REGISTRY)}") from None


def names() -> tuple[str, ...]:
    """Names of the registered colour maps, in registration order."""
    return tuple(_REGISTRY)


SIGNED_FIELD = register(ColourMap("signed-field", "blue - white - red", True, matplotlib="RdBu_r"))
SIGNED_LINES = register(ColourMap(
    "signed-lines", "blue - grey - red", True, stops=((30, 80, 230), (128, 128, 128), (225, 40, 30)),
))
MAGNITUDE = register(ColourMap("magnitude", "inferno (black at rest)", False, matplotlib="inferno"))
STRAIN = register(ColourMap(
    "strain", "compressed blue - relaxed grey - stretched red", True,
    stops=((40, 110, 230), (170, 170, 170), (230, 60, 40)),
))


# --- scale policies ------------------------------------------------------------------------------

PERCENTILE = 99.0
"""Adaptive scales: the limit follows this percentile of |value| in each frame."""
SMOOTHING_SECONDS = 4.0
"""Adaptive scales: time constant (simulated s) of the smoothing of the limit (in log space)."""
SAMPLE = 20_000
"""Values of a frame an adaptive scale looks at (an even stride through the frame)."""
SYMLOG_RANGE = 1000.0
"""Symlog scales: the linear part is limit / SYMLOG_RANGE wide."""


class ColourScale:
    """The scale of one sequence of pictures: values -> positions on a colour map.

    ``fraction(values)`` gives float32 positions in [0, 1] (signed: 0.5 at zero) for
    ``ColourMap.table`` lookups; ``observe(values, time)`` lets the scale follow a frame;
    ``limit`` is the value (units of the quantity) at the map's end; ``ticks()`` gives
    (position, value) pairs for a colour bar; ``describe()`` says the scale in words.  This base
    class is the ``fixed`` policy: linear, the limit never changes."""

    policy = "fixed"
    follows = False
    logarithmic = False

    def __init__(self, limit: float, signed: bool, floor: float = 0.0) -> None:
        self.limit = limit if limit > 0 and math.isfinite(limit) else 1.0
        self.signed = signed
        self.floor = floor
        self._time: float | None = None

    def observe(self, values: np.ndarray, time: float) -> None:
        """Follow one frame's values (simulated time ``time`` s): adaptive policies move the
        limit towards the frame's ``PERCENTILE``-th percentile of |value|, smoothed; a first
        frame, a time going backwards (a reset) or a field above the limit sets it at once."""
        if not self.follows:
            return
        flat = np.abs(np.asarray(values).ravel())
        if flat.size == 0:
            return
        sample = flat[:: max(1, flat.size // SAMPLE)]
        target = float(np.percentile(sample, PERCENTILE))
        # a field that is zero almost everywhere (a pulse just started) still shows its front
        target = max(target, 0.02 * float(flat.max()), self.floor)
        if not (target > 0 and math.isfinite(target)):
            return
        if self._time is None or time < self._time or target > self.limit:
            self.limit = target
        else:
            weight = 1.0 - math.exp(-(time - self._time) / SMOOTHING_SECONDS)
            self.limit = math.exp(math.log(self.limit)
                                  + weight * (math.log(target) - math.log(self.limit)))
        self._time = time

    def _normalised(self, magnitudes: np.ndarray) -> np.ndarray:
        """|value| -> [0, 1]: linear, or the symmetric logarithm."""
        if not self.logarithmic:
            return np.minimum(magnitudes * np.float32(1.0 / self.limit), np.float32(1.0))
        width = self.limit / SYMLOG_RANGE
        result = np.log1p(magnitudes * np.float32(1.0 / width)) * np.float32(
            1.0 / math.log1p(SYMLOG_RANGE))
        return np.minimum(result, np.float32(1.0)).astype(np.float32)

    def value_at(self, fraction: float) -> float:
        """|value| at ``fraction`` in [0, 1] of the way from zero to the limit."""
        if not self.logarithmic:
            return fraction * self.limit
        return self.limit / SYMLOG_RANGE * math.expm1(fraction * math.log1p(SYMLOG_RANGE))

    def values(self, fractions: np.ndarray) -> np.ndarray:
        """The inverse of ``fraction``: positions on the map (float, [0, 1]) -> values (float32),
        e.g. to read a colour-mapped picture back on the scale it was drawn with."""
        fractions = np.asarray(fractions, dtype=np.float32)
        if self.signed:
            magnitudes = np.minimum(np.abs(fractions - np.float32(0.5)) * np.float32(2.0), 1.0)
            sign = np.sign(fractions - np.float32(0.5))
        else:
            magnitudes, sign = np.clip(fractions, 0.0, 1.0), np.float32(1.0)
        if self.logarithmic:
            result = np.float32(self.limit / SYMLOG_RANGE) * np.expm1(
                magnitudes * np.float32(math.log1p(SYMLOG_RANGE)))
        else:
            result = magnitudes * np.float32(self.limit)
        return (sign * result).astype(np.float32)

    def fraction(self, values: np.ndarray) -> np.ndarray:
        values = np.asarray(values, dtype=np.float32)
        if not self.signed:
            return self._normalised(np.abs(values))
        return np.float32(0.5) + np.float32(0.5) * np.sign(values) * self._normalised(np.abs(values))

    def ticks(self) -> list[tuple[float, float]]:
        """(position along the bar in [0, 1], value) for a colour bar's labels: zero, the limit
        and its half (linear) or limit / SYMLOG_RANGE**0.5 (logarithmic), both signs."""
        if self.logarithmic:
            middle = self.limit / math.sqrt(SYMLOG_RANGE)
            inner = float(self._normalised(np.array([middle], np.float32))[0])
        else:
            middle, inner = 0.5 * self.limit, 0.5
        marks = [(0.0, 0.0), (inner, middle), (1.0, self.limit)]
        if not self.signed:
            return marks
        positive = [(0.5 + 0.5 * f, v) for f, v in marks]
        return [(1.0 - p, -v) for p, v in reversed(positive[1:])] + positive

    def describe(self) -> str:
        """The scale in words, for a colour bar's caption."""
        kind = "log" if self.logarithmic else "linear"
        if self.follows:
            return f"{kind} scale following the field ({PERCENTILE:g}th percentile, smoothed)"
        return f"{kind} scale, fixed"


class AdaptiveScale(ColourScale):
    """Linear, the limit following the field (smoothed ``PERCENTILE``-th percentile)."""

    policy = "adaptive"
    follows = True


class SymlogScale(ColourScale):
    """Symmetric logarithm (linear within limit / ``SYMLOG_RANGE`` of zero), fixed limit."""

    policy = "symlog"
    logarithmic = True


class AdaptiveSymlogScale(ColourScale):
    """Symmetric logarithm whose limit follows the field: waves of every amplitude show."""

    policy = "adaptive-symlog"
    follows = True
    logarithmic = True


SCALES: dict[str, type[ColourScale]] = {kind.policy: kind for kind in (
    ColourScale, AdaptiveScale, SymlogScale, AdaptiveSymlogScale)}
"""The scale policies by name."""


def make_scale(policy: str, limit: float, signed: bool, floor: float = 0.0) -> ColourScale:
    """A fresh ``ColourScale`` of ``policy`` starting at ``limit``; ``floor``: the smallest limit
    an adaptive scale goes down to (so rounding noise of a lattice at rest stays uncoloured)."""
    try:
        kind = SCALES[policy]
    except KeyError:
        raise ValueError(f"unknown colour scale {policy!r}; known: {', '.join(SCALES)}") from None
    return kind(limit, signed, floor)


# --- one scheme per quantity ---------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Scheme:
    """How ``quantity`` is coloured in every picture: ``label`` and ``units`` for colour bars,
    ``field`` the map of field images, ``lines`` the map of springs and particles drawn over a
    background, ``scale`` the default scale policy (one of ``SCALES``)."""

    quantity: str
    label: str
    units: str
    field: ColourMap
    lines: ColourMap
    scale: str

    @property
    def signed(self) -> bool:
        return self.field.signed

    def colour(self, values: np.ndarray, scale: ColourScale, lines: bool = False) -> np.ndarray:
        """uint8 RGB with the shape of ``values`` plus (3,) on the scale in use."""
        table = (self.lines if lines else self.field).table()
        return colour_fractions(scale.fraction(values), table)

    def title(self) -> str:
        """The colour bar's title: quantity and units."""
        return f"{self.label} ({self.units})"


def colour_fractions(fractions: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Positions in [0, 1] -> uint8 RGB from ``table`` (256, 3)."""
    indices = np.asarray(fractions, dtype=np.float32) * np.float32(255.0) + np.float32(0.5)
    np.clip(indices, 0.0, 255.0, out=indices)
    return table[indices.astype(np.uint8)]


_SCHEMES: dict[str, Scheme] = {}


def register_scheme(scheme: Scheme) -> Scheme:
    """Add (or replace) the scheme of ``scheme.quantity``."""
    if scheme.scale not in SCALES:
        raise ValueError(f"unknown colour scale {scheme.scale!r}")
    _SCHEMES[scheme.quantity] = scheme
    return scheme


def scheme(quantity: str) -> Scheme:
    """The colour scheme of ``quantity``; a clear error lists the known ones."""
    try:
        return _SCHEMES[quantity]
    except KeyError:
        raise ValueError(f"no colour scheme for {quantity!r}; known: {', '.join(_SCHEMES)}") from None


register_scheme(Scheme("displacement", "displacement", "m", SIGNED_FIELD, SIGNED_LINES, "adaptive-symlog"))
register_scheme(Scheme("magnitude", "displacement |u|", "m", MAGNITUDE, MAGNITUDE, "adaptive-symlog"))
register_scheme(Scheme("speed", "speed |v|", "m/s", MAGNITUDE, MAGNITUDE, "adaptive-symlog"))
register_scheme(Scheme("strain", "spring strain - rest strain", "dimensionless", SIGNED_FIELD,
                       SIGNED_LINES, "adaptive-symlog"))
register_scheme(Scheme("density", "density change rho/rho_0 - 1", "dimensionless", SIGNED_FIELD,
                       SIGNED_LINES, "adaptive-symlog"))


def colour_bar(quantity_scheme: Scheme, scale: ColourScale, label: str | None = None, *,
               width: int = 480, height: int = 84, lines: bool = False) -> np.ndarray:
    """A colour bar as a (height, width, 3) uint8 RGB picture on white: the title (``label``,
    default the scheme's quantity and units), the map, the numbers of ``scale`` at its ticks
    (the end ones kept inside the picture) and the scale in words.  Drawn with Pillow."""
    from PIL import Image, ImageDraw, ImageFont

    image = Image.new("RGB", (width, height), (255, 255, 255))
    text = (30, 30, 30)
    font = ImageFont.load_default(size=max(9, round(height * 0.17)))
    small = ImageFont.load_default(size=max(8, round(height * 0.14)))
    margin = round(0.03 * width)
    bar_top, bar_height = round(height * 0.27), round(height * 0.2)
    bar_width = width - 2 * margin
    table = (quantity_scheme.lines if lines else quantity_scheme.field).table()
    pixels = np.asarray(image).copy()
    pixels[bar_top : bar_top + bar_height, margin : margin + bar_width] = \
        table[np.linspace(0, 255, bar_width).round().astype(int)][None]
    image = Image.fromarray(pixels)
    draw = ImageDraw.Draw(image)
    draw.text((margin, bar_top - 2), label or quantity_scheme.title(), fill=text, font=font,
              anchor="lb")
    marks = scale.ticks()
    for k, (position, value) in enumerate(marks):
        x = margin + position * (bar_width - 1)
        draw.line([(x, bar_top + bar_height), (x, bar_top + bar_height + 3)], fill=text)
        anchor = "la" if k == 0 else "ra" if k == len(marks) - 1 else "ma"
        draw.text((x, bar_top + bar_height + 4), f"{value:.2g}" if value else "0", fill=text,
                  font=small, anchor=anchor)
    draw.text((margin, height - 2), scale.describe(), fill=(90, 90, 90), font=small, anchor="lb")
    return np.asarray(image)
