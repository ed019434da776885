"""Hearing a probe, against physics: the WAV made from a probed particle plays the lattice's own
motion sped up by the factor it reports.

* A chain excited in one normal mode: the WAV's dominant frequency divided by the factor is the
  mode's frequency of the paper's equation (3), omega_n = 2 sqrt(k/m) sin(n pi / (2 (N + 1))).
* With drag b on every particle each mode's amplitude decays as exp(-b t / 2m): so does the
  WAV's, at the simulated time of each audio sample (audio time times the factor).
* Two sources mirror-symmetric about the middle column: u_y is even under the mirror for sources
  in phase and odd for sources in antiphase, so at mirror-symmetric probes the channel
  difference (in phase) or sum (antiphase) is silent while the other is not.
"""

from __future__ import annotations

import io
import json
import math
import wave

import numpy as np
import pytest

import sim
from sim.instruments.probes import ProbeSeries, dominant_frequencies
from sim.instruments.sound import describe_factor, frequency_factor, probe_sound
from sim.theory.modes import excited_state

STIFFNESS = 35.0


def read_wav(data: bytes) -> tuple[np.ndarray, int]:
    """(samples (count, channels) as floats, sample rate) of 16-bit WAV bytes."""
    with wave.open(io.BytesIO(data)) as stream:
        assert stream.getsampwidth() == 2
        count, channels = stream.getnframes(), stream.getnchannels()
        samples = np.frombuffer(stream.readframes(count), dtype="<i2")
        return samples.reshape(count, channels).astype(float), stream.getframerate()


def probed_run(simulation: sim.Simulation, particles: list[int], duration: float,
               every: int = 5) -> ProbeSeries:
    """The probes' series over ``duration`` seconds, sampled every ``every`` steps."""
    probes = ProbeSeries(simulation.model, particles, limit=1 << 20)
    probes.add(simulation.time, simulation.state.particle_positions())
    for _ in range(round(duration / (every * simulation.dt))):
        simulation.step(every)
        probes.add(simulation.time, simulation.state.particle_positions())
    return probes


def chain_mode(mode: int, drag: float = 0.0) -> tuple[sim.Simulation, float]:
    """A linear 5-particle chain started in one longitudinal mode, and that mode's frequency
    (Hz) by equation (3)."""
    model = sim.Model.create(5, 1, stiffness=STIFFNESS, linear=True, drag=drag)
    positions, velocities = excited_state(model, mode, 1, 0, 0.05)
    scene = sim.Scene(name="chain", model=model, initial_positions=positions,
                      initial_velocities=velocities)
    omega = 2 * math.sqrt(STIFFNESS / 1.0) * math.sin(mode * math.pi / (2 * (model.nx + 1)))
    return sim.Simulation(scene, integrator="rk4", dt=0.01), omega / (2 * math.pi)


def test_the_factor_is_a_nice_number_that_brings_the_frequency_into_hearing():
    for frequency in np.geomspace(1e-3, 1e3, 61):
        factor = frequency_factor(frequency)
        mantissa = factor / 10 ** math.floor(math.log10(factor) + 1e-9)
        assert min(abs(mantissa - step) for step in (1, 2, 5)) < 1e-9
        assert 300 / math.sqrt(2.5) - 1e-6 <= frequency * factor <= 300 * math.sqrt(2.5) + 1e-6
    assert describe_factor(200, 1.3) == "×200: 1.3 Hz sounds as 260 Hz"


@pytest.mark.parametrize("mode", [1, 3])
def test_the_sound_of_a_mode_is_the_mode_sped_up_by_the_factor(mode):
    simulation, frequency = chain_mode(mode)
    probes = probed_run(simulation, [0], duration=frequency_factor(frequency) * 1.0)
    sound = probe_sound(probes.times, probes.displacements[:, 0, 0])
    samples, rate = read_wav(sound.wav)
    assert samples.shape[1] == 1 and rate == sound.rate
    assert samples.shape[0] / rate == pytest.approx(sound.seconds)
    (heard, _), = dominant_frequencies(samples[:, 0], 1.0 / rate, count=1)
    # within the resolution of the sound's spectrum (1 / its length), mapped back
    assert heard / sound.factor == pytest.approx(frequency, abs=1.0 / sound.simulated)
    assert 190 <= heard <= 475
    assert np.abs(samples).max() == pytest.approx(0.9 * 32767, abs=1)  # loud, not clipped


