"""Recordings: real ``.rrd`` files written by ``app.recording`` and read back with
rerun's own reader (``rerun.chunk.RrdReader``) and CLI (``rerun rrd verify``)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

import sim
from app.cli import build_parser, main
from app.recording import Recorder, RecordingError, RecordingOptions, destination
from app.recording.explain import table_rows
from app.recording.field import video_available
from app.recording.layout import ENERGY_TERMS
from sim.runtime.runner import Runner
from tests.helpers import wait_for

REPO = Path(__file__).resolve().parent.parent


# --- reading files back ------------------------------------------------------------------------


def read_chunks(path: Path) -> list:
    return RrdReader(path).stream().to_chunks()


def temporal(chunks: list, entity: str, column: str) -> dict[int, object]:
    """{step: value} of one component column of an entity's temporal rows."""
    rows: dict[int, object] = {}
    for chunk in chunks:
        if chunk.entity_path != entity or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if column not in batch.schema.names:
            continue
        for step, value in zip(batch.column("step").to_pylist(), batch.column(column), strict=True):
            rows[step] = value
    return rows


def static_rows(chunks: list, entity: str) -> int:
    return sum(chunk.num_rows for chunk in chunks if chunk.entity_path == entity and chunk.is_static)


def as_array(value: object, width: int | None = None) -> np.ndarray:
    """An Arrow list cell (possibly of fixed-size lists) as a numpy array."""
    flat = value.values  # type: ignore[attr-defined]
    while hasattr(flat, "values") and not hasattr(flat, "to_numpy_zero_copy"):
        flat = flat.flatten() if hasattr(flat, "flatten") else flat.values
    array = np.asarray(flat.to_numpy(zero_copy_only=False))
    return array.reshape(-1, width) if width else array


def scalar(value: object) -> float:
    return float(value.as_py()[0])  # type: ignore[attr-defined]


def texts(chunks: list, entity: str) -> list[tuple[int, str, str]]:
    out = []
    for chunk in chunks:
        if chunk.entity_path != entity or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        steps = batch.column("step").to_pylist() if "step" in batch.schema.names else [None] * len(batch)
        levels = batch.column("TextLog:level").to_pylist()
        for step, text, level in zip(steps, batch.column("TextLog:text").to_pylist(), levels, strict=True):
            out.append((step, text[0], level[0] if level else None))
    return out


def rerun_binary() -> str:
    import rerun_cli

    return str(Path(rerun_cli.__file__).parent / "rerun")


def record_scene(path: Path, scene, steps: int, every: int, **option_values) -> Recorder:
    option_values.setdefault("frame_interval", 0.0)
    simulation = sim.Simulation(scene)
    runner = Runner(simulation)
    with Recorder(path, scene, options=RecordingOptions(**option_values)) as recorder:
        recorder.attach(runner)
        runner.publish()
        runner.advance(steps, every=every)
    return recorder


# --- small scenes ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def grid_file(tmp_path_factory) -> tuple[Path, object]:
    scene = sim.scenes.build("grid")
    path = tmp_path_factory.mktemp("grid") / "grid.rrd"
    record_scene(path, scene, steps=30, every=3)
    return path, scene


