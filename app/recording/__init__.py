"""Rerun recordings of simulations: ``Recorder`` (a ``sim.runtime.runner.Runner`` subscriber that writes a
``.rrd`` file, ``app.recording.recorder``) with what to log (``RecordingOptions``,
``app.recording.options``) and the fixed colour scales (``look_ahead``, ``app.recording.scales``).
The ``oscillators record`` command uses them.

See ``docs/recording.md`` for the file layout and how to open or analyse a recording.
"""

from app.recording.destination import RecordingError
from app.recording.explain import RunInfo
from app.recording.options import DETAIL_LIMIT, LoggingPlan, RecordingOptions
from app.recording.recorder import Recorder
from app.recording.scales import ColourScales, look_ahead

__all__ = [
    "DETAIL_LIMIT", "ColourScales", "LoggingPlan", "Recorder", "RecordingError",
    "RecordingOptions", "RunInfo", "look_ahead",
]
