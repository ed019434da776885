"""Rerun recordings of simulations: ``Recorder`` (a ``sim.runner.Runner`` subscriber that writes a
``.rrd`` file) and the ``oscillators record`` command (``app.recording.cli``).

See ``docs/recording.md`` for the file layout and how to open or analyse a recording.
"""

from app.recording.explain import RunInfo
from app.recording.recorder import (
    DETAIL_LIMIT,
    LoggingPlan,
    Recorder,
    RecordingError,
    RecordingOptions,
)
from app.recording.scales import ColourScales, look_ahead

__all__ = [
    "DETAIL_LIMIT", "ColourScales", "LoggingPlan", "Recorder", "RecordingError",
    "RecordingOptions", "RunInfo", "look_ahead",
]
