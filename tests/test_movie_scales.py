"""Colour scales that keep the waves visible: the scale policies of ``app.colours`` against their
definitions, and decoded movie frames of the interference run in which most of the lattice shows
the field (the default, adaptive log scale) where a fixed linear scale leaves it blank."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from app import colours
from app.cli import main
from tests.test_movie import decoded, picture_box


def test_symlog_scale_is_linear_near_zero_and_logarithmic_beyond():
    scale = colours.make_scale("symlog", 1.0, signed=True)
    width = 1.0 / colours.SYMLOG_RANGE
    values = np.array([-1.0, -width, 0.0, 1e-3 * width, width, 10 * width, 1.0, 5.0])
    fractions = scale.fraction(values)
    top = math.log1p(colours.SYMLOG_RANGE)
    expected = 0.5 + 0.5 * np.sign(values) * np.minimum(np.log1p(np.abs(values) / width) / top, 1)
    np.testing.assert_allclose(fractions, expected, atol=1e-6)
    # every tick label is the value found at its position on the bar
    for position, value in scale.ticks():
        assert scale.fraction(np.array([value]))[0] == pytest.approx(position, abs=1e-6)


def test_adaptive_scale_follows_the_amplitude_smoothly():
    scale = colours.make_scale("adaptive", 1.0, signed=True)
    rng = np.random.default_rng(1)
    field = rng.standard_normal(50_000)
    scale.observe(field, 0.0)
    first = scale.limit
    assert first == pytest.approx(np.percentile(np.abs(field), colours.PERCENTILE), rel=0.05)
    # the field weakens tenfold: the limit follows with the smoothing time constant, no jump
    limits = []
    for k in range(1, 41):
        scale.observe(0.1 * field, 0.5 * k)
        limits.append(scale.limit)
    assert all(b <= a for a, b in zip(limits, limits[1:], strict=False))
    step = 1 - math.exp(-0.5 / colours.SMOOTHING_SECONDS)  # one 0.5 s frame, in log space
    assert limits[0] == pytest.approx(first * 0.1**step, rel=0.05)
    assert limits[-1] == pytest.approx(0.1 * first, rel=0.1)  # after 20 s = 5 time constants
    # the field grows past the limit: the scale rises at once (no saturated frames)
    scale.observe(3 * field, 21.0)
    assert scale.limit == pytest.approx(3 * first, rel=0.05)
    fixed = colours.make_scale("fixed", 2.0, signed=False)
    fixed.observe(field, 0.0)
    assert fixed.limit == 2.0


def shown_fraction(frame: np.ndarray, box: tuple[int, int, int, int]) -> float:
    """Share of the picture's pixels whose colour differs visibly from the colour of zero."""
    x0, y0, width, height = box
    picture = frame[y0 + 2 : y0 + height - 2, x0 + 2 : x0 + width - 2].astype(int)
    zero = colours.SIGNED_FIELD.table()[128].astype(int)
    return float((np.abs(picture - zero).max(axis=2) > 30).mean())


def middle_and_end_fractions(tmp_path, arguments: list[str], size: tuple[int, int],
                             scene) -> list[float]:
    path = tmp_path / "movie.mp4"
    assert main(["movie", *arguments, "-o", str(path), "--frames", "3", "--size",
                 f"{size[0]}x{size[1]}", "--quiet", "--force"]) == 0
    frames, _, _ = decoded(path)
    assert len(frames) == 3
    box = picture_box(scene, size)
    return [shown_fraction(frame, box) for frame in frames[1:]]


def test_interference_waves_fill_the_movie_quarter_size(tmp_path):
    """The interference run on a lattice a quarter as wide and high, for a quarter of the time
    (waves cross it at the same times relative to its size): in the middle and last frames most
    of the lattice shows the field (measured 63 % and 99 %); a fixed linear scale shows a quarter
    of it at most."""
    overrides = ["--set", "nx=170", "--set", "ny=96", "--duration", "37.5"]
    scene = sim.scenes.build("interference", nx=170, ny=96)
    size = (640, 360)
    adaptive = middle_and_end_fractions(tmp_path, ["interference", *overrides], size, scene)
    assert min(adaptive) > 0.5, adaptive
    fixed = middle_and_end_fractions(tmp_path, ["interference", *overrides, "--scale", "fixed"],
                                     size, scene)
    assert max(fixed) < 0.35, fixed  # measured 20 % and 24 %


@pytest.mark.slow
def test_interference_waves_fill_the_full_movie(tmp_path):
    """The full 150 s flagship at 720p: frames at t = 75 s and 150 s show the field over most
    of the lattice."""
    scene = sim.scenes.build("interference")
    fractions = middle_and_end_fractions(tmp_path, ["interference"], (1280, 720), scene)
    assert min(fractions) > 0.5, fractions
