"""Movies of runs and recordings: ``oscillators movie`` (``app.movie.cli``) and, for code such
as the web page, ``render_movie(scene_or_simulation, path, ...)`` and
``movie_bytes(scene_or_simulation, kind, ...)`` (``app.movie.render``).  docs/recording.md
("Movies") describes the pictures, colours and measured speed."""

from app.movie.render import COLOURS, MovieOptions, movie_bytes, render_movie

__all__ = ["COLOURS", "MovieOptions", "movie_bytes", "render_movie"]
