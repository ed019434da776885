"""Instruments in recordings (probes, mode energies, a driver's work, a sponge's outline): real
``.rrd`` files written by ``oscillators record`` or ``app.recording.Recorder`` and read back with
rerun's own reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

import sim
from app.cli import main
from app.recording import Recorder, RecordingOptions, instruments, style
from sim.runtime.runner import Runner
from tests.test_recording import as_array, document, read_chunks, scalar, temporal


def tensor(value: object) -> np.ndarray:
    """A tensor cell (``Tensor:data``, ``BarChart:values``) as a numpy array of its shape."""
    cell = value.as_py()[0]  # type: ignore[attr-defined]
    return np.asarray(cell["buffer"], dtype=float).reshape(cell["shape"])


def static_chunks(chunks: list, entity: str) -> list:
    return [chunk.to_record_batch() for chunk in chunks
            if chunk.entity_path == entity and chunk.is_static]


def view_origins(path: Path) -> dict[str, str]:
    """{view name: origin} of the default blueprint."""
    reader = RrdReader(path)
    views = {}
    for store in reader.blueprints():
        for chunk in reader.stream(store=store).to_chunks():
            batch = chunk.to_record_batch()
            if "ViewBlueprint:space_origin" in batch.schema.names:
                name = batch.column("ViewBlueprint:display_name").to_pylist()[0][0]
                views[name] = batch.column("ViewBlueprint:space_origin").to_pylist()[0][0]
    return views


# --- probes and the driver -----------------------------------------------------------------------


@pytest.fixture(scope="module")
def resonance_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("resonance") / "resonance.rrd"
    assert main(["record", "resonance", "--duration", "30", "--every", "5", "--probe", "0,0",
                 "--probe", "6,0", "-o", str(path), "--quiet"]) == 0
    return path


def test_probe_series_has_one_value_per_frame_at_the_drivers_frequency(resonance_file):
    chunks = read_chunks(resonance_file)
    series = temporal(chunks, "/probes/0_0/x", "Scalars:scalars")
    frames = temporal(chunks, "/energy/total", "Scalars:scalars")
    assert sorted(series) == sorted(frames) == list(range(0, 3001, 5))
    assert temporal(chunks, "/probes/0_0/y", "Scalars:scalars")  # both in-plane components
    assert not temporal(chunks, "/probes/0_0/z", "Scalars:scalars")  # z only in 3-D
    scene = sim.scenes.build("resonance")
    reference = sim.Simulation(scene)
    reference.step(1500)
    expected = reference.peek_positions()[0, 0] - reference.rest_positions[0, 0]
    assert scalar(series[1500]) == pytest.approx(expected, rel=1e-12, abs=1e-15)

    values = np.array([scalar(series[step]) for step in sorted(series)])
    interval = 5 * scene.dt
    window = np.hanning(values.size)
    amplitudes = np.abs(np.fft.rfft((values - values.mean()) * window))
    frequencies = np.fft.rfftfreq(values.size, interval)
    resolution = 1.0 / (values.size * interval)
    driver = scene.model.driver
    assert abs(frequencies[np.argmax(amplitudes)] - driver.frequency) <= resolution


def test_spectra_and_their_peaks_are_explained(resonance_file):
    chunks = read_chunks(resonance_file)
    bars = static_chunks(chunks, "/spectra/0_0/x")
    assert len(bars) == 1
    amplitudes = tensor(bars[0].column("BarChart:values")[0])
    frequencies = tensor(bars[0].column("BarChart:abscissa")[0])
    assert amplitudes.size == frequencies.size == 601 // 2 + 1
    driver = sim.scenes.build("resonance").model.driver
    assert abs(frequencies[np.argmax(amplitudes)] - driver.frequency) <= 1 / 30
    text = document(chunks)
    assert driver.describe() in text
    peaks = [line for line in text.splitlines() if line.startswith("* Probe (0, 0), u_x:")]
    assert peaks and "normal mode (3, 1) x at 0.6678 Hz" in peaks[0], peaks
    assert "## Driver and walls" in text and "`driven`" in text
    views = view_origins(resonance_file)
    assert views["probe displacement (m)"] == "/probes"
    assert views["probe spectra (m against Hz, at the end)"] == "/spectra"


def test_energy_plot_of_a_driven_scene_contains_the_drivers_work(resonance_file):
    chunks = read_chunks(resonance_file)
    driven = temporal(chunks, "/energy/driven", "Scalars:scalars")
    assert sorted(driven) == list(range(0, 3001, 5))
    reference = sim.Simulation(sim.scenes.build("resonance"))
    reference.step(3000)
    energy = reference.energy()
    assert scalar(driven[3000]) == pytest.approx(energy.driven, rel=1e-9)
    assert energy.driven > energy.total > 0  # the drag took the rest
    balance = scalar(temporal(chunks, "/drift/energy_balance_error", "Scalars:scalars")[3000])
    assert balance == pytest.approx(100 * reference.energy_balance_error(), rel=1e-6, abs=1e-9)
    assert abs(balance) < 1.0  # measured with Energy.balance, the driver's work included
    assert static_chunks(chunks, "/lattice/driver")
    colour = static_chunks(chunks, "/energy/driven")[0].column("SeriesLines:colors")[0].as_py()[0]
    red, green, blue = style.TERM_COLOURS["driven"]
    assert colour >> 8 == (red << 16) | (green << 8) | blue


def test_probe_outside_the_lattice_is_refused(tmp_path, capsys):
    path = tmp_path / "x.rrd"
    assert main(["record", "chain", "--probe", "5,0", "--steps", "5", "-o", str(path),
                 "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: --probe") and "columns 0-4 and rows 0-0" in error
    assert not path.exists() and not list(tmp_path.iterdir())
    with pytest.raises(SystemExit):
        main(["record", "chain", "--probe", "2", "-o", str(path)])


@pytest.mark.slow
def test_resonance_default_recording(tmp_path):
    """The driven preset's default recording is what every preset's must be (small, explained,
    colour scales neither saturated nor faint)."""
    from tests.test_recording import check_default_recording

    path = tmp_path / "resonance.rrd"
    assert main(["record", "resonance", "-o", str(path), "--quiet"]) == 0
    check_default_recording(path, "resonance")


# --- mode energies --------------------------------------------------------------------------------


def test_mode_energies_add_up_to_kinetic_and_spring_energy(tmp_path):
    path = tmp_path / "modes.rrd"
    assert main(["record", "grid", "--set", "linear=true", "--modes", "--steps", "40",
                 "--every", "4", "-o", str(path), "--quiet"]) == 0
    chunks = read_chunks(path)
    model = sim.scenes.build("grid", linear=True).model
    energies = {name: temporal(chunks, f"/modes/{name}/energy", "Tensor:data")
                for name in ("x", "y")}
    kinetic = temporal(chunks, "/energy/kinetic", "Scalars:scalars")
    potential = temporal(chunks, "/energy/potential", "Scalars:scalars")
    assert sorted(energies["x"]) == sorted(energies["y"]) == sorted(kinetic) == list(range(0, 41, 4))
    for step in energies["x"]:
        x, y = tensor(energies["x"][step]), tensor(energies["y"][step])
        assert x.shape == y.shape == (model.ny, model.nx)
        expected = scalar(kinetic[step]) + scalar(potential[step])  # no gravity: springs only
        assert x.sum() + y.sum() == pytest.approx(expected, rel=1e-6)
    images = temporal(chunks, "/modes/x/image", "Image:buffer")
    assert sorted(images) == sorted(energies["x"])
    assert as_array(images[40]).size == model.nx * model.ny * 3
    views = view_origins(path)
    assert views["energy per mode, x (log colour)"] == "/modes/x/image"
    assert "energy per mode" in document(chunks)


def test_mode_energies_are_thinned_and_refused_where_they_cannot_run(tmp_path, capsys):
    scene = sim.scenes.build("chain", linear=True)
    runner = Runner(sim.Simulation(scene))
    path = tmp_path / "thinned.rrd"
    options = RecordingOptions(modes=True, modes_every=3, frame_interval=0, background=False)
    with Recorder(path, scene, options=options) as recorder:
        recorder.attach(runner)
        runner.publish()
        runner.advance(10, every=1)
    steps = sorted(temporal(read_chunks(path), "/modes/x/energy", "Tensor:data"))
    assert steps == [0, 3, 6, 9]
    # the default keeps a whole recording's mode energies within their budget
    big = sim.scenes.build("grid", nx=300, ny=200).model
    every = instruments.modes_every(big, 1000)
    assert 1000 / every * instruments.mode_frame_bytes(big) <= instruments.MODES_BUDGET_BYTES
    assert instruments.mode_image_shape(big) == (100, 100)

    refused = tmp_path / "refused.rrd"
    assert main(["record", "ionic", "--set", "nx=50", "--set", "ny=41", "--modes", "--steps", "5",
                 "-o", str(refused), "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: --modes") and "2,000 particles" in error
    assert not refused.exists()


def test_nearest_mode_is_the_one_sim_probes_names():
    from sim.instruments.probes import nearest_modes

    for model in (sim.scenes.build("resonance").model,
                  sim.scenes.build("membrane", nx=6, ny=5).model):
        for frequency in np.linspace(0.05, 2.0, 25):
            mine, listed = instruments.nearest_mode(model, frequency), nearest_modes(model, frequency)[0]
            assert abs(mine.frequency - frequency) == pytest.approx(abs(listed.frequency - frequency))
    assert instruments.nearest_mode(sim.scenes.build("ionic").model, 1.0) is None


def test_block_sums_keep_the_energy():
    values = np.random.default_rng(1).random((383, 682))
    summed = instruments.block_sum(values, 3, 6)
    assert summed.shape == (128, 114)
    assert summed.sum() == pytest.approx(values.sum(), rel=1e-12)


# --- the sponge -----------------------------------------------------------------------------------


def test_absorbing_layer_is_outlined_and_explained(tmp_path):
    scene = sim.scenes.build("grid", boundary="absorbing", sponge_width=2)
    path = tmp_path / "sponge.rrd"
    runner = Runner(sim.Simulation(scene))
    options = RecordingOptions(field="raw", positions="all", frame_interval=0, background=False)
    with Recorder(path, scene, options=options) as recorder:
        recorder.attach(runner)
        runner.advance(2, every=1)
    chunks = read_chunks(path)
    model = scene.model
    lines = static_chunks(chunks, "/lattice/sponge")
    strips = [as_array(strip, 2) for strip in lines[0].column("LineStrips2D:strips")[0].values]
    rest = model.rest_positions
    x0, y0, a, w = rest[0, 0], rest[0, 1], model.spacing, model.sponge_width
    xs = sorted({float(x) for strip in strips for x in strip[:, 0]})
    ys = sorted({float(y) for strip in strips for y in strip[:, 1]})
    # the inner edge lies between the layer's last particle and the first free one
    assert xs == pytest.approx([x0 + (w - 0.5) * a, x0 + (model.nx - w - 0.5) * a])
    assert ys == pytest.approx([y0 + (w - 0.5) * a, y0 + (model.ny - w - 0.5) * a])
    pixels = static_chunks(chunks, "/field/sponge")[0].column("LineStrips2D:strips")[0].values
    corners = np.concatenate([as_array(strip, 2) for strip in pixels])
    assert corners.min(axis=0) == pytest.approx([w, w])
    assert corners.max(axis=0) == pytest.approx([model.nx - w, model.ny - w])
    text = document(chunks)
    assert "**Absorbing walls**" in text and f"{w} particles deep" in text


def test_an_fput_recording_has_the_mode_shares_and_the_return(tmp_path):
    path = tmp_path / "fput.rrd"
    assert main(["record", "fput", "--modes", "-o", str(path), "--quiet"]) == 0
    chunks = read_chunks(path)
    first = temporal(chunks, "/modes/shares/1", "Scalars:scalars")
    shares = np.array([scalar(first[step]) for step in sorted(first)])
    assert shares[0] > 0.99 and shares.min() < 0.1
    for mode in (2, 3, 4):
        assert max(scalar(v) for v in temporal(chunks, f"/modes/shares/{mode}",
                                               "Scalars:scalars").values()) > 0.2
    returns = [chunk.to_record_batch() for chunk in chunks
               if chunk.entity_path == "/modes/shares/returns" and not chunk.is_static]
    times = [t / 1e9 for batch in returns
             for t in batch.column("sim_time").cast("int64").to_pylist()]
    values = [scalar(v) for batch in returns for v in batch.column("Scalars:scalars")]
    assert len(values) == 1 and values[0] > 0.97
    assert times[0] / sim.scenes.presets.FPUT_PERIOD == pytest.approx(153.4, abs=1.0)
    assert view_origins(path)["share of energy in modes 1-4"] == "/modes/shares"
    assert "mode 1's energy came back: 98.1% at 153" in document(chunks)
