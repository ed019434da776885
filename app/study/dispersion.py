"""The continuum limit: wave speed and dispersion measured from simulated chains.

Chains are one row of ``particles`` masses between two walls, unstressed (rest length = spacing)
with linearised springs, moving along the chain: the cross springs to the walls above and below
then add no stiffness, and the longitudinal motion is exactly that of a 1-D chain with fixed ends,
whose standing waves are sin(q x) with q = p pi / ((N + 1) a), p = 1..N.

* Dispersion (``measure_dispersion``): a random displacement excites every wavenumber; the
  displacement u(i, t) is recorded, sine-transformed in space (DST-I) and Fourier-transformed in
  time (Hann window); the peak of each wavenumber's spectrum, refined by parabolic interpolation of
  the log power, is its measured frequency, compared with omega = 2 sqrt(k/m) |sin(q a / 2)| and the
  continuum line omega = c q, c = a sqrt(k/m).
* Wave speed (``measure_wave_speed``): a wide Gaussian pulse (width >> a, so long wavelength)
  splits into two; the centroid of u^2 of the right-going half is tracked and fitted by a line.
* Ionic chain (``measure_ionic``): masses M, m alternating; the measured frequencies of all
  wavenumbers form the acoustic and optical branches,
  omega^2 = k (1/m + 1/M) -+ k sqrt((1/m + 1/M)^2 - 4 sin^2(q a) / (m M)), with a gap between
  sqrt(2k/M) and sqrt(2k/m), measured as the widest empty frequency interval.

Integration: the most accurate compiled integrator (``sim.integrators.most_accurate``: RK4) at
omega_max dt ~ 0.1, whose phase error (RK4: ~(omega dt)^4 / 120) is negligible.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

import sim
from sim.integrators.registry import most_accurate
from sim.theory.observables import highest_frequency

ProgressCallback = Callable[[str], None]


def chain_scene(particles: int, stiffness: float, mass: float | np.ndarray) -> sim.Scene:
    """A 1-row linearised unstressed chain of ``particles`` between walls, at rest."""
    scene = sim.scenes.build("chain", nx=particles, ny=1, stiffness=stiffness, mass=mass,
                             linear=True)
    return dataclasses.replace(scene, initial_positions=scene.model.rest_positions.copy())


def discrete_frequency(q: np.ndarray, stiffness: float, mass: float, spacing: float = 1.0):
    """omega(q) = 2 sqrt(k/m) |sin(q a / 2)| of the monatomic chain (rad/s); q in rad/m."""
    return 2 * np.sqrt(stiffness / mass) * np.abs(np.sin(np.asarray(q) * spacing / 2))


def ionic_branches(q: np.ndarray, stiffness: float, light: float, heavy: float,
                   spacing: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(acoustic, optical) omega(q) (rad/s) of the chain with masses alternating; q in rad/m
    (extended zone of the spacing a: the unit cell is 2 a)."""
    total = 1 / light + 1 / heavy
    root = np.sqrt(total**2 - 4 * np.sin(np.asarray(q) * spacing) ** 2 / (light * heavy))
    return np.sqrt(stiffness * (total - root)), np.sqrt(stiffness * (total + root))


