"""Probes against theory: the spectrum of a probed particle peaks at the normal-mode frequency.

The chain's longitudinal modes are those of the paper's equation (3):
omega_n = 2 sqrt(k/m) sin(n pi / (2 (N + 1))).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.instruments.probes import ProbeSeries, dominant_frequencies, spectrum, uniform_series
from sim.theory.modes import excited_state


def chain_frequency(n: int, model: sim.Model) -> float:
    """Hz of the chain's n-th longitudinal mode (equation (3))."""
    omega = 2 * math.sqrt(model.stiffness / model.masses.flat[0]) * math.sin(
        n * math.pi / (2 * (model.nx + 1)))
    return omega / (2 * math.pi)


@pytest.mark.parametrize("mode", [1, 2, 4])
def test_a_probe_on_an_excited_mode_peaks_at_its_frequency(mode):
    scene = sim.scenes.build("chain", linear=True)
    model = scene.model
    positions, velocities = excited_state(model, mode, 1, 0, 0.05)
    simulation = sim.Simulation(sim.Scene(name="chain", model=model, initial_positions=positions,
                                          initial_velocities=velocities), integrator="rk4",
                                dt=0.01)
    probe = ProbeSeries(model, [0])
    duration = 80.0
    for _ in range(int(duration / 0.05)):
        probe.add(simulation.time, simulation.state.particle_positions())
        simulation.step(5)
    (frequency, _), *_ = probe.dominant(0, 0)
    resolution = 1.0 / duration
    assert frequency == pytest.approx(chain_frequency(mode, model), abs=resolution)


def test_the_spectrum_reads_a_sine_at_its_amplitude_and_frequency():
    interval, count = 0.01, 4000
    times = interval * np.arange(count)
    values = 0.3 * np.sin(2 * np.pi * 2.37 * times) + 0.05
    frequencies, amplitudes = spectrum(values, interval)
    assert frequencies[np.argmax(amplitudes)] == pytest.approx(2.37, abs=1 / (count * interval))
    assert amplitudes.max() == pytest.approx(0.3, rel=0.2)  # Hann window: scalloping < 16 %
    (peak, _), = dominant_frequencies(values, interval, count=1)
    assert peak == pytest.approx(2.37, abs=0.1 / (count * interval))


def test_uneven_samples_are_resampled_onto_an_even_grid():
    times = np.sort(np.random.default_rng(1).uniform(0, 10, 500))
    values, interval = uniform_series(times, np.sin(times))
    grid = times[0] + interval * np.arange(500)
    np.testing.assert_allclose(values, np.sin(grid), atol=2e-3)


def test_run_prints_the_dominant_frequencies_of_a_probe(capsys):
    from app.cli import main

    assert main(["run", "chain", "--set", "linear=true", "--probe", "2,0", "--duration", "60",
                 "--quiet"]) == 0
    output = capsys.readouterr().out
    line = next(line for line in output.splitlines() if line.startswith("probe particle 2"))
    first = float(line.split(": ")[1].split(" Hz")[0])
    model = sim.scenes.build("chain").model
    assert first == pytest.approx(chain_frequency(1, model), abs=1 / 60)
    assert "mode (1, 1) x" in line


@pytest.mark.parametrize("probe", ["9,0", "1", "a,b", "-1,0"])
def test_a_bad_probe_is_refused_with_one_line(probe, capsys):
    from app.cli import main

    assert main(["run", "chain", f"--probe={probe}", "--steps", "10", "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: --probe") and "Traceback" not in error


def _chain_page(folder, mode: int, duration: float):
    """A page of the linearised chain in its normal mode ``mode`` (x), solved exactly (dt 0.1 s),
    whose scene lasts ``duration`` (s); started (call ``.stop()``)."""
    from app.web.app import WebApp
    from tests.helpers import free_port

    model = sim.scenes.build("chain", linear=True).model
    positions, velocities = excited_state(model, mode, 1, 0, 0.05)
    scene = sim.Scene(name="chain", model=model, initial_positions=positions,
                      initial_velocities=velocities, integrator="exact", dt=0.1,
                      duration=duration)
    app = WebApp(sim.Simulation(scene), port=free_port(), scenes_dir=folder,
                 recordings_dir=folder)
    app.start()
    return app, model


def test_the_page_probes_the_selection_and_finds_the_mode(tmp_path):
    from tests.helpers import wait_for
    from tests.test_web_safety import press, settle

    app, model = _chain_page(tmp_path, 2, 120.0)
    try:
        # the first frame drawn clears the selection: select after it
        assert wait_for(lambda: app.view.last_positions is not None)
        probes = app.panel.probes
        press(probes.probe_button)
        assert "select particles first" in probes.text.content
        app.set_selection(np.array([1]))
        press(probes.probe_button)
        probes.component.value = "x"
        app.panel.run.speed.value = "as fast as it can"  # not real time: 60 s in a few seconds
        app.runner.steps_per_frame = 2  # a frame every 0.2 s: Nyquist 2.5 Hz
        app.runner.play()
        assert wait_for(lambda: probes.series is not None and probes.series.times.size > 0
                        and probes.series.times[-1] > 60, timeout=60)
        app.runner.pause()
        settle(app)
        (frequency, _), *_ = probes.series.dominant(0, 0)
        span = probes.series.times[-1] - probes.series.times[0]
        assert frequency == pytest.approx(chain_frequency(2, model), abs=1 / span)
        assert wait_for(lambda: "mode (2, 1) x" in probes.text.content)
    finally:
        app.stop()


def test_probing_keeps_the_page_running_past_the_duration_until_the_sound_lasts(tmp_path):
    """The grid stops at its duration, but not while its probes' sound is shorter than 3 s
    (the chain's mode 1 at 0.487 Hz sounds x500: 1,500 s of simulated time); the run says why
    it goes on, and stops at the duration once the probing stops."""
    from tests.helpers import wait_for
    from tests.test_web_safety import press, settle

    app, _ = _chain_page(tmp_path, 1, 10.0)
    try:
        assert wait_for(lambda: app.view.last_positions is not None)
        probes, run = app.panel.probes, app.panel.run
        app.set_selection(np.array([2]))
        press(probes.probe_button)
        probes.component.value = "x"
        run.speed.value = "as fast as it can"
        app.runner.play()
        assert wait_for(lambda: app.runner.simulation.time > 30, timeout=60)
        assert app.runner.playing  # past the duration (10 s): the probes need 1,500 s
        assert "for the probes" in run.end_html.content and "goes on past" in run.end_html.content
        assert "1500 s of simulated time" in run.end_html.content
        press(probes.clear_button)  # no probes: the run stops at once, at the duration's note
        assert wait_for(lambda: not app.runner.playing, timeout=30)
        settle(app)
        assert "Paused at the scene" in run.end_html.content
    finally:
        app.stop()
