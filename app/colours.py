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
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

Colour = tuple[int, int, int]


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