def test_file_is_final_and_verified(grid_file):
    path, _ = grid_file
    assert path.exists() and not Path(str(path) + ".partial").exists()
    result = subprocess.run([rerun_binary(), "rrd", "verify", str(path)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    reader = RrdReader(path)
    assert len(reader.recordings()) == 1 and reader.blueprints()


def test_timelines_and_positions_match_an_independent_simulation(grid_file):
    path, scene = grid_file
    chunks = read_chunks(path)
    positions = temporal(chunks, "/lattice/particles", "Points2D:positions")
    assert sorted(positions) == list(range(0, 31, 3))
    names = {name for chunk in chunks if not chunk.is_static for name in chunk.timeline_names}
    assert {"step", "sim_time"} <= names
    reference = sim.Simulation(scene)
    for step in (0, 3, 15, 30):
        reference.step(step - reference.step_count)
        recorded = as_array(positions[step], 2)
        np.testing.assert_allclose(recorded, reference.peek_positions(), rtol=0, atol=1e-5)
    times = {}
    for chunk in chunks:
        if chunk.entity_path == "/energy/total" and not chunk.is_static:
            batch = chunk.to_record_batch()
            for step, duration in zip(batch.column("step").to_pylist(),
                                      batch.column("sim_time").cast("int64").to_pylist(), strict=True):
                times[step] = duration * 1e-9
    assert times[30] == pytest.approx(30 * scene.dt, rel=1e-9)


def test_energy_series_and_strains_match(grid_file):
    path, scene = grid_file
    chunks = read_chunks(path)
    reference = sim.Simulation(scene)
    series = {term: temporal(chunks, f"/energy/{term}", "Scalars:scalars")
              for term in ("kinetic", "potential", "total", "dissipated")}
    strains = temporal(chunks, "/lattice/springs", "strain")
    for step in (0, 9, 30):
        reference.step(step - reference.step_count)
        energy = reference.energy()
        for term, rows in series.items():
            assert scalar(rows[step]) == pytest.approx(energy[term], rel=1e-9, abs=1e-12)
        # float32 on file: 6e-8 relative, far below a colour step of the strain scale
        np.testing.assert_allclose(as_array(strains[step]), reference.strains(), atol=1e-7)
    integrator = temporal(chunks, "/settings/integrator", "TextDocument:text")
    assert [v.as_py() for v in integrator.values()] == [["rk4"]]
    assert scalar(temporal(chunks, "/settings/dt", "Scalars:scalars")[30]) == scene.dt


def test_static_data_is_logged_once(grid_file):
    path, scene = grid_file
    chunks = read_chunks(path)
    for entity in ("/scene", "/lattice/rest", "/lattice/anchors", "/lattice"):
        assert static_rows(chunks, entity) == 1, entity
        assert not temporal(chunks, entity, "Points2D:positions")
    rest = [c for c in chunks if c.entity_path == "/lattice/rest" and c.is_static][0]
    assert len(as_array(rest.to_record_batch().column("Points2D:positions")[0], 2)) == 96
    topology = [c for c in chunks if c.entity_path == "/lattice/springs" and c.is_static
                and "first" in c.to_record_batch().schema.names]
    assert len(topology) == 1
    first = as_array(topology[0].to_record_batch().column("first")[0])
    np.testing.assert_array_equal(first, scene.model.springs[:, 0])
    scene_text = [c for c in chunks if c.entity_path == "/scene"][0].to_record_batch()
    assert "stiffness" in scene_text.column("TextDocument:text")[0].as_py()[0]


def test_raw_field_is_lossless_and_oriented_like_the_lattice(tmp_path):
    scene = sim.scenes.build("grid")
    path = tmp_path / "raw.rrd"
    record_scene(path, scene, steps=10, every=5, field="raw", detail_limit=10, background=False)
    chunks = read_chunks(path)
    images = temporal(chunks, "/field", "DepthImage:buffer")
    assert sorted(images) == [0, 5, 10]
    assert not temporal(chunks, "/lattice/particles", "Points2D:positions")  # big-scene plan
    reference = sim.Simulation(scene)
    reference.step(10)
    # the grid's particle is displaced by (0.4, 0.3) a: the signed field shows u_x
    displacement = (reference.peek_positions() - reference.rest_positions)[:, 0]
    image = np.frombuffer(as_array(images[10]).astype(np.uint8).tobytes(), dtype=np.float32)
    image = image.reshape(8, 12)
    np.testing.assert_allclose(image[::-1].ravel(), displacement, rtol=1e-6, atol=1e-7)
    assert (displacement < -1e-3).any() and (displacement > 1e-3).any()  # signed, both kinds



def test_speed_field_and_changes_mid_run(tmp_path):
    scene = sim.scenes.build("grid")
    simulation = sim.Simulation(scene)
    runner = Runner(simulation)
    path = tmp_path / "changes.rrd"
    options = RecordingOptions(field="raw", quantity="speed", detail_limit=10, frame_interval=0)
    with Recorder(path, scene, options=options) as recorder:
        recorder.attach(runner)
        runner.advance(4, every=2)
        runner.post(lambda s: setattr(s, "integrator", "verlet"))
        runner.post(lambda s: s.set_parameters(damping=0.5))
        runner.advance(4, every=2)
    chunks = read_chunks(path)
    integrators = temporal(chunks, "/settings/integrator", "TextDocument:text")
    assert {step: value.as_py()[0] for step, value in integrators.items()} == {2: "rk4", 6: "verlet"}
    assert list(temporal(chunks, "/settings/model", "TextDocument:text")) == [6]
    messages = [text for _, text, _ in texts(chunks, "/log")]
    assert any("verlet" in text for text in messages)
    assert any("parameters changed" in text for text in messages)
    image = as_array(temporal(chunks, "/field", "DepthImage:buffer")[8]).astype(np.uint8)
    speeds = np.frombuffer(image.tobytes(), dtype=np.float32).reshape(8, 12)[::-1].ravel()
    expected = np.linalg.norm(simulation.state.particle_velocities(), axis=1)
    np.testing.assert_allclose(speeds, expected, rtol=1e-6, atol=1e-7)

# --- integrity -----------------------------------------------------------------------------------


def test_blow_up_ends_the_recording_cleanly(tmp_path):
    scene = sim.scenes.build("grid")
    simulation = sim.Simulation(scene, integrator="euler", dt=0.2)
    runner = Runner(simulation)
    path = tmp_path / "blowup.rrd"
    with pytest.raises(sim.BlowUpError):
        with Recorder(path, scene) as recorder:
            recorder.attach(runner)
            runner.advance(10_000, every=10)
    chunks = read_chunks(path)
    errors = [entry for entry in texts(chunks, "/log") if entry[2] == "ERROR"]
    assert len(errors) == 1 and "blew up" in errors[0][1]
    assert max(temporal(chunks, "/energy/total", "Scalars:scalars")) == errors[0][0]


def test_unwritable_path_and_full_disk_fail_before_the_run(tmp_path, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    scene = sim.scenes.build("chain")
    with pytest.raises(RecordingError, match="cannot write"):
        Recorder(blocker / "x.rrd", scene)
    assert main(["record", "chain", "--steps", "5", "-o", str(blocker / "x.rrd"), "--quiet"]) == 2

    import shutil

    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage",
                        lambda path: real(path)._replace(free=1_000_000))
    with pytest.raises(RecordingError, match="disk space"):
        Recorder(tmp_path / "y.rrd", scene, expected_frames=1000)
    assert not list(tmp_path.glob("y.rrd*"))


@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM])
def test_signal_leaves_a_readable_file(tmp_path, signal_number):
    path = tmp_path / "interrupted.rrd"
    command = [sys.executable, "-m", "app.cli", "record", "grid", "--steps", "100000000",
               "--every", "20", "-o", str(path), "--quiet"]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    partial = Path(str(path) + ".partial")
    deadline = time.monotonic() + 40
    while time.monotonic() < deadline and (not partial.exists() or partial.stat().st_size < 200_000):
        time.sleep(0.2)
    assert partial.exists(), process.communicate(timeout=10)
    process.send_signal(signal_number)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert path.exists() and not partial.exists()
    assert destination.readable_part(path).complete  # ends with its end message and footer
    chunks = read_chunks(path)
    steps = temporal(chunks, "/energy/total", "Scalars:scalars")
    assert len(steps) > 10
    # Ctrl-C is the user's stop (a WARN); SIGTERM stops it from outside (an ERROR saying so)
    level, text = ("WARN", "interrupted") if signal_number == signal.SIGINT else (
        "ERROR", "stopped by SIGTERM")
    warnings = [entry for entry in texts(chunks, "/log") if entry[2] == level]
    assert warnings and text in warnings[0][1]
    assert warnings[0][0] == max(steps)
    # The stop request is honoured between frames: every recorded frame is complete.
    assert set(temporal(chunks, "/lattice/springs", "strain")) == set(steps)


