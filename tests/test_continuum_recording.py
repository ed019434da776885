"""The continuum-limit recording read back with rerun's own reader: every N and the continuum
curve on one timeline, the curve back at its initial shape after one crossing time (the string's
period), and the distances falling with N."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
import rerun_cli
from rerun.chunk import RrdReader

from app.cli import main
from app.recording.continuum import (
    CURVE_POINTS,
    distance_entity,
    drawn_exaggeration,
    entity,
    record_continuum,
)
from sim.scenes.bodies import Body, Shape

PARTICLES = (4, 16, 64)
FRAMES = 8


def _rows(chunks, path: str, column: str) -> dict[float, object]:
    """{time (s): value} of one component column of an entity's temporal rows."""
    rows = {}
    for chunk in chunks:
        if chunk.entity_path != path or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        times = batch.column("time").cast("int64").to_pylist()  # nanoseconds
        for time, value in zip(times, batch.column(column).to_pylist(), strict=True):
            rows[time * 1e-9] = value
    return rows


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    body = Body(kind="string", shape=Shape("gaussian", centre=0.4))
    path = tmp_path_factory.mktemp("continuum") / "string.rrd"
    record_continuum(body, PARTICLES, path, frames=FRAMES)
    return body, RrdReader(path).stream().to_chunks()


def test_every_particle_count_and_the_curve_are_on_one_timeline(recorded):
    body, chunks = recorded
    expected = [body.crossing_time * k / FRAMES for k in range(FRAMES + 1)]
    for n in PARTICLES:
        for part, column in (("lattice", "Points2D:positions"), ("continuum", "LineStrips2D:strips")):
            rows = _rows(chunks, entity(n, part), column)
            assert sorted(rows) == pytest.approx(expected, abs=1e-9)
        beads = _rows(chunks, entity(n, "lattice"), "Points2D:positions")
        assert len(beads[0.0]) == n


def test_the_continuum_curve_returns_to_its_shape_after_one_crossing_time(recorded):
    body, chunks = recorded
    curves = _rows(chunks, entity(16, "continuum"), "LineStrips2D:strips")
    first, last = (np.array(curves[t][0]) for t in (min(curves), max(curves)))
    assert first.shape == (CURVE_POINTS + 1, 2)
    drawn = -body.shape.values(first[:, 0] / body.length) * drawn_exaggeration(body)  # y down
    assert np.abs(first[:, 1] - drawn).max() < 1e-6 * np.abs(drawn).max()  # stored as float32
    assert np.abs(last[:, 1] - drawn).max() < 2e-6 * np.abs(drawn).max()  # period 2 L0 / c
    middle = np.array(curves[sorted(curves)[FRAMES // 2]][0])
    assert not np.allclose(middle[:, 1], first[:, 1], atol=0.1 * np.abs(first[:, 1]).max())


def test_the_distance_falls_with_the_number_of_particles(recorded):
    _, chunks = recorded
    final = [_rows(chunks, distance_entity(n), "Scalars:scalars") for n in PARTICLES]
    start = [rows[min(rows)][0] for rows in final]
    end = [rows[max(rows)][0] for rows in final]
    assert max(start) < 1e-6  # all start on the shape (the series is converged to 1e-7)
    assert end[0] > end[1] > 8 * end[2] > 0  # 4x finer: 10x closer once the bump is resolved


def test_cli_records_and_refuses_an_existing_file(tmp_path, capsys):
    path = tmp_path / "m.rrd"
    arguments = ["continuum", "membrane", "--particles", "4,8", "--shape", "sine", "--quiet",
                 "--record", str(path), "--frames", "4"]
    assert main(arguments) == 0
    verified = subprocess.run([str(Path(rerun_cli.__file__).parent / "rerun"), "rrd", "verify",
                               str(path)], capture_output=True, text=True, timeout=120)
    assert verified.returncode == 0, verified.stderr
    chunks = RrdReader(path).stream().to_chunks()
    assert _rows(chunks, entity(8, "continuum"), "Image:buffer")
    capsys.readouterr()
    assert main(arguments) == 2
    assert "already exists" in capsys.readouterr().err
