"""Movie labels say what is true: a title that does not fit is shrunk, then cut after a whole
word (never mid-number); a movie of a running simulation is labelled with the run's own time."""

from __future__ import annotations

import dataclasses

from PIL import Image, ImageDraw

import sim
from app.movie.options import MovieOptions
from app.movie.painter import _fit_title, _title
from app.movie.render import _source


def test_a_long_title_is_cut_after_a_whole_word():
    scene = sim.scenes.build("interference")
    text = _title(scene)
    draw = ImageDraw.Draw(Image.new("RGB", (10, 10)))
    for width in (1280, 640, 320):
        fitted, font = _fit_title(draw, text, 30, int(width * 0.72))
        assert draw.textlength(fitted, font=font) <= int(width * 0.72)
        if fitted != text:
            assert fitted.endswith(" …"), fitted
            kept = fitted[: -len(" …")]
            assert text.startswith(kept) and text[len(kept)] in " ,;:(", (fitted, text)
    assert "682x38…" not in _fit_title(draw, text, 30, int(1280 * 0.72))[0]


def test_a_movie_of_a_running_simulation_says_the_run_time():
    simulation = sim.Simulation(sim.scenes.build("grid"))
    simulation.step(150)
    options = dataclasses.replace(MovieOptions().resolved("mp4"), frames=3, duration=0.5)
    source = _source(simulation, options)
    times = [state.time for state in source.states(False, False)]
    assert times[0] == simulation.time and abs(times[0] - 1.5) < 1e-9
    assert abs(times[-1] - 2.0) < 1e-9
    assert "from t = 1.50 s" in source.summary
