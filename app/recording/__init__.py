"""Rerun recordings of simulations: ``Recorder`` (a ``sim.runtime.runner.Runner`` subscriber that writes a
``.rrd`` file, ``app.recording.recorder``) with what to log (``RecordingOptions``,
``app.recording.options``) and the fixed colour scales (``look_ahead``, ``app.recording.scales``).
The ``oscillators record`` command uses them.

See ``docs/recording.md`` for the file layout and how to open or analyse a recording.
"""

import importlib

_HOMES = {
    "RecordingError": "destination", "RunInfo": "explain", "DETAIL_LIMIT": "options",
    "LoggingPlan": "options", "RecordingOptions": "options", "Recorder": "recorder",
    "ColourScales": "scales", "look_ahead": "scales",
}
"""Where each name lives: imported at first use, so that what needs only the options (the
command line's parsers) does not load rerun."""


def __getattr__(name: str):
    if name in _HOMES:
        return getattr(importlib.import_module(f"app.recording.{_HOMES[name]}"), name)
    raise AttributeError(f"module 'app.recording' has no attribute {name!r}")


__all__ = [
    "DETAIL_LIMIT", "ColourScales", "LoggingPlan", "Recorder", "RecordingError",
    "RecordingOptions", "RunInfo", "look_ahead",
]