def test_a_damped_mode_decays_in_the_sound_at_the_rate_drag_predicts():
    drag = 0.004  # N s/m on 1 kg: every mode's amplitude decays as exp(-0.002 t)
    simulation, frequency = chain_mode(1, drag=drag)
    probes = probed_run(simulation, [2], duration=frequency_factor(frequency) * 1.0)
    sound = probe_sound(probes.times, probes.displacements[:, 0, 0])
    samples, rate = read_wav(sound.wav)
    tenth = samples.shape[0] // 10
    early = np.sqrt(np.mean(samples[tenth : 3 * tenth, 0] ** 2))
    late = np.sqrt(np.mean(samples[7 * tenth : 9 * tenth, 0] ** 2))
    apart = 6 * tenth / rate * sound.factor  # simulated seconds between the two windows
    assert late < early
    assert late / early == pytest.approx(math.exp(-drag / 2 * apart), rel=0.02)


def mirrored_sources(phase: float) -> sim.Simulation:
    """Two force sources along y on row 4, four columns either side of the middle column 10
    of a 21x9 lattice (mirror-symmetric about column 10), the second with ``phase``."""
    source = dict(row=4, direction="y", amplitude=0.01, frequency=0.8, kind="force", ramp=1.0)
    model = sim.Model.create(21, 9, stiffness=STIFFNESS, rest_length=0.8, linear=True,
                             sources=[dict(source, column=6), dict(source, column=14, phase=phase)])
    return sim.Simulation(model, integrator="verlet", dt=0.01)


@pytest.mark.parametrize("phase, silent", [(0.0, "difference"), (math.pi, "sum")])
def test_mirror_probes_of_mirror_sources_leave_the_sum_or_difference_silent(phase, silent):
    simulation = mirrored_sources(phase)
    nx = simulation.model.nx
    left, right = 4 * nx + 3, 4 * nx + 17  # row 4, columns 3 and 17: mirror images
    probes = probed_run(simulation, [left, right], duration=150.0)
    sound = probe_sound(probes.times, probes.displacements[:, :, 1])
    samples, _ = read_wav(sound.wav)
    assert samples.shape[1] == 2

    def rms(values: np.ndarray) -> float:
        return float(np.sqrt(np.mean(values ** 2)))

    channel = min(rms(samples[:, 0]), rms(samples[:, 1]))
    total, difference = rms(samples[:, 0] + samples[:, 1]), rms(samples[:, 0] - samples[:, 1])
    quiet, loud = (difference, total) if silent == "difference" else (total, difference)
    assert channel > 1000  # both channels sound (16-bit samples)
    assert quiet < 1e-3 * channel
    assert loud > 1.5 * channel


def test_nothing_to_hear_is_refused_clearly():
    times = np.linspace(0, 4, 100)
    with pytest.raises(ValueError, match="did not move"):
        probe_sound(times, np.zeros(100))
    with pytest.raises(ValueError, match="too short"):
        probe_sound(times, np.sin(2 * np.pi * 1.0 * times))  # 4 s at ×200: 0.02 s
    with pytest.raises(ValueError, match="one or two"):
        probe_sound(times, np.ones((100, 3)))


def test_run_writes_the_sound_of_its_probes(tmp_path, capsys):
    from app.cli import main

    target = tmp_path / "probe.wav"
    assert main(["run", "chain", "--set", "linear=true", "--probe", "2,0", "--probe", "1,0",
                 "--duration", "300", "--quiet", "--json", "--sound", str(target)]) == 0
    summary = json.loads(capsys.readouterr().out)
    samples, rate = read_wav(target.read_bytes())
    assert samples.shape[1] == 2
    assert summary["sound_file"] == str(target.resolve())
    factor = summary["sound_factor"]
    assert samples.shape[0] / rate == pytest.approx(300 / factor, abs=2 / rate)
    assert not list(tmp_path.glob("*.partial"))


