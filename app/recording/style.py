"""Colours of recordings and movies: series lines readable on light and dark backgrounds, and
colour-bar legends drawn as small images.

Line colours are chosen so that their WCAG contrast ratio is at least 3 against white (rerun's
light theme) and against rerun's dark panel background (``DARK_BACKGROUND``); the tests check it.
Each integrator's lines take its colour from the integrator registry (``integrator_colour``).
The colour maps (springs, meshes, field images, mode energies) are those of ``app.colours``.
"""

from __future__ import annotations

import io
import math

import numpy as np

from app.colours import ENERGY_COLOURS, Colour, ColourMap
from sim.integrators.registry import IntegratorError, describe

WHITE: Colour = (255, 255, 255)
DARK_BACKGROUND: Colour = (13, 16, 17)
"""Rerun's dark-theme panel background (approximately)."""

TERM_COLOURS: dict[str, Colour] = ENERGY_COLOURS
"""The energy terms' line colours (``app.colours.ENERGY_COLOURS``)."""
DRIFT_COLOUR: Colour = (200, 40, 140)
"""The energy-balance error line of a single run."""
NEUTRAL_COLOUR: Colour = (128, 128, 128)
"""dt, field scale and other secondary lines; the rest positions."""
PARTICLE_COLOUR: Colour = (40, 110, 235)
ANCHOR_COLOUR: Colour = (128, 128, 128)


def integrator_colour(name: str | None) -> Colour:
    """The RGB of the energy-balance lines of the tree ``name``: its integrator's colour in a
    comparison (trees named after integrators), ``DRIFT_COLOUR`` for a single run (None) or a
    tree that is not named after an integrator."""
    if not name:
        return DRIFT_COLOUR
    try:
        return describe(name).colour
    except IntegratorError:
        return DRIFT_COLOUR


def relative_luminance(colour: Colour) -> float:
    """WCAG relative luminance of an sRGB colour (0 black, 1 white)."""

    def channel(value: int) -> float:
        v = value / 255.0
        return v / 12.92 if v <= 0.03928 else ((v + 0.055) / 1.055) ** 2.4

    r, g, b = (channel(v) for v in colour)
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def contrast_ratio(first: Colour, second: Colour) -> float:
    """WCAG contrast ratio (1 to 21) of two colours."""
    high, low = sorted((relative_luminance(first), relative_luminance(second)), reverse=True)
    return (high + 0.05) / (low + 0.05)


def nice_number(value: float) -> float:
    """``value`` rounded to 1, 2 or 5 times a power of ten (for exaggeration factors)."""
    if not (value > 0 and math.isfinite(value)):
        return 1.0
    exponent = math.floor(math.log10(value))
    for mantissa in (1.0, 2.0, 5.0, 10.0):
        if value <= mantissa * 10**exponent * 1.5:
            return mantissa * 10**exponent
    return 10.0 ** (exponent + 1)


def legend_png(
    colour_map: ColourMap, low: float, high: float, label: str, *, width: int = 520, height: int = 96,
    note: str | None = None,
) -> bytes:
    """A colour bar from ``low`` to ``high`` with five ticks and ``label`` (its unit in it), as PNG
    bytes of ``width`` x ``height`` pixels, drawn with Pillow (no matplotlib: its text parser is
    not safe to use from several threads, and recorders start in any thread)."""
    from PIL import Image, ImageDraw, ImageFont

    image = Image.new("RGB", (width, height), WHITE)
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=13)
    small = ImageFont.load_default(size=11)
    margin = 26
    bar_top, bar_height = 28, 18
    bar_width = width - 2 * margin
    table = colour_map.table()
    gradient = table[np.linspace(0, 255, bar_width).round().astype(int)]
    pixels = np.asarray(image).copy()
    pixels[bar_top : bar_top + bar_height, margin : margin + bar_width] = gradient[None]
    image = Image.fromarray(pixels)
    draw = ImageDraw.Draw(image)
    text = (40, 40, 40)
    draw.text((margin, 6), label, fill=text, font=font)
    for fraction in np.linspace(0.0, 1.0, 5):
        x = margin + fraction * (bar_width - 1)
        draw.line([(x, bar_top + bar_height), (x, bar_top + bar_height + 4)], fill=text)
        value = low + fraction * (high - low)
        draw.text((x, bar_top + bar_height + 5), f"{value:.3g}", fill=text, font=small,
                  anchor="ma")
    if note:
        draw.text((margin, height - 16), note, fill=(80, 80, 80), font=small)
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()