def test_attach_and_close_while_the_runner_thread_runs(tmp_path):
    scene = sim.scenes.build("grid")
    runner = Runner(sim.Simulation(scene), max_fps=200)
    runner.start()
    runner.play()
    try:
        assert wait_for(lambda: runner.simulation.step_count > 0), "the runner never stepped"
        recorder = Recorder(tmp_path / "live.rrd", scene)  # as the web app makes it
        recorder.attach(runner, snapshot=True)
        attached = runner.frames_published
        assert wait_for(lambda: runner.frames_published >= attached + 20), runner.error
        recorder.close()
        # frames published after close are ignored (no error, nothing written)
        closed = runner.frames_published
        assert wait_for(lambda: runner.frames_published >= closed + 3), runner.error
    finally:
        runner.stop()
    assert runner.error is None
    steps = temporal(read_chunks(tmp_path / "live.rrd"), "/energy/total", "Scalars:scalars")
    # >= 20 frames one step (0.01 s) apart went to the recorder, which keeps one every
    # 0.04 s of simulated time (25 a simulated second); one may race the subscription
    assert len(steps) >= 4 and min(steps) > 0
    assert min(np.diff(sorted(steps))) >= 4


# --- command line --------------------------------------------------------------------------------


def test_compare_mode_holds_one_tree_per_integrator(tmp_path):
    path = tmp_path / "compare.rrd"
    status = main(["record", "grid", "--compare", "euler,verlet,rk4", "--dt", "0.05",
                   "--steps", "200", "--every", "5", "-o", str(path), "--quiet"])
    assert status == 0  # Euler blowing up is a result of the comparison, not a failure
    chunks = read_chunks(path)
    roots = {chunk.entity_path.split("/")[1] for chunk in chunks}
    assert {"euler", "verlet", "rk4", "scene"} <= roots
    assert "lattice" not in roots and "energy" not in roots
    verlet = temporal(chunks, "/verlet/lattice/particles", "Points2D:positions")
    assert max(verlet) == 200
    reference = sim.Simulation(sim.scenes.build("grid"), integrator="verlet", dt=0.05)
    reference.step(200)
    np.testing.assert_allclose(as_array(verlet[200], 2), reference.peek_positions(), atol=1e-5)
    assert any(level == "ERROR" for _, _, level in texts(chunks, "/euler/log"))
    assert max(temporal(chunks, "/rk4/energy/total", "Scalars:scalars")) == 200