def test_run_prints_its_summary_when_there_is_nothing_to_hear(tmp_path, capsys):
    from app.cli import main

    target = tmp_path / "short.wav"
    assert main(["run", "chain", "--probe", "2,0", "--duration", "10", "--quiet", "--json",
                 "--sound", str(target)]) == 2
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert "too short" in summary["sound_error"] and summary["probes"]
    assert captured.err.splitlines()[-1].startswith("error: --sound:")
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("arguments, message", [
    (["--sound", "x.wav"], "--sound needs --probe"),
    (["--probe", "0,0", "--probe", "1,0", "--probe", "2,0", "--sound", "x.wav"], "two"),
    (["--probe", "0,0", "--sound", "x.mp3"], ".wav"),
    (["--probe", "0,0", "--sound", "missing/x.wav"], "does not exist"),
])
def test_run_refuses_a_sound_it_cannot_make(arguments, message, tmp_path, monkeypatch, capsys):
    from app.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["run", "chain", "--steps", "10", "--quiet", *arguments]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: --sound") and message in error and "Traceback" not in error
    assert not list(tmp_path.iterdir())


@pytest.mark.slow  # 50 s: the page runs 50 s of simulated time for its sound (the tests above
# cover the sound itself in the default suite)
def test_the_page_plays_the_probes_and_forgets_them_on_reset(tmp_path):
    import base64
    import re

    from app.web.app import WebApp
    from app.web.folders.probes import SOUND_RATE, SOUND_SECONDS
    from tests.helpers import free_port, wait_for
    from tests.test_web_safety import press, settle

    simulation = mirrored_sources(math.pi)
    scene = sim.Scene(name="mirrored", model=simulation.model, integrator="verlet", dt=0.02,
                      duration=1000.0)
    app = WebApp(sim.Simulation(scene), port=free_port(), scenes_dir=tmp_path,
                 recordings_dir=tmp_path)
    app.start()
    try:
        assert wait_for(lambda: app.view.last_positions is not None)
        probes = app.panel.probes
        press(probes.hear_button)
        assert "probe particles first" in probes.player.content
        nx = simulation.model.nx
        app.set_selection(np.array([4 * nx + 3, 4 * nx + 17, 4 * nx + 18]))
        press(probes.probe_button)
        assert probes.player.content == ""
        probes.component.value = "y"
        app.panel.run.speed.value = "as fast as it can"
        app.runner.steps_per_frame = 10
        app.runner.play()
        assert wait_for(lambda: (probes.series.last_time or 0) > 60, timeout=60)
        app.runner.pause()
        settle(app)
        press(probes.hear_button)
        content = probes.player.content
        found = re.search(r'<audio controls src="data:audio/wav;base64,([A-Za-z0-9+/=]+)"', content)
        assert found, content
        assert len(found.group(1)) <= 4 / 3 * (44 + SOUND_RATE * SOUND_SECONDS * 4) + 4
        samples, rate = read_wav(base64.b64decode(found.group(1)))
        assert rate == SOUND_RATE and samples.shape[1] == 2  # the first two of three probes
        assert "probe 1 left, probe 2 right (of 3 probes)" in content
        assert "sounds as" in content
        # the two are mirror images in antiphase (the test above): the sum is silent
        assert np.abs(samples.sum(axis=1)).max() <= 1 and np.abs(samples).max() > 10000
        app.control.reset().result(timeout=5)
        assert wait_for(lambda: probes.player.content == "")
        press(probes.hear_button)
        press(probes.clear_button)
        assert probes.player.content == ""
    finally:
        app.stop()


def test_run_goes_on_until_the_probes_sound_lasts_three_seconds(tmp_path, capsys):
    """The chain's own 20 s would give 0.04 s of sound: run says how much it needs, runs on,
    and the WAV lasts 3 s; with a duration given, it makes the shorter sound and says the
    duration that 3 s need."""
    import wave

    from app.cli import main

    path = tmp_path / "chain.wav"
    assert main(["run", "chain", "--set", "linear=true", "--probe", "2,0", "--sound",
                 str(path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "--sound: 3 s of sound" in out and "running on to t = " in out
    with wave.open(str(path)) as sound:
        assert sound.getnframes() / sound.getframerate() == pytest.approx(3.0, abs=0.01)
    assert main(["run", "chain", "--set", "linear=true", "--probe", "2,0", "--sound",
                 str(tmp_path / "short.wav"), "--duration", "30", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "gives 0.15 s (give --duration 600 or more)" in out, out