def record_displacements(
    scene: sim.Scene, duration: float, sample_interval: float, steps_per_sample: int = 12,
    progress: ProgressCallback | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Run the scene with the most accurate integrator and return (times (n_t,) s, displacements
    along x (n_t, N) m)."""
    simulation = sim.Simulation(scene, integrator=most_accurate(scene.model),
                                dt=sample_interval / steps_per_sample)
    simulation.chunk_steps = steps_per_sample
    rest = scene.model.rest_positions[:, 0]
    samples = int(round(duration / sample_interval))
    displacements = np.empty((samples, scene.model.n_particles))
    for index in range(samples):
        displacements[index] = simulation.state.positions[0].ravel() - rest
        simulation.step(steps_per_sample)
        if progress and index % max(1, samples // 10) == 0:
            progress(f"t = {simulation.time:.4g} s")
    return np.arange(samples) * sample_interval, displacements


def sine_transform(displacements: np.ndarray) -> np.ndarray:
    """DST-I over the last axis: (n_t, N) -> (n_t, N) amplitudes of sin(p pi i / (N + 1))."""
    count = displacements.shape[-1]
    index = np.arange(1, count + 1)
    basis = np.sin(np.pi * np.outer(index, index) / (count + 1))
    return displacements @ basis


def peak_frequencies(series: np.ndarray, sample_interval: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequency (rad/s) of the spectral peak of each column of (n_t, n) ``series`` (Hann window,
    parabolic interpolation of the log power) and the (n_freq, n) power spectrum."""
    samples = series.shape[0]
    window = np.hanning(samples)[:, None]
    power = np.abs(np.fft.rfft(series * window, axis=0)) ** 2
    bin_width = 2 * np.pi / (samples * sample_interval)
    peaks = np.argmax(power[1:-1], axis=0) + 1
    columns = np.arange(series.shape[1])
    logs = np.log(power + 1e-300)
    left, centre, right = logs[peaks - 1, columns], logs[peaks, columns], logs[peaks + 1, columns]
    denominator = left - 2 * centre + right
    shift = np.where(denominator != 0, 0.5 * (left - right) / np.where(denominator == 0, 1,
                                                                          denominator), 0.0)
    return (peaks + shift) * bin_width, power


@dataclasses.dataclass(frozen=True)
class Spectrum:
    """Measured frequency of each standing wave of a chain.  ``q`` (N,) rad/m, ``measured``
    (N,) rad/s, ``power`` (n_freq, N) space-time power spectrum, ``frequencies`` (n_freq,) rad/s."""

    q: np.ndarray
    measured: np.ndarray
    frequencies: np.ndarray
    power: np.ndarray


def measure_spectrum(
    scene: sim.Scene, duration: float = 200.0, sample_interval: float = 0.1, seed: int = 1,
    progress: ProgressCallback | None = None,
) -> Spectrum:
    """Random displacements (1 % of a spacing) along the chain, recorded and transformed."""
    model = scene.model
    rng = np.random.default_rng(seed)
    positions = model.rest_positions.copy()
    positions[:, 0] += 0.01 * model.spacing * rng.standard_normal(model.n_particles)
    scene = dataclasses.replace(scene, initial_positions=positions)
    omega_max = highest_frequency(scene.model)
    steps_per_sample = max(1, math.ceil(sample_interval * omega_max / 0.1))
    _, displacements = record_displacements(scene, duration, sample_interval, steps_per_sample,
                                            progress)
    modes = sine_transform(displacements)
    measured, power = peak_frequencies(modes, sample_interval)
    count = model.n_particles
    q = np.arange(1, count + 1) * np.pi / ((count + 1) * model.spacing)
    frequencies = np.arange(power.shape[0]) * 2 * np.pi / (displacements.shape[0] * sample_interval)
    return Spectrum(q, measured, frequencies, power)


def measure_wave_speed(
    particles: int = 1200, stiffness: float = 35.0, mass: float = 1.0, width: float = 15.0,
    progress: ProgressCallback | None = None,
) -> float:
    """Speed (m/s) of a Gaussian pulse of ``width`` spacings on a chain, by front tracking."""
    scene = chain_scene(particles, stiffness, mass)
    model = scene.model
    a = model.spacing
    centre = particles // 2
    index = np.arange(particles)
    positions = model.rest_positions.copy()
    positions[:, 0] += 0.01 * a * np.exp(-0.5 * ((index - centre) / width) ** 2)
    scene = dataclasses.replace(scene, initial_positions=positions)
    speed_guess = a * math.sqrt(stiffness / mass)
    start_distance, end_distance = 5 * width, particles / 2 - 5 * width
    duration = end_distance * a / speed_guess
    sample_interval = duration / 200
    omega_max = 2 * math.sqrt(stiffness / mass)
    steps_per_sample = max(1, math.ceil(sample_interval * omega_max / 0.1))
    times, displacements = record_displacements(scene, duration, sample_interval,
                                                steps_per_sample, progress)
    right = displacements[:, centre:] ** 2
    x = (index[centre:] - centre) * a
    centroids = (right * x).sum(axis=1) / right.sum(axis=1)
    # keep the times when the right-going pulse is clear of the left-going one and of the wall
    keep = (centroids > start_distance * a) & (centroids < end_distance * a)
    slope, _ = np.polyfit(times[keep], centroids[keep], 1)
    return float(slope)


@dataclasses.dataclass(frozen=True)
class DispersionStudy:
    """Everything ``dispersion_study`` measured (SI units; q in rad/m, omega in rad/s)."""

    particles: int
    stiffness: float
    mass: float
    heavy: float
    spacing: float
    wave_speed_measured: float
    wave_speed_theory: float
    monatomic: Spectrum
    ionic: Spectrum
    gap_measured: tuple[float, float]
    gap_theory: tuple[float, float]

    def checkpoints(self, fractions=(0.25, 0.5, 0.75)) -> list[dict[str, float]]:
        """Measured against discrete-relation frequencies at a few q a / pi."""
        rows = []
        for fraction in fractions:
            p = int(round(fraction * (self.particles + 1)))
            q = self.monatomic.q[p - 1]
            theory = float(discrete_frequency(q, self.stiffness, self.mass, self.spacing))
            measured = float(self.monatomic.measured[p - 1])
            rows.append(dict(q=float(q), measured=measured, theory=theory,
                             continuum=self.wave_speed_theory * float(q),
                             relative_error=measured / theory - 1))
        return rows

    def as_dict(self) -> dict[str, Any]:
        return dict(
            particles=self.particles, stiffness=self.stiffness, mass=self.mass, heavy=self.heavy,
            wave_speed_measured=self.wave_speed_measured,
            wave_speed_theory=self.wave_speed_theory,
            wave_speed_relative_error=self.wave_speed_measured / self.wave_speed_theory - 1,
            dispersion=self.checkpoints(),
            ionic_gap_measured=list(self.gap_measured), ionic_gap_theory=list(self.gap_theory),
        )


def ionic_gap(spectrum: Spectrum) -> tuple[float, float]:
    """(lower, upper) edges (rad/s) of the widest interval free of measured frequencies."""
    frequencies = np.sort(spectrum.measured)
    widest = int(np.argmax(np.diff(frequencies)))
    return float(frequencies[widest]), float(frequencies[widest + 1])


def dispersion_study(
    particles: int = 400, stiffness: float = 35.0, mass: float = 1.0, heavy: float = 4.0,
    duration: float = 200.0, progress: ProgressCallback | None = None,
) -> DispersionStudy:
    """Wave speed, monatomic dispersion and ionic branches (see the module docstring)."""
    if progress:
        progress("wave speed: pulse on a long chain")
    speed = measure_wave_speed(max(3 * particles, 1200), stiffness, mass, progress=progress)
    if progress:
        progress("monatomic chain: space-time spectrum")
    monatomic = measure_spectrum(chain_scene(particles, stiffness, mass), duration,
                                 progress=progress)
    masses = np.where(np.arange(particles) % 2 == 0, heavy, mass).reshape(1, particles)
    if progress:
        progress("ionic chain: space-time spectrum")
    ionic = measure_spectrum(chain_scene(particles, stiffness, masses), duration,
                             progress=progress)
    spacing = 1.0
    return DispersionStudy(
        particles=particles, stiffness=stiffness, mass=mass, heavy=heavy, spacing=spacing,
        wave_speed_measured=speed, wave_speed_theory=spacing * math.sqrt(stiffness / mass),
        monatomic=monatomic, ionic=ionic, gap_measured=ionic_gap(ionic),
        gap_theory=(math.sqrt(2 * stiffness / heavy), math.sqrt(2 * stiffness / mass)),
    )


def format_report(study: DispersionStudy) -> str:
    lines = [
        f"chain of {study.particles} particles, k = {study.stiffness:g} N/m, m = {study.mass:g} kg,"
        " a = 1 m, linearised, unstressed, fixed ends",
        f"wave speed (pulse tracking): {study.wave_speed_measured:.5g} m/s; a sqrt(k/m) = "
        f"{study.wave_speed_theory:.5g} m/s "
        f"({study.wave_speed_measured / study.wave_speed_theory - 1:+.3%})",
        "",
        f"{'q a / pi':>9s} {'measured':>10s} {'discrete':>10s} {'continuum':>10s} {'error':>8s}",
    ]
    for row in study.checkpoints():
        lines.append(
            f"{row['q'] * study.spacing / math.pi:9.3f} {row['measured']:10.5g} "
            f"{row['theory']:10.5g} {row['continuum']:10.5g} {row['relative_error']:+8.3%}"
        )
    errors = study.monatomic.measured / discrete_frequency(
        study.monatomic.q, study.stiffness, study.mass) - 1
    well_resolved = study.monatomic.q * study.spacing / math.pi > 0.05
    lines += [
        f"all wavenumbers with q a / pi > 0.05: largest |error| "
        f"{np.abs(errors[well_resolved]).max():.3%}",
        "",
        f"ionic chain (M = {study.heavy:g} kg, m = {study.mass:g} kg alternating): gap measured "
        f"{study.gap_measured[0]:.4g} .. {study.gap_measured[1]:.4g} rad/s; theory sqrt(2k/M) = "
        f"{study.gap_theory[0]:.4g} .. sqrt(2k/m) = {study.gap_theory[1]:.4g} rad/s",
    ]
    return "\n".join(lines)


def plot_dispersion(study: DispersionStudy, path: str) -> None:
    """Two panels: monatomic and ionic space-time spectra with the analytic curves; PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(12, 5))
    a = study.spacing
    for axis, spectrum, title in (
        (axes[0], study.monatomic, f"monatomic chain, m = {study.mass:g} kg"),
        (axes[1], study.ionic, f"ionic chain, M = {study.heavy:g} kg / m = {study.mass:g} kg"),
    ):
        top = 1.15 * float(spectrum.measured.max())
        rows = spectrum.frequencies <= top
        normalised = spectrum.power[rows] / spectrum.power[rows].max(axis=0, keepdims=True)
        axis.imshow(
            np.log10(normalised + 1e-8), origin="lower", aspect="auto", cmap="Greys",
            extent=(0, float(spectrum.q[-1]) * a / math.pi, 0,
                    float(spectrum.frequencies[rows][-1])), vmin=-4, vmax=0,
        )
        axis.plot(spectrum.q * a / math.pi, spectrum.measured, ".", color="tab:orange",
                  markersize=3, label="measured (spectral peak)")
        axis.set_xlabel("q a / pi")
        axis.set_ylabel("omega (rad/s)")
        axis.set_title(title, fontsize=10)
        axis.set_ylim(0, top)
    q = np.linspace(0, math.pi / a, 400)
    axes[0].plot(q * a / math.pi, discrete_frequency(q, study.stiffness, study.mass, a), "b-",
                 label="2 sqrt(k/m) |sin(q a/2)|")
    axes[0].plot(q * a / math.pi, study.wave_speed_theory * q, "g--",
                 label=f"continuum c q, c = {study.wave_speed_theory:.3g} m/s")
    # a standing wave sin(q x) on the two-mass chain belongs to both branches (q and pi/a - q
    # are the same wave on the 2a unit cell): both curves are drawn over the whole range
    acoustic, optical = ionic_branches(q, study.stiffness, study.mass, study.heavy, a)
    axes[1].plot(q * a / math.pi, acoustic, "b-", linewidth=1, label="acoustic branch")
    axes[1].plot(q * a / math.pi, optical, "r-", linewidth=1, label="optical branch")
    for edge, name in zip(study.gap_theory, ("sqrt(2k/M)", "sqrt(2k/m)"), strict=True):
        axes[1].axhline(edge, color="grey", linestyle=":", linewidth=1)
        axes[1].text(0.02, edge, name, fontsize=8, va="bottom")
    for axis in axes:
        axis.legend(fontsize=8, loc="lower right")
    figure.suptitle(
        f"dispersion measured on chains of {study.particles} particles (space-time spectrum); "
        f"pulse speed {study.wave_speed_measured:.4g} m/s vs a sqrt(k/m) = "
        f"{study.wave_speed_theory:.4g} m/s", fontsize=9,
    )
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