@pytest.mark.parametrize("listing", ["", " , ", "euler,warp", "rk4,rk4"])
def test_compare_rejects_empty_or_bad_lists(tmp_path, capsys, listing):
    path = tmp_path / "x.rrd"
    assert main(["record", "chain", "--compare", listing, "--steps", "5", "-o", str(path),
                 "--quiet"]) == 2
    assert capsys.readouterr().err.startswith("error: --compare")
    assert not path.exists()


def test_help_teaches_with_examples(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["record", "--help"])
    text = capsys.readouterr().out
    for phrase in ("examples:", "--compare euler,verlet,rk4", "--field", "rerun ", "--positions"):
        assert phrase in text


def test_cli_duration_and_output(tmp_path):
    path = tmp_path / "sub" / "chain.rrd"
    arguments = ["record", "chain", "--duration", "0.5", "--dt", "0.01", "-o", str(path),
                 "--quiet"]
    assert main(arguments) == 2  # the folder is not created on the way
    path.parent.mkdir()
    assert main(arguments) == 0
    steps = temporal(read_chunks(path), "/energy/total", "Scalars:scalars")
    assert max(steps) == 50


# --- large scenes ------------------------------------------------------------------------------


@pytest.mark.slow  # records the flagship (the size estimate is checked by default)
def test_interference_default_recording_fits_the_budget(tmp_path):
    """Budget: 1000 frames of interference in under 50 MB; extrapolated from a few frames."""
    scene = sim.scenes.build("interference")
    simulation = sim.Simulation(scene)
    simulation.step(150)  # let the waves spread so the images are not flat
    frames = 6

    def recorded_bytes(count: int) -> tuple[int, Recorder]:
        runner = Runner(simulation)
        path = tmp_path / f"interference{count}.rrd"
        with Recorder(path, scene, options=RecordingOptions(frame_interval=0)) as recorder:
            recorder.attach(runner)
            if count:
                runner.advance(count, every=1)
        return path.stat().st_size, recorder

    static_bytes, _ = recorded_bytes(0)
    total_bytes, _ = recorded_bytes(frames)
    per_frame = (total_bytes - static_bytes) / frames
    assert per_frame * 1000 < 50e6, f"{per_frame / 1e3:.0f} kB a frame"
    chunks = read_chunks(tmp_path / f"interference{frames}.rrd")
    entities = {chunk.entity_path for chunk in chunks if not chunk.is_static}
    assert "/field" in entities and "/lattice/springs" not in entities
    assert not temporal(chunks, "/lattice/particles", "Points2D:positions")
    column = "VideoStream:sample" if video_available() else "EncodedImage:blob"
    assert len(temporal(chunks, "/field", column)) == frames



