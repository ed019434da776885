"""Any recording makes a movie: the default recording of every preset (positions for small
lattices, a colour-mapped field video for large ones) re-rendered by ``oscillators movie`` and
decoded; a field recording's movie shows the recorded field's colours where the independent run
has its wave; GIFs are written frame by frame."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from app.cli import main
from app.colours import SIGNED_FIELD
from tests.test_movie import decoded, picture_box, pixel_of

LARGE = ("interference", "interference-open")
PRESETS = [name if name not in ("single-slit", "double-slit", "bandgap")  # two-sources: the ripple tank
           else pytest.param(name, marks=pytest.mark.slow)
           for name in sim.scenes.names() if name not in LARGE] + [
    pytest.param("interference-open", marks=pytest.mark.slow)]
"""Every preset; the flagship's default recording is the field test below."""


@pytest.mark.parametrize("name", PRESETS)
def test_default_recording_of_every_preset_makes_a_movie(tmp_path, name):
    """`oscillators record NAME` with its defaults (shortened to 12 steps) -> `movie` decodes."""
    recording = tmp_path / f"{name}.rrd"
    assert main(["record", name, "--steps", "12", "-o", str(recording), "--quiet"]) == 0
    movie = tmp_path / f"{name}.mp4"
    assert main(["movie", str(recording), "-o", str(movie), "--size", "320x180", "--quiet"]) == 0
    frames, _, _ = decoded(movie)
    assert len(frames) >= 2 and frames[0].shape == (180, 320, 3)


def test_movie_of_a_field_recording_shows_the_recorded_wave(tmp_path):
    """A large lattice's recording holds a colour-mapped field video; its movie's last frame is
    coloured where an independent run's wave is strong, with the sign of u_y, and plain where the
    lattice has not moved.  (The flagship's default recording, shortened to 60 steps.)"""
    recording = tmp_path / "interference.rrd"
    assert main(["record", "interference", "--steps", "60", "-o", str(recording),
                 "--quiet"]) == 0
    movie = tmp_path / "interference.mp4"
    assert main(["movie", str(recording), "-o", str(movie), "--size", "1280x720", "--frames", "3",
                 "--quiet"]) == 0
    frames, _, _ = decoded(movie)
    scene = sim.scenes.build("interference")
    model = scene.model
    simulation = sim.Simulation(scene)
    simulation.step(60)
    uy = (simulation.peek_positions() - simulation.rest_positions)[:, 1].reshape(model.ny, model.nx)
    last = frames[-1].astype(int)
    box = picture_box(scene, (1280, 720))
    zero = SIGNED_FIELD.table()[128].astype(int)
    row, column = pixel_of(box, model, model.nx // 2, model.ny // 4)
    assert np.abs(last[row, column] - zero).max() <= 12  # nothing arrived in the middle
    windows = np.lib.stride_tricks.sliding_window_view(uy, (3, 3))
    one_sign = (windows.min(axis=(2, 3)) > 0) | (windows.max(axis=(2, 3)) < 0)
    strength = np.where(one_sign[:, :40], np.abs(windows.mean(axis=(2, 3))[:, :40]), 0.0)
    j, i = np.unravel_index(np.argmax(strength), strength.shape)
    row, column = pixel_of(box, model, i + 1, j + 1)
    colour = last[row - 1 : row + 2, column - 1 : column + 2].reshape(-1, 3).mean(axis=0)
    assert np.abs(colour - zero).max() > 40
    assert (colour[0] > colour[2]) == (uy[j + 1, i + 1] > 0)


def test_movie_of_a_raw_field_recording(tmp_path):
    """A field recorded as raw floats (no positions) makes a movie from the values themselves."""
    recording = tmp_path / "raw.rrd"
    assert main(["record", "grid", "--steps", "4", "--field", "raw", "--positions", "none",
                 "-o", str(recording), "--quiet"]) == 0
    movie = tmp_path / "raw.mp4"
    assert main(["movie", str(recording), "-o", str(movie), "--size", "320x180", "--quiet"]) == 0
    assert len(decoded(movie)[0]) == 5


def test_gif_frames_are_streamed_with_the_colour_map(tmp_path):
    """A GIF of the grid decodes frame by frame with the movie's own colours (its palette holds
    the colour map) and the requested timing."""
    path = tmp_path / "grid.gif"
    assert main(["movie", "grid", "-o", str(path), "--frames", "40", "--fps", "20", "--quiet"]) == 0
    frames, _, _ = decoded(path)
    assert len(frames) == 40 and frames[0].shape == (360, 640, 3)  # the GIF default size
    from PIL import Image

    with Image.open(path) as image:
        assert image.n_frames == 40 and image.info["duration"] == 50
