"""A movie of a large lattice stops within a second of its cancel, wherever it is: in the
colour scales' look-ahead run before the first frame, or between frames."""

from __future__ import annotations

import time

import pytest

import sim
from app.movie import render_html, render_movie
from app.movie.render import MovieCancelled


@pytest.mark.parametrize("suffix", [".mp4", ".html"])
@pytest.mark.parametrize("cancel_after", [0.5, 6.0])
def test_a_large_movie_stops_within_a_second_of_its_cancel(tmp_path, suffix, cancel_after):
    scene = sim.scenes.build("grid", nx=700, ny=700)
    started = time.monotonic()
    asked: list[float] = []

    def on_frame(done: int, planned: int) -> bool:
        now = time.monotonic()
        if now - started < cancel_after:
            return True
        asked.append(asked[0] if asked else now)
        return False

    render = render_movie if suffix == ".mp4" else render_html
    with pytest.raises(MovieCancelled):
        render(scene, tmp_path / f"movie{suffix}", progress=False, max_frames=120,
               on_frame=on_frame)
    stopped = time.monotonic()
    assert asked and stopped - (started + cancel_after) < 1.0, stopped - started
    assert not (tmp_path / f"movie{suffix}").exists()