@pytest.mark.slow
def test_interference_thousand_frames_end_to_end(tmp_path):
    """The size budget, measured whole: 1000 frames in under 50 MB (the time budget is
    measured by benchmarks/recording_speed.py)."""
    path = tmp_path / "interference.rrd"
    assert main(["record", "interference", "--steps", "1000", "--every", "1", "-o", str(path),
                 "--quiet"]) == 0
    assert path.stat().st_size < 50e6
    steps = temporal(read_chunks(path), "/energy/total", "Scalars:scalars")
    assert len(steps) == 1001


# --- recordings that explain themselves -----------------------------------------------------------

SMALL_PRESETS = ["single", "square", "chain", "grid", "ionic", "catenary", "membrane"]
SIZE_LIMIT = 10e6  # bytes (10 MB)


def static_value(chunks: list, entity: str, column: str) -> object:
    for chunk in chunks:
        if chunk.entity_path == entity and chunk.is_static:
            batch = chunk.to_record_batch()
            if column in batch.schema.names:
                return batch.column(column)[0]
    raise KeyError(f"{entity}:{column}")


def document(chunks: list) -> str:
    """The read-me as the viewer shows it: the last static ``/scene`` text (a recording with
    probes logs it again at the end, with their spectra)."""
    texts = [row.as_py()[0] for chunk in chunks if chunk.entity_path == "/scene"
             and chunk.is_static for row in chunk.to_record_batch().column("TextDocument:text")]
    return texts[-1]  # the last row: a chunk may hold both logs of the read-me


def default_timeline(path: Path) -> str:
    reader = RrdReader(path)
    for store in reader.blueprints():
        for chunk in reader.stream(store=store).to_chunks():
            batch = chunk.to_record_batch()
            if "TimePanelBlueprint:timeline" in batch.schema.names:
                return batch.column("TimePanelBlueprint:timeline")[0].as_py()[0]
    raise AssertionError("no time panel in the blueprint")


def pooled_percentile(rows: dict[int, object], offset: float = 0.0, q: float = 99.0) -> float:
    values = np.concatenate([np.abs(as_array(value) - offset) for value in rows.values()])
    return float(np.percentile(values, q))


