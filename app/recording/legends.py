"""The colour bars of a recording (``/legend/<name>``): one picture for each thing it colours,
with its scale and unit.

The springs', the surface's and the mode energies' bars are static (their scales are fixed,
``app.recording.style.legend_png``).  The field's bar is the one the page and the movies draw
(``app.colours.colour_bar``): it shows the numbers of the scale in use, so when the field's scale
follows the field (``app.recording.field``) a new bar is logged, at that frame's time, whenever
its numbers change (``FieldLegend``); the viewer shows the bar of the moment on screen.
"""

from __future__ import annotations

import io

import numpy as np
import rerun as rr

from app.colours import SIGNED_LINES, ColourScale, colour_bar, scheme
from app.recording.instruments import mode_legend_png
from app.recording.options import LoggingPlan
from app.recording.scales import AXIS_NAMES, SIGNED, UNITS, ColourScales
from app.recording.style import legend_png

LEGEND_HEIGHT = 96
"""Height of every colour bar (pixels); they are stacked with a gap of 8 pixels."""
LEGEND_WIDTH = 520
"""Width of every colour bar (pixels)."""


def field_label(plan: LoggingPlan, axis: int) -> str:
    """The field bar's title: the quantity (the displacement's component) and its unit."""
    if plan.quantity in SIGNED:
        return f"field: displacement u_{AXIS_NAMES[axis]} (m)"
    return f"field: {plan.quantity} ({UNITS[plan.quantity]})"


def field_legend_png(label: str, quantity: str, scale: ColourScale) -> bytes:
    """The field's colour bar on ``scale`` (its numbers at this moment) as PNG bytes."""
    from PIL import Image

    picture = colour_bar(scheme(quantity), scale, label, width=LEGEND_WIDTH, height=LEGEND_HEIGHT)
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(picture)).save(buffer, format="PNG")
    return buffer.getvalue()


class FieldLegend:
    """``/legend/field``: logged at the stream's current time when the bar's numbers change."""

    def __init__(self, entity: str, label: str, quantity: str) -> None:
        self.entity = entity
        self.label = label
        self.quantity = quantity
        self.shown: str | None = None
        self.logged = 0
        """Bars logged so far."""

    def update(self, stream: rr.RecordingStream, scale: ColourScale) -> None:
        numbers = " ".join(f"{value:.2g}" for _, value in scale.ticks())
        if numbers == self.shown:
            return
        png = field_legend_png(self.label, self.quantity, scale)
        stream.log(self.entity, rr.EncodedImage(contents=png, media_type="image/png"))
        self.shown = numbers
        self.logged += 1


def colour_legends(plan: LoggingPlan, scales: ColourScales,
                   exaggeration: float) -> dict[str, tuple[bytes | None, int]]:
    """{name: (PNG bytes, height in pixels)} of the colour bars for what ``plan`` colours:
    springs (strain), the 3-D surface (height, drawn ``exaggeration`` times larger), the field
    (None: its bars are logged frame by frame, ``FieldLegend``) and the mode energies."""
    legends: dict[str, tuple[bytes | None, int]] = {}
    if plan.springs:
        legends["strain"] = (legend_png(
            SIGNED_LINES, -scales.strain, scales.strain,
            "springs: strain - rest strain (dimensionless)",
            note="blue compressed, grey as at rest, red stretched"), LEGEND_HEIGHT)
    if plan.surface:
        legends["height"] = (legend_png(
            SIGNED_LINES, -scales.height, scales.height,
            f"surface: height z (m), drawn ×{exaggeration:g}",
            note="blue below the plane, red above"), LEGEND_HEIGHT)
    if plan.field:
        legends["field"] = (None, LEGEND_HEIGHT)
    if plan.modes_every:
        legends["modes"] = (mode_legend_png(scales.energy), LEGEND_HEIGHT)
    return legends
