"""The colour bars of a recording (``/legend/<name>``): one PNG for each thing it colours, with
the fixed scale and its unit (``app.recording.style.legend_png``)."""

from __future__ import annotations

from app.colours import MAGNITUDE, SIGNED_FIELD, SIGNED_LINES
from app.recording.instruments import mode_legend_png
from app.recording.options import LoggingPlan
from app.recording.scales import AXIS_NAMES, SIGNED, UNITS, ColourScales
from app.recording.style import legend_png

LEGEND_HEIGHT = 96
"""Height of every colour bar (pixels); they are stacked with a gap of 8 pixels."""


def colour_legends(plan: LoggingPlan, scales: ColourScales, field_scale: float,
                   exaggeration: float) -> dict[str, tuple[bytes, int]]:
    """{name: (PNG bytes, height in pixels)} of the colour bars for what ``plan`` colours:
    springs (strain), the 3-D surface (height, drawn ``exaggeration`` times larger), the field
    (its quantity, on ``field_scale``) and the mode energies."""
    legends: dict[str, tuple[bytes, int]] = {}
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
        signed = plan.quantity in SIGNED
        label = (f"field: displacement u_{AXIS_NAMES[scales.axis]} (m)" if signed
                 else f"field: {plan.quantity} ({UNITS[plan.quantity]})")
        legends["field"] = (legend_png(
            SIGNED_FIELD if signed else MAGNITUDE,
            -field_scale if signed else 0.0, field_scale, label), LEGEND_HEIGHT)
    if plan.modes_every:
        legends["modes"] = (mode_legend_png(scales.energy), LEGEND_HEIGHT)
    return legends
