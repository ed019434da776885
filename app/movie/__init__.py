"""Movies of runs and recordings, for the ``oscillators movie`` command and code such as the web
page: ``render_movie(scene_or_simulation, path, ...)`` and ``movie_bytes(scene_or_simulation,
kind, ...)`` (``app.movie.render``) with ``MovieOptions`` (``app.movie.options``), and one
self-contained HTML page that plays the run in 3-D: ``render_html`` (``app.movie.html``).
docs/recording.md ("Movies") describes the pictures, colours and measured speed.

The names are imported when first used (``__getattr__``): ``app.movie.options`` alone, which
the command line reads for its ``--help``, does not bring in the encoders and the 3-D page."""

from __future__ import annotations

import importlib
from typing import Any

_HOMES = {"render_html": "app.movie.html", "COLOURS": "app.movie.options",
          "MovieOptions": "app.movie.options", "movie_bytes": "app.movie.render",
          "render_movie": "app.movie.render"}

__all__ = ["COLOURS", "MovieOptions", "movie_bytes", "render_html", "render_movie"]


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'app.movie' has no attribute {name!r}")
    return getattr(importlib.import_module(_HOMES[name]), name)
