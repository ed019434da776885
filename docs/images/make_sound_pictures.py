"""Draw ``probe_sound.png`` of ``docs/instruments.md`` ("Hearing a probe") and print the numbers
quoted there: three WAV files made by ``sim.instruments.sound.probe_sound``, read back with the
standard library's ``wave`` and drawn as waveforms (audio time) with the envelope or the
silence the physics predicts:

* a damped mode: mode 1 of a linear 5-particle chain with drag 0.004 N s/m, whose amplitude
  decays as exp(-b t / 2m) in simulated time, i.e. exp(-b factor tau / 2m) in audio time tau;
* beats: modes 11 and 12 of a linear 12-particle chain together, which beat at f12 - f11,
  heard at (f12 - f11) times the factor;
* stereo: two sources in antiphase mirror-symmetric about the middle column of a 21x9 lattice,
  probed at mirror-image particles: left = -right, so left + right is silent.

Run from the repository root (deterministic, about ten seconds)::

    .venv/bin/python docs/images/make_sound_pictures.py
"""

from __future__ import annotations

import io
import math
import wave
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sim  # noqa: E402
from sim.instruments.probes import ProbeSeries, dominant_frequencies  # noqa: E402
from sim.instruments.sound import Sound, probe_sound  # noqa: E402
from sim.theory.modes import excited_state  # noqa: E402

HERE = Path(__file__).resolve().parent
STIFFNESS = 35.0


def chain_frequency(n: int, particles: int) -> float:
    """Hz of mode n of a chain between walls (equal masses 1 kg): the paper's equation (3)."""
    return 2 * math.sqrt(STIFFNESS) * math.sin(n * math.pi / (2 * (particles + 1))) / (2 * math.pi)


def probed(simulation: sim.Simulation, particles: list[int], seconds: float,
           every: int) -> ProbeSeries:
    probes = ProbeSeries(simulation.model, particles, limit=1 << 20)
    probes.add(simulation.time, simulation.positions)
    for _ in range(round(seconds / (every * simulation.dt))):
        simulation.step(every)
        probes.add(simulation.time, simulation.positions)
    return probes


def read(sound: Sound) -> np.ndarray:
    """(count, channels) samples as fractions of full scale."""
    with wave.open(io.BytesIO(sound.wav)) as stream:
        data = np.frombuffer(stream.readframes(stream.getnframes()), dtype="<i2")
        return data.reshape(-1, stream.getnchannels()) / 32767.0


def chain_started(particles: int, modes: list[int], drag: float = 0.0) -> sim.Simulation:
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, linear=True, drag=drag)
    positions = model.rest_positions.copy()
    for mode in modes:
        shaped, _ = excited_state(model, mode, 1, 0, 0.03)
        positions += shaped - model.rest_positions
    scene = sim.Scene(name="chain", model=model, initial_positions=positions,
                      initial_velocities=np.zeros_like(positions))
    return sim.Simulation(scene, integrator="rk4", dt=0.01)


def draw_probe_sound(path: Path) -> None:
    figure, axes = plt.subplots(3, 1, figsize=(10, 9))
    # a damped mode
    drag = 0.004
    damped = probe_sound(*_series(probed(chain_started(5, [1], drag), [2], 500.0, 5)))
    samples = read(damped)[:, 0]
    tau = np.arange(samples.size) / damped.rate
    start = np.abs(samples[: damped.rate // 20]).max()  # the first 50 ms
    envelope = start * np.exp(-drag / 2 * damped.factor * tau)
    axes[0].plot(tau, samples, linewidth=0.3, color="tab:blue", label="WAV (mono)")
    axes[0].plot(tau, envelope, "--", color="tab:red",
                 label=f"exp(-b t / 2m), t = {damped.factor:g} × audio time")
    (heard, _), = dominant_frequencies(samples, 1 / damped.rate, count=1)
    print(f"damped: {damped.describe()}; heard {heard:.2f} Hz / {damped.factor:g} = "
          f"{heard / damped.factor:.5f} Hz, equation (3) {chain_frequency(1, 5):.5f} Hz")
    axes[0].set_title(f"mode 1 of a 5-particle chain, drag {drag} N s/m: {damped.describe()}",
                      fontsize=9)
    # beats
    beating = probe_sound(*_series(probed(chain_started(12, [11, 12]), [0], 400.0, 2)))
    samples = read(beating)[:, 0]
    tau = np.arange(samples.size) / beating.rate
    beat = (chain_frequency(12, 12) - chain_frequency(11, 12)) * beating.factor
    axes[1].plot(tau, samples, linewidth=0.3, color="tab:blue", label="WAV (mono)")
    for k in range(int(tau[-1] * beat) + 1):
        axes[1].axvline(k / beat, color="tab:red", linewidth=0.6, alpha=0.5,
                        label=f"every 1 / ((f12 - f11) × factor) = {1 / beat:.3f} s"
                        if k == 0 else None)
    print(f"beats: {beating.describe()}; f11 {chain_frequency(11, 12):.4f} Hz, f12 "
          f"{chain_frequency(12, 12):.4f} Hz: beats at {beat:.2f} Hz in the sound")
    axes[1].set_title(f"modes 11 and 12 of a 12-particle chain, particle 0: "
                      f"{beating.describe()}", fontsize=9)
    # stereo, mirror images in antiphase
    source = dict(row=4, direction="y", amplitude=0.01, frequency=0.8, kind="force", ramp=1.0)
    model = sim.Model.create(21, 9, stiffness=STIFFNESS, rest_length=0.8, linear=True,
                             sources=[dict(source, column=6),
                                      dict(source, column=14, phase=math.pi)])
    series = probed(sim.Simulation(model, integrator="verlet", dt=0.01),
                    [4 * 21 + 3, 4 * 21 + 17], 150.0, 5)
    stereo = probe_sound(series.times, series.displacements[:, :, 1])
    samples = read(stereo)
    tau = np.arange(samples.shape[0]) / stereo.rate
    axes[2].plot(tau, samples[:, 0], linewidth=0.6, color="tab:blue",
                 label="left: column 3, row 4")
    axes[2].plot(tau, samples[:, 1], linewidth=0.6, color="tab:orange",
                 label="right: column 17, row 4")
    axes[2].plot(tau, samples.sum(axis=1), linewidth=1.2, color="black", label="left + right")
    rms = np.sqrt(np.mean(samples ** 2, axis=0))
    print(f"stereo: {stereo.describe()}; channel RMS {rms[0]:.4f}, {rms[1]:.4f} of full scale, "
          f"left + right RMS {np.sqrt(np.mean(samples.sum(axis=1) ** 2)):.3g}")
    axes[2].set_title(f"sources in antiphase, probes at mirror images: {stereo.describe()}",
                      fontsize=9)
    for axis in axes:
        axis.set_xlabel("audio time (s)")
        axis.set_ylabel("sample / full scale")
        axis.set_ylim(-1.05, 1.05)
        axis.legend(fontsize=8, loc="upper right")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _series(probes: ProbeSeries) -> tuple[np.ndarray, np.ndarray]:
    """(times, displacement along x of the first probe)."""
    return probes.times, probes.displacements[:, 0, 0]


if __name__ == "__main__":
    draw_probe_sound(HERE / "probe_sound.png")
    print(f"picture written to {HERE / 'probe_sound.png'}")
