"""Movies of runs and recordings, for the ``oscillators movie`` command and code such as the web
page: ``render_movie(scene_or_simulation, path, ...)`` and ``movie_bytes(scene_or_simulation,
kind, ...)`` (``app.movie.render``) with ``MovieOptions`` (``app.movie.options``), and one
self-contained HTML page that plays the run in 3-D: ``render_html`` (``app.movie.html``).
docs/recording.md ("Movies") describes the pictures, colours and measured speed."""

from app.movie.html import render_html
from app.movie.options import COLOURS, MovieOptions
from app.movie.render import movie_bytes, render_movie

__all__ = ["COLOURS", "MovieOptions", "movie_bytes", "render_html", "render_movie"]