def check_default_recording(path: Path, name: str) -> None:
    """What every preset's default recording must be: small, readable, self-explaining, in
    seconds, with colour scales that are neither saturated nor faint."""
    assert path.stat().st_size <= SIZE_LIMIT, f"{path.stat().st_size / 1e6:.1f} MB"
    result = subprocess.run([rerun_binary(), "rrd", "verify", str(path)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    chunks = read_chunks(path)
    scene = sim.scenes.build(name)
    model = scene.model
    rows = table_rows(document(chunks))
    for key in model.parameters():
        assert key in rows and rows[key][3], f"{key} has no unit in the document"
    assert rows["mass"][3] == "kg" and rows["time step dt"][2] == "s"
    assert rows["stiffness"][3] == "N/m" and rows["spacing"][3] == "m"
    for heading in ("## Initial condition", "## How to read the views", "## Versions",
                    "recorded by", "frame interval", "rerun-sdk"):
        assert heading in document(chunks), heading
    assert default_timeline(path) == "sim_time"
    energy = [c for c in chunks if c.entity_path == "/energy/total" and not c.is_static][0]
    assert str(energy.to_record_batch().schema.field("sim_time").type).startswith("duration")
    assert temporal(chunks, "/drift/energy_balance_error", "Scalars:scalars")
    if model.dim == 2 and model.n_particles <= 2500:
        scale = scalar(static_value(chunks, "/lattice/springs", "strain_colour_scale"))
        rest = scalar(static_value(chunks, "/lattice/springs", "rest_strain"))
        assert rest == pytest.approx((model.spacing - model.rest_length) / model.rest_length)
        p99 = pooled_percentile(temporal(chunks, "/lattice/springs", "strain"), rest)
        assert 0.3 <= p99 / scale <= 1.0, (p99, scale)
    elif model.dim == 3:
        scale = scalar(static_value(chunks, "/lattice/surface", "height_colour_scale"))
        vertices = temporal(chunks, "/lattice/surface", "Mesh3D:vertex_positions")
        heights = {step: as_array(value, 3)[:, 2] for step, value in vertices.items()}
        p99 = np.percentile(np.abs(np.concatenate(list(heights.values()))), 99)
        assert 0.3 <= p99 / scale <= 1.0, (p99, scale)


@pytest.mark.parametrize("name", [
    name if name != "membrane" else pytest.param(name, marks=pytest.mark.slow)  # 3-D kernels
    for name in SMALL_PRESETS])
def test_every_small_preset_default_recording(tmp_path, name):
    path = tmp_path / f"{name}.rrd"
    assert main(["record", name, "-o", str(path), "--quiet"]) == 0
    check_default_recording(path, name)


@pytest.mark.slow
def test_interference_default_recording(tmp_path):
    path = tmp_path / "interference.rrd"
    assert main(["record", "interference", "-o", str(path), "--quiet"]) == 0
    check_default_recording(path, "interference")


def test_document_names_the_displaced_particle_and_the_command(grid_file, tmp_path):
    path = tmp_path / "grid.rrd"
    assert main(["record", "grid", "--steps", "20", "-o", str(path), "--quiet"]) == 0
    text = document(read_chunks(path))
    model = sim.scenes.build("grid").model
    centre = (model.ny // 2) * model.nx + model.nx // 2  # the preset displaces the centre one
    assert f"particle {centre} (column i = {model.nx // 2}, row j = {model.ny // 2})" in text
    assert "(+0.4, +0.3) m" in text  # (0.4, 0.3) a with a = 1 m
    command = [line for line in text.splitlines() if "recorded by" in line][0]
    assert "`oscillators record grid " in command and "--steps 20" in command, command
    assert "every 1 steps = 0.01 | s" in text


def test_line_colours_are_readable_on_light_and_dark_themes(grid_file):
    from app.recording import style
    from sim.integrators.registry import INTEGRATORS, describe

    colours = [*style.TERM_COLOURS.values(), *(describe(name).colour for name in INTEGRATORS),
               style.DRIFT_COLOUR, style.NEUTRAL_COLOUR]
    for colour in colours:
        assert style.contrast_ratio(colour, style.WHITE) >= 3.0, colour
        assert style.contrast_ratio(colour, style.DARK_BACKGROUND) >= 3.0, colour
    path, _ = grid_file
    chunks = read_chunks(path)
    for term in ENERGY_TERMS:  # the grid has no driver: no `driven` line
        colour = style.TERM_COLOURS[term]
        packed = static_value(chunks, f"/energy/{term}", "SeriesLines:colors").as_py()[0]
        assert packed >> 8 == (colour[0] << 16) | (colour[1] << 8) | colour[2], term
    assert static_rows(chunks, "/legend/strain") == 1


def test_compare_plots_each_integrators_drift(tmp_path):
    path = tmp_path / "compare.rrd"
    assert main(["record", "grid", "--compare", "euler,verlet", "--dt", "0.01", "--steps", "300",
                 "--every", "10", "-o", str(path), "--quiet"]) == 0
    chunks = read_chunks(path)
    drift = {name: temporal(chunks, f"/{name}/drift/energy_balance_error", "Scalars:scalars")
             for name in ("euler", "verlet")}
    reference = sim.Simulation(sim.scenes.build("grid"), integrator="verlet", dt=0.01)
    reference.step(300)
    assert scalar(drift["verlet"][300]) == pytest.approx(100 * reference.energy_balance_error(),
                                                         rel=1e-6, abs=1e-9)
    # Euler gains energy on an undamped lattice (its amplification exceeds 1); Verlet does not
    assert scalar(drift["euler"][300]) > 10 * abs(scalar(drift["verlet"][300]))
    logs = {name: temporal(chunks, f"/{name}/drift/log10_abs_error", "Scalars:scalars")
            for name in ("euler", "verlet")}
    for name in ("euler", "verlet"):
        assert scalar(logs[name][300]) == pytest.approx(
            np.log10(abs(scalar(drift[name][300]))), abs=1e-9)
    for name in ("euler", "verlet"):  # each run keeps its own absolute-energy plot
        assert temporal(chunks, f"/{name}/energy/total", "Scalars:scalars")


def test_interference_field_is_signed_and_its_scale_fixed_on_request(tmp_path):
    path = tmp_path / "interference.rrd"
    assert main(["record", "interference", "--steps", "40", "--every", "20", "--field", "raw",
                 "--raw-dtype", "float16", "--scale", "fixed", "-o", str(path), "--quiet"]) == 0
    chunks = read_chunks(path)
    model = sim.scenes.build("interference").model
    images = temporal(chunks, "/field", "DepthImage:buffer")
    image = np.frombuffer(as_array(images[0]).astype(np.uint8).tobytes(), np.float16)
    field = image.reshape(model.ny, model.nx)[::-1].astype(float)  # row 0 at the bottom
    middle = model.ny // 2
    # at t = 0 the left source is pushed +0.5 a in y, the right one -0.5 a: opposite signs
    assert field[middle, 0] == pytest.approx(0.5 * model.spacing, rel=1e-3)
    assert field[middle, -1] == pytest.approx(-0.5 * model.spacing, rel=1e-3)
    assert np.count_nonzero(field) == 2
    assert "u_y (m)" in document(chunks)
    limits = temporal(chunks, "/colour_scale/field", "Scalars:scalars")
    assert len({scalar(value) for value in limits.values()}) == 1  # fixed: one limit throughout
    assert "The scale is fixed for the whole recording" in document(chunks)


def test_a_lattice_of_another_spacing_ends_the_probes_and_modes_with_a_warning_and_notes(
        tmp_path):
    """The views that follow particles of one lattice end when its spacing changes: a WARN says
    so at that step, and the probes' spectra still reach the read-me."""
    scene = sim.scenes.build("grid")
    runner = Runner(sim.Simulation(scene))
    path = tmp_path / "reshaped.rrd"
    options = RecordingOptions(probes=[(3, 4)], modes=True, modes_every=1, frame_interval=0,
                               background=False)
    with Recorder(path, scene, options=options) as recorder:
        recorder.attach(runner)
        runner.advance(40, every=2)
        runner.post(lambda s: s.set_parameters(spacing=1.2))
        runner.advance(4, every=2)
    chunks = read_chunks(path)
    warnings = [(step, text) for step, text, level in texts(chunks, "/log") if level == "WARN"]
    assert any("probes stop here" in text for _, text in warnings), warnings
    assert any("mode energies stop here" in text for _, text in warnings), warnings
    assert {step for step, _ in warnings} == {42}
    probe_steps = temporal(chunks, "/probes/3_4/y", "Scalars:scalars")
    assert probe_steps and max(probe_steps) == 40
    assert "Probes: spectra" in document(chunks)
