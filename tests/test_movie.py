"""Movies: real files written by ``oscillators movie`` / ``app.movie`` and decoded with PyAV; their
frame counts and durations, and the colours of decoded frames against an independent run of the
same scene (background where nothing has arrived, colour where the wave is)."""

from __future__ import annotations

import io
from pathlib import Path

import av
import numpy as np
import pytest

import sim
from app.cli import build_parser, main
from app.colours import SIGNED_FIELD
from app.movie import movie_bytes, render_movie
from app.movie.encode import available


def decoded(path_or_bytes: Path | bytes) -> tuple[list[np.ndarray], float, float]:
    """(RGB frames, container duration in s, frames per second) of a movie."""
    source = io.BytesIO(path_or_bytes) if isinstance(path_or_bytes, bytes) else str(path_or_bytes)
    with av.open(source) as container:
        stream = container.streams.video[0]
        frames = [frame.to_ndarray(format="rgb24") for frame in container.decode(stream)]
        duration = float(container.duration) / av.time_base if container.duration else 0.0
        rate = float(stream.average_rate or 0)
    return frames, duration, rate


def picture_box(scene, size: tuple[int, int]) -> tuple[int, int, int, int]:
    """(x0, y0, width, height) of the field picture in the frame, as the renderer lays it out."""
    from app.movie.options import MovieOptions
    from app.movie.painter import Painter
    from app.recording.scales import ColourScales

    scales = ColourScales(strain=1, field=1, height=0, axis=1, rest_strain=0, seconds=0)
    painter = Painter(scene, scene.model, "", "displacement", scales, MovieOptions(size=size))
    return painter.x0, painter.y0, painter.px, painter.py


def pixel_of(box: tuple[int, int, int, int], model, i: int, j: int) -> tuple[int, int]:
    """Frame pixel (row, column) at the centre of lattice site (column i, row j from the bottom)."""
    x0, y0, width, height = box
    column = x0 + int((i + 0.5) * width / model.nx)
    row = y0 + int((model.ny - 1 - j + 0.5) * height / model.ny)
    return row, column


@pytest.fixture(scope="module")
def interference_movie(tmp_path_factory) -> tuple[Path, object]:
    path = tmp_path_factory.mktemp("movie") / "interference.mp4"
    status = main(["movie", "interference", "-o", str(path), "--duration", "4", "--frames", "11",
                   "--fps", "10", "--size", "1280x720", "--quiet"])
    assert status == 0
    return path, sim.scenes.build("interference")


def test_interference_movie_frames_and_duration(interference_movie):
    path, _ = interference_movie
    frames, duration, rate = decoded(path)
    assert len(frames) == 11 and frames[0].shape == (720, 1280, 3)
    assert rate == pytest.approx(10)
    assert duration == pytest.approx(11 / 10, abs=0.11)


def test_frames_span_the_duration_exactly():
    """The last frame is at the movie's duration, also when the steps do not divide evenly among
    the frames (1000 frames of the 150 s flagship once ended at 159.84 s)."""
    from app.movie.options import MovieOptions
    from app.movie.simulated import SimulationSource

    scene = sim.scenes.build("chain")
    source = SimulationSource(scene, MovieOptions(frames=7, duration=1.0, dt=0.01))
    times = [state.time for state in source.states(False, False)]
    assert len(times) == 7 and times[0] == 0.0
    assert times[-1] == pytest.approx(1.0)
    assert np.all(np.diff(times) > 0)


