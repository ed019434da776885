"""Recordings follow the field: the field image of a large lattice is coloured on the scale the
page and the movies use (a log scale whose limit follows the field), so a recording read back
with rerun's API shows the waves late in the run, its colour bar shows the numbers in use, and a
movie made from the recording shows them too.  ``--scale fixed`` keeps one linear scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app import colours
from app.cli import main
from app.movie.recorded import _flat
from sim.scenes.building import build
from tests.test_movie import decoded, picture_box
from tests.test_recording import read_chunks, temporal

SMALL_FLAGSHIP = ["interference", "--set", "nx=200", "--set", "ny=110", "--duration", "30"]
"""The flagship's scene on a smaller lattice and a shorter run (its fronts have spread by 29 s)."""


def field_pictures(path: Path, times: list[float]) -> dict[float, np.ndarray]:
    """The recording's field image (H.264 samples at ``/field``) decoded with PyAV at the first
    recorded frame at or after each of ``times`` (simulated seconds)."""
    import av

    samples = {}
    for chunk in read_chunks(path):
        if chunk.entity_path != "/field" or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if "VideoStream:sample" not in batch.schema.names:
            continue
        for step, ns, value in zip(batch.column("step").to_pylist(),
                                   batch.column("sim_time").cast("int64").to_pylist(),
                                   batch.column("VideoStream:sample"), strict=True):
            if value.is_valid and len(value.values):
                samples[step] = (ns * 1e-9, _flat(value).astype(np.uint8).tobytes())
    codec = av.CodecContext.create("h264", "r")
    found: dict[float, np.ndarray] = {}
    for step in sorted(samples):
        time, data = samples[step]
        for frame in codec.decode(av.Packet(data)):
            for wanted in times:
                if wanted not in found and time >= wanted - 1e-6:
                    found[wanted] = frame.to_ndarray(format="rgb24")
    assert set(found) == set(times), (sorted(found), times)
    return found


def share_unlike_commonest(picture: np.ndarray, threshold: int = 40) -> float:
    """The share of pixels whose colour differs clearly (by more than ``threshold`` in some
    channel) from the picture's commonest colour (the field at rest)."""
    flat = picture.reshape(-1, 3).astype(int)
    keys = (flat[:, 0] << 16) | (flat[:, 1] << 8) | flat[:, 2]
    values, counts = np.unique(keys, return_counts=True)
    common = values[counts.argmax()]
    colour = np.array([common >> 16, (common >> 8) & 255, common & 255])
    return float((np.abs(flat - colour).max(axis=1) > threshold).mean())


def inside_picture(frame: np.ndarray, scene, size: tuple[int, int]) -> np.ndarray:
    """The part of a movie frame that shows the lattice's field picture."""
    x0, y0, width, height = picture_box(scene, size)
    return frame[y0 + 2 : y0 + height - 2, x0 + 2 : x0 + width - 2]


@pytest.mark.parametrize("policy", list(colours.SCALES))
def test_a_colour_read_back_gives_the_value_on_its_scale(policy):
    """``ColourScale.values`` inverts ``fraction`` (how a movie reads a recorded picture)."""
    for signed in (True, False):
        scale = colours.make_scale(policy, 0.02, signed)
        values = np.array([-0.02, -3e-3, -1e-5, 0.0, 2e-6, 4e-4, 0.0199]) if signed else \
            np.array([0.0, 1e-5, 4e-4, 0.0199])
        np.testing.assert_allclose(scale.values(scale.fraction(values)), values, rtol=1e-3,
                                   atol=1e-9)


@pytest.mark.slow  # records the flagship
def test_a_shortened_flagship_recording_shows_the_waves_late_and_fixed_does_not(tmp_path):
    """The flagship's scene (smaller, 30 s): late in the run the default recording's field image
    shows the waves on a third of the lattice or more, its colour bar was redrawn as the scale
    moved, and each frame's limit is logged; on ``--scale fixed`` the same moment is nearly
    blank (the fronts weaken as they spread)."""
    follows, fixed = tmp_path / "follows.rrd", tmp_path / "fixed.rrd"
    assert main(["record", *SMALL_FLAGSHIP, "-o", str(follows), "--quiet"]) == 0
    assert main(["record", *SMALL_FLAGSHIP, "--scale", "fixed", "-o", str(fixed),
                 "--quiet"]) == 0
    late = field_pictures(follows, [15.0, 29.0])
    assert share_unlike_commonest(late[15.0]) > 0.25, share_unlike_commonest(late[15.0])
    assert share_unlike_commonest(late[29.0]) > 0.5, share_unlike_commonest(late[29.0])
    blank = field_pictures(fixed, [29.0])[29.0]
    assert share_unlike_commonest(blank) < 0.25, share_unlike_commonest(blank)
    chunks = read_chunks(follows)
    limits = [float(np.asarray(v.as_py()).ravel()[0])
              for v in temporal(chunks, "/colour_scale/field", "Scalars:scalars").values()]
    assert len(limits) >= 700 and max(limits) > 1.3 * min(limits)  # it followed the field
    bars = temporal(chunks, "/legend/field", "EncodedImage:blob")
    assert 3 <= len(bars) < len(limits)  # redrawn when its numbers change, not every frame
    assert not temporal(read_chunks(fixed), "/colour_scale/field", "Scalars:scalars") or len(
        {round(float(np.asarray(v.as_py()).ravel()[0]), 12) for v in temporal(
            read_chunks(fixed), "/colour_scale/field", "Scalars:scalars").values()}) == 1


@pytest.mark.slow  # records the flagship
def test_a_movie_of_a_shortened_flagship_recording_shows_the_waves(tmp_path):
    """``movie REC.rrd`` reads each frame on the scale it was recorded with and draws it with
    the recording's policy: late frames show the waves on a third of the picture or more."""
    recording = tmp_path / "follows.rrd"
    assert main(["record", *SMALL_FLAGSHIP, "-o", str(recording), "--quiet"]) == 0
    movie = tmp_path / "follows.mp4"
    assert main(["movie", str(recording), "-o", str(movie), "--frames", "31", "--size",
                 "640x360", "--quiet"]) == 0
    frames, _, _ = decoded(movie)
    field = inside_picture(frames[-1], build("interference", nx=200, ny=110), (640, 360))
    assert share_unlike_commonest(field) > 0.3, share_unlike_commonest(field)


@pytest.mark.slow
def test_the_flagship_default_recording_shows_the_waves_at_every_moment(tmp_path):
    """``oscillators record interference`` (150 s): at 60 s and 145 s a quarter of the field
    image or more differs clearly from its commonest colour, in the recording and in the movie
    made from it."""
    recording = tmp_path / "interference.rrd"
    assert main(["record", "interference", "-o", str(recording), "--quiet"]) == 0
    pictures = field_pictures(recording, [60.0, 145.0])
    for moment, picture in pictures.items():
        assert share_unlike_commonest(picture) >= 0.25, (moment, share_unlike_commonest(picture))
    movie = tmp_path / "interference.mp4"
    assert main(["movie", str(recording), "-o", str(movie), "--frames", "151", "--size",
                 "1280x720", "--quiet"]) == 0
    frames, _, _ = decoded(movie)
    for index in (60, 145):  # one frame a simulated second from t = 0
        field = inside_picture(frames[index], build("interference"), (1280, 720))
        assert share_unlike_commonest(field) >= 0.25, (index, share_unlike_commonest(field))
