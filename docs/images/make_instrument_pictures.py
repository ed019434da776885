"""Draw the pictures of ``docs/instruments.md`` that no ``oscillators`` command draws, and print
the numbers quoted there:

* ``mode_energies.png``: the energy in every normal mode of an 11x7 grid (linearised springs)
  after one particle in its middle was displaced, per polarisation, as log-colour heat maps;
  checks that the mode energies add up to kinetic + spring energy;
* ``probe_spectrum.png``: the spectrum of particle (0, 0) of the ``resonance`` preset over its
  60 s run (what ``oscillators run resonance --probe 0,0`` prints), with the chain's normal-mode
  frequencies marked;
* ``bandgap.png``: the steady amplitude along the ``bandgap`` preset's ionic chain driven inside
  the gap and in each band, with the decay predicted by the dispersion relation;
* ``walls.png``: one pulse on a chain with fixed walls, free ends and periodic rows, as
  space-time pictures.

Run from the repository root (deterministic, about half a minute)::

    .venv/bin/python docs/images/make_instrument_pictures.py
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

import sim  # noqa: E402
from sim.theory.modes import mode_energies  # noqa: E402
from sim.theory.observables import highest_frequency  # noqa: E402
from sim.instruments.probes import ProbeSeries, dominant_frequencies, mode_table, spectrum  # noqa: E402

HERE = Path(__file__).resolve().parent
STIFFNESS = 35.0


def draw_mode_energies(path: Path) -> None:
    """Heat maps of the mode energies of the 11x7 grid, 3 s after its middle particle was
    displaced by (0.4, 0.3) m and released (linearised springs, RK4 dt = 0.01 s)."""
    scene = sim.scenes.build("grid", nx=11, ny=7, linear=True)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.01)
    simulation.step(300)
    model = simulation.model
    energies = mode_energies(model, simulation.positions, simulation.velocities)
    energy = simulation.energy()
    total = sum(float(part.sum()) for part in energies)
    print(f"mode energies: sum {total:.9f} J, kinetic + spring {energy.kinetic + energy.spring:.9f}"
          f" J, relative difference {total / (energy.kinetic + energy.spring) - 1:+.1e}")
    figure, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    largest = max(float(part.max()) for part in energies)
    norm = LogNorm(vmin=largest * 1e-6, vmax=largest)
    for axis, part, name in zip(axes, energies, ("x (along the rows)", "y (along the columns)"),
                                strict=True):
        image = axis.imshow(np.maximum(part, largest * 1e-7), origin="lower", cmap="magma",
                            norm=norm, extent=(0.5, model.nx + 0.5, 0.5, model.ny + 0.5))
        axis.set_xticks(range(1, model.nx + 1))
        axis.set_yticks(range(1, model.ny + 1))
        axis.set_xlabel("m (half-waves along x)")
        axis.set_ylabel("n (half-waves along y)")
        axis.set_title(f"polarisation {name}: {float(part.sum()):.4f} J", fontsize=10)
    figure.colorbar(image, ax=axes, label="mode energy (J)", shrink=0.9)
    figure.suptitle(
        f"11x7 grid, middle particle displaced (0.4, 0.3) m, t = 3 s: mode energies sum to "
        f"{total:.6f} J = kinetic + spring energy; even m or n: a node at that particle, "
        "no energy", fontsize=9,
    )
    figure.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(figure)


def draw_probe_spectrum(path: Path) -> None:
    """The spectrum of particle (0, 0) of the resonance preset over its 60 s run, sampled as
    ``oscillators run --probe`` samples it (four times per period of the fastest mode)."""
    scene = sim.scenes.build("resonance")
    simulation = sim.Simulation(scene)
    model = simulation.model
    probes = ProbeSeries(model, [0], limit=1 << 20)
    probes.add(simulation.time, simulation.positions)
    chunk = max(1, int(math.pi / (2 * highest_frequency(model) * simulation.dt)))
    while simulation.time < scene.duration - 1e-9:
        simulation.step(chunk)
        probes.add(simulation.time, simulation.positions)
    values = probes.displacements[:, 0, 0]
    interval = float(np.mean(np.diff(probes.times)))
    frequencies, amplitudes = spectrum(values, interval)
    peaks = dominant_frequencies(values, interval, count=3)
    modes = [mode for mode in mode_table(model) if mode.polarisation == "x"]
    print("probe (0, 0) of resonance: " + "; ".join(
        f"{f:.4g} Hz ({a:.3g} m)" for f, a in peaks))
    figure, axis = plt.subplots(figsize=(10, 4.4))
    for index, mode in enumerate(modes):
        axis.axvline(mode.frequency, color="grey", linestyle="--", linewidth=0.8, alpha=0.6,
                     label="normal modes (x)" if index == 0 else None)
        axis.text(mode.frequency, 1.01, f"n={mode.m}", rotation=90, fontsize=7, ha="center",
                  va="bottom", transform=axis.get_xaxis_transform())
    axis.semilogy(frequencies, amplitudes, color="tab:blue", linewidth=1,
                  label="spectrum of the displacement (Hann window)")
    for frequency, amplitude in peaks:
        axis.plot(frequency, amplitude, "o", color="tab:red", markersize=5)
        axis.annotate(f"{frequency:.4g} Hz", (frequency, amplitude), textcoords="offset points",
                      xytext=(6, 4), fontsize=8, color="tab:red")
    axis.set_xlim(0, 2.2)
    axis.set_ylim(amplitudes[frequencies < 2.2].max() * 1e-4, amplitudes.max() * 3)
    axis.set_xlabel("frequency (Hz)")
    axis.set_ylabel("amplitude (m)")
    axis.legend(fontsize=8, loc="upper right")
    axis.set_title("oscillators run resonance --probe 0,0: particle (0, 0) over 60 s; the drive "
                   "at f3 = 0.6678 Hz and the transients of modes 2 and 4 ring", fontsize=9,
                   pad=28)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def gap_decay_per_spacing(omega: float, light: float = 1.0, heavy: float = 4.0) -> float:
    """kappa a of the evanescent wave of the diatomic chain at ``omega`` (rad/s) inside its gap:
    with s = 1/m + 1/M, q a = pi/2 + i kappa a in the dispersion relation
    omega^2 = k s -+ k sqrt(s^2 - 4 sin^2(q a) / (m M)) gives
    cosh^2(kappa a) = m M (s^2 - (omega^2 / k - s)^2) / 4."""
    s = 1 / light + 1 / heavy
    cosh_squared = light * heavy * (s**2 - (omega**2 / STIFFNESS - s) ** 2) / 4
    return math.acosh(math.sqrt(cosh_squared))


def steady_amplitudes(scene: sim.Scene, frequency: float, settle: float = 300.0,
                      periods: int = 30) -> np.ndarray:
    """Amplitude (m) of every particle's motion along x at the drive frequency, fitted over
    ``periods`` periods after the ramp and ``settle`` seconds.  Many periods: the transients at
    the band edges travel slowly (group velocity near zero) and linger for hundreds of seconds;
    a long fit window keeps their leak into the fitted amplitude below 1e-7 m."""
    driver = dataclasses.replace(scene.model.driver, frequency=frequency)
    model = scene.model.replace(driver=driver)
    simulation = sim.Simulation(dataclasses.replace(scene, model=model))
    simulation.step(int(round((driver.ramp + settle) / simulation.dt)))
    omega = 2 * math.pi * frequency
    steps = int(round(periods / frequency / simulation.dt))
    stride = max(1, steps // 400)
    times, rows = [], []
    for _ in range(steps // stride):
        simulation.step(stride)
        times.append(simulation.time)
        rows.append(simulation.positions[:, 0] - simulation.rest_positions[:, 0])
    t = np.array(times)
    basis = np.stack([np.cos(omega * t), np.sin(omega * t), np.ones_like(t)], axis=1)
    coefficients, *_ = np.linalg.lstsq(basis, np.array(rows), rcond=None)
    return np.hypot(coefficients[0], coefficients[1])


def draw_bandgap(path: Path) -> None:
    scene = sim.scenes.build("bandgap")
    model = scene.model
    acoustic_top = math.sqrt(2 * STIFFNESS / 4.0) / (2 * math.pi)
    optical_bottom = math.sqrt(2 * STIFFNESS / 1.0) / (2 * math.pi)
    figure, axis = plt.subplots(figsize=(10, 4.6))
    columns = np.arange(model.nx)
    axis.axvspan(model.nx - model.sponge_width - 0.5, model.nx - 0.5, color="tab:grey",
                 alpha=0.15, label=f"sponge ({model.sponge_width} particles)")
    for frequency, colour, where in ((0.4, "tab:blue", "acoustic band"),
                                     (0.95, "tab:red", "inside the gap"),
                                     (1.4, "tab:green", "optical band")):
        amplitude = steady_amplitudes(scene, frequency)
        axis.semilogy(columns, amplitude, ".-", color=colour, markersize=3, linewidth=0.8,
                      label=f"{frequency:g} Hz, {where}")
        if where == "inside the gap":
            kappa = gap_decay_per_spacing(2 * math.pi * frequency)
            heavy = amplitude[0:12:2]
            measured = -np.polyfit(np.arange(heavy.size) * 2.0, np.log(heavy), 1)[0]
            print(f"bandgap at {frequency} Hz: kappa a predicted {kappa:.4f} (decay length "
                  f"{1 / kappa:.3f} a, amplitude x{math.exp(-2 * kappa):.3f} per cell), measured "
                  f"on the heavy particles {measured:.4f}")
            axis.semilogy(columns[:30], amplitude[0] * np.exp(-kappa * columns[:30]), "k--",
                          linewidth=1, label=f"exp(-kappa x), kappa a = {kappa:.3f} from the "
                          "dispersion relation")
    axis.set_ylim(1e-9, 1e2)  # headroom for the legend above the travelling waves
    axis.set_xlabel("particle (column)")
    axis.set_ylabel("steady amplitude (m)")
    axis.set_title(f"bandgap preset: ionic chain (4 kg / 1 kg), gap {acoustic_top:.3f} to "
                   f"{optical_bottom:.3f} Hz, driven at particle 0 (force, A = 0.02 m)",
                   fontsize=10)
    axis.legend(fontsize=8, loc="upper right")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def pulse_history(boundary: str, particles: int = 120, seconds: float = 30.0,
                  samples: int = 240) -> np.ndarray:
    """(samples, particles) longitudinal displacement of a linear chain carrying a Gaussian
    pulse that starts in the middle and runs left (u(x + c t)), c = sqrt(k/m) spacings/s."""
    stiffness = 35.0
    model = sim.Model.create(particles, 1, stiffness=stiffness, linear=True, boundary=boundary)
    columns = np.arange(particles)
    pulse = 0.01 * np.exp(-0.5 * ((columns - particles / 2) / 4.0) ** 2)
    positions = model.rest_positions.copy()
    velocities = np.zeros_like(positions)
    positions[:, 0] += pulse
    velocities[:, 0] = math.sqrt(stiffness) * np.gradient(pulse)
    simulation = sim.Simulation(sim.Scene(name="pulse", model=model, initial_positions=positions,
                                          initial_velocities=velocities),
                                integrator="rk4", dt=0.02)
    every = max(1, int(round(seconds / samples / simulation.dt)))
    history = []
    for _ in range(samples):
        history.append(simulation.positions[:, 0] - model.rest_positions[:, 0])
        simulation.step(every)
    return np.array(history)


def draw_walls(path: Path) -> None:
    """Space-time pictures of one pulse on a fixed, a free and a periodic chain."""
    figure, axes = plt.subplots(1, 3, figsize=(11, 3.6), sharey=True)
    seconds = 30.0
    for axis, boundary in zip(axes, ("fixed", "free", "periodic"), strict=True):
        history = pulse_history(boundary, seconds=seconds)
        image = axis.imshow(history, aspect="auto", origin="lower", cmap="RdBu_r",
                            vmin=-0.01, vmax=0.01, extent=(0, history.shape[1], 0, seconds))
        axis.set_title({"fixed": "fixed walls: comes back inverted",
                        "free": "free ends: comes back upright",
                        "periodic": "periodic: leaves left, enters right"}[boundary], fontsize=9)
        axis.set_xlabel("particle (column)")
    axes[0].set_ylabel("time (s)")
    figure.colorbar(image, ax=axes, label="displacement u_x (m)", shrink=0.9)
    figure.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(figure)


def main() -> None:
    draw_mode_energies(HERE / "mode_energies.png")
    draw_probe_spectrum(HERE / "probe_spectrum.png")
    draw_bandgap(HERE / "bandgap.png")
    draw_walls(HERE / "walls.png")
    print(f"pictures written to {HERE}")


if __name__ == "__main__":
    main()