def test_interference_movie_shows_the_field_where_the_wave_is(interference_movie):
    path, scene = interference_movie
    frames, _, _ = decoded(path)
    model = scene.model
    box = picture_box(scene, (1280, 720))
    # an independent run to the last frame's time: 10 intervals of 4 s / 10 = 0.4 s = 20 steps
    simulation = sim.Simulation(scene)
    simulation.step(200)
    uy = (simulation.peek_positions() - simulation.rest_positions)[:, 1].reshape(model.ny, model.nx)
    last = frames[-1].astype(int)
    background = np.array(SIGNED_FIELD.table()[128], int)  # zero displacement
    # far from both sources (the middle of the lattice) nothing has arrived: background colour
    row, column = pixel_of(box, model, model.nx // 2, model.ny // 4)
    assert abs(uy[model.ny // 4, model.nx // 2]) < 1e-9
    assert np.abs(last[row, column] - background).max() <= 12
    # near each source, the 3x3-particle patch of one sign whose mean |u_y| is largest: coloured,
    # red where u_y > 0, blue where u_y < 0 (H.264 blurs single-particle detail, patches survive)
    windows = np.lib.stride_tricks.sliding_window_view(uy, (3, 3))
    mean = windows.mean(axis=(2, 3))
    one_sign = (windows.min(axis=(2, 3)) > 0) | (windows.max(axis=(2, 3)) < 0)
    for side in (slice(0, 40), slice(model.nx - 44, model.nx - 4)):
        strength = np.where(one_sign[:, side], np.abs(mean[:, side]), 0.0)
        j, i = np.unravel_index(np.argmax(strength), strength.shape)
        assert strength[j, i] > 0.003  # metres: a clear part of the front (scale ~0.01 m)
        value = mean[j, i + side.start]
        row, column = pixel_of(box, model, i + side.start + 1, j + 1)  # the patch centre
        colour = last[row - 1 : row + 2, column - 1 : column + 2].reshape(-1, 3).mean(axis=0)
        assert np.abs(colour - background).max() > 40, (i, j, value, colour)
        assert (colour[0] > colour[2]) == (value > 0), (i, j, value, colour)


def test_grid_gif_and_movie_bytes(tmp_path):
    path = tmp_path / "grid.gif"
    assert main(["movie", "grid", "-o", str(path), "--duration", "1", "--size", "320x180",
                 "--fps", "10", "--quiet"]) == 0
    frames, _, _ = decoded(path)
    assert len(frames) == 26  # 25 frames per simulated second, plus t = 0
    from PIL import Image

    with Image.open(path) as image:
        assert image.n_frames == 26 and image.info["duration"] == 100  # 10 frames/s
    data = movie_bytes(sim.scenes.build("grid"), "mp4", frames=5, size=(256, 144),
                       progress=False)
    frames, _, rate = decoded(data)
    assert len(frames) == 5 and frames[0].shape == (144, 256, 3) and rate == pytest.approx(30)
    # a running simulation (the web page's current run): its state now is the movie's start
    simulation = sim.Simulation(sim.scenes.build("grid"))
    simulation.step(50)
    before = simulation.peek_positions().copy()
    data = movie_bytes(simulation, "mp4", frames=3, size=(256, 144), progress=False)
    assert len(decoded(data)[0]) == 3
    np.testing.assert_array_equal(simulation.peek_positions(), before)  # left untouched


@pytest.mark.skipif(not available("webm"), reason="PyAV without libvpx-vp9")
def test_webm_and_membrane(tmp_path):
    path = render_movie(sim.scenes.build("membrane"), tmp_path / "drum.webm", frames=6,
                        size=(320, 180), progress=False)
    frames, _, _ = decoded(path)
    assert len(frames) == 6
    # the bump starts above the plane: red (height > 0) dominates over blue in the first frame
    first = frames[0][20:140].astype(int)  # the picture, above the colour bar
    reddish = ((first[:, :, 0] - first[:, :, 2]) > 80).sum()
    bluish = ((first[:, :, 2] - first[:, :, 0]) > 80).sum()
    assert reddish > 20 and reddish > 5 * bluish


def test_movie_of_a_recording(tmp_path):
    recording = tmp_path / "chain.rrd"
    assert main(["record", "chain", "--steps", "40", "--every", "4", "-o", str(recording),
                 "--quiet"]) == 0
    movie = tmp_path / "chain.mp4"
    assert main(["movie", str(recording), "-o", str(movie), "--size", "320x180", "--quiet"]) == 0
    frames, _, _ = decoded(movie)
    assert len(frames) == 11  # the recording's frames: steps 0, 4, ..., 40


def test_refusals(tmp_path, capsys):
    existing = tmp_path / "x.mp4"
    existing.write_bytes(b"")
    assert main(["movie", "chain", "-o", str(existing), "--quiet"]) == 2
    assert "--force" in capsys.readouterr().err
    assert main(["movie", "chain", "-o", str(tmp_path / "x.avi"), "--quiet"]) == 2
    not_a_recording = tmp_path / "z.rrd"
    not_a_recording.write_bytes(b"not rerun")
    assert main(["movie", str(not_a_recording), "-o", str(tmp_path / "y.mp4"), "--quiet"]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_help_teaches_with_examples(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["movie", "--help"])
    text = capsys.readouterr().out
    for phrase in ("examples:", "oscillators movie interference", ".gif", "--color", "recording"):
        assert phrase in text


@pytest.mark.slow
def test_default_interference_movie(tmp_path):
    """The full default: 1000 frames of the 150 s run at 720p in under 20 MB (the adaptive log
    colour scale shows the short waves everywhere, which cost bits: 15 MB with the default
    encoder settings, 54 MB with the earlier ones; the speed is measured by
    benchmarks/movie_speed.py, size and memory by benchmarks/movie_memory.py, encoder settings
    by benchmarks/movie_settings.py)."""
    path = tmp_path / "interference.mp4"
    assert main(["movie", "interference", "-o", str(path), "--quiet"]) == 0
    assert path.stat().st_size < 20e6
    frames, duration, _ = decoded(path)
    assert len(frames) == 1000 and duration == pytest.approx(1000 / 30, abs=0.1)


def test_a_movie_says_so_when_its_kernels_compile_first(monkeypatch, capsys):
    """A first run on a machine compiles its kernels in the movie's process for seconds: the
    command says so before it starts (a step tried with compiles refused tells)."""
    import argparse

    from app.cli import movie
    from sim.runtime import warming

    scene = sim.scenes.build("chain")
    arguments = argparse.Namespace(integrator=None, dt=None)
    sim.Simulation(scene).step(1)  # compiled: nothing to say
    movie._say_if_compiling(scene, arguments)
    assert "compiling" not in capsys.readouterr().err

    def refuse(self, n=1):
        raise warming.WouldCompile("a kernel is missing")

    monkeypatch.setattr(sim.Simulation, "step", refuse)
    movie._say_if_compiling(scene, arguments)
    assert "compiling the kernels for this run (first time on this machine" in \
        capsys.readouterr().err
