"""Rerun recordings of simulations: ``Recorder`` (a ``sim.runner.Runner`` subscriber that writes a
``.rrd`` file) and the ``oscillators record`` command (``app.recording.cli``).

See ``docs/recording.md`` for the file layout and how to open or analyse a recording.
"""

from app.recording.recorder import (
    DETAIL_LIMIT,
    LoggingPlan,
    Recorder,
    RecordingError,
    RecordingOptions,
)

__all__ = ["DETAIL_LIMIT", "LoggingPlan", "Recorder", "RecordingError", "RecordingOptions"]
