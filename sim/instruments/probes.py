"""Probes: the displacement of chosen particles over time, and its spectrum.

A probe samples a particle's displacement from rest (m) at the frames a run publishes;
``spectrum`` turns a sampled series into amplitudes against frequency (Hann window, resampled to
a uniform grid when the samples are not evenly spaced) and ``dominant_frequencies`` picks its
peaks, each refined by parabolic interpolation of the log amplitude between FFT bins (the
resolution is 1/T Hz for a series T seconds long; the refinement does better for clean peaks).
``nearest_modes`` names the lattice's normal-mode frequencies closest to a peak, for equal
masses.  Observables as functions: nothing here steps a simulation.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sim.model.lattice import Model
from sim.theory.modes import (
    POLARISATION_NAMES,
    mode_frequency,
    polarisations,
    second_difference_eigenvalues,
)


def uniform_series(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float]:
    """(values on a uniform time grid, its interval (s)): linear interpolation onto as many
    evenly spaced times as there are samples (returned unchanged if already even)."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    if times.size < 2:
        raise ValueError("a spectrum needs at least two samples")
    steps = np.diff(times)
    interval = float((times[-1] - times[0]) / (times.size - 1))
    if interval <= 0:
        raise ValueError("the samples must span a positive time")
    if np.allclose(steps, interval, rtol=1e-6, atol=0.0):
        return values, interval
    grid = times[0] + interval * np.arange(times.size)
    return np.interp(grid, times, values), interval


def spectrum(values: np.ndarray, interval: float) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies in Hz, amplitudes in the unit of ``values``) of an evenly sampled series:
    mean removed, Hann window, one-sided FFT scaled so that a sine of amplitude A reads A."""
    values = np.asarray(values, dtype=float)
    values = values - values.mean()
    window = np.hanning(values.size)
    amplitudes = np.abs(np.fft.rfft(values * window)) * 2.0 / window.sum()
    frequencies = np.fft.rfftfreq(values.size, interval)
    return frequencies, amplitudes


def dominant_frequencies(values: np.ndarray, interval: float, count: int = 3,
                         floor: float = 1e-3) -> list[tuple[float, float]]:
    """Up to ``count`` peaks (frequency Hz, amplitude), largest first: local maxima of the
    spectrum above ``floor`` times the largest, each refined between bins."""
    frequencies, amplitudes = spectrum(values, interval)
    if amplitudes.size < 3 or amplitudes.max() <= 0:
        return []
    top = amplitudes.max()
    peaks = [
        index for index in range(1, amplitudes.size - 1)
        if amplitudes[index] >= amplitudes[index - 1] and amplitudes[index] > amplitudes[index + 1]
        and amplitudes[index] >= floor * top
    ]
    peaks.sort(key=lambda index: amplitudes[index], reverse=True)
    resolution = frequencies[1] - frequencies[0]
    found = []
    for index in peaks[:count]:
        left, centre, right = np.log(amplitudes[index - 1 : index + 2] + 1e-300)
        curvature = left - 2 * centre + right
        shift = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
        found.append((float(frequencies[index] + shift * resolution), float(amplitudes[index])))
    return found


@dataclasses.dataclass(frozen=True)
class ModeMatch:
    """A normal mode near a measured frequency: (m, n), polarisation name, frequency (Hz)."""

    m: int
    n: int
    polarisation: str
    frequency: float

    def describe(self) -> str:
        return f"mode ({self.m}, {self.n}) {self.polarisation} at {self.frequency:.4g} Hz"


def mode_table(model: Model) -> list[ModeMatch]:
    """Every normal mode of an equal-mass lattice with its frequency (Hz), lowest first."""
    modes = [
        ModeMatch(m, n, POLARISATION_NAMES[c], mode_frequency(model, m, n, c) / (2 * np.pi))
        for c in range(model.dim) for n in range(1, model.ny + 1) for m in range(1, model.nx + 1)
    ]
    return sorted(modes, key=lambda mode: mode.frequency)


def nearest_modes(model: Model, frequency: float, count: int = 1) -> list[ModeMatch]:
    """The ``count`` normal modes whose frequencies are closest to ``frequency`` (Hz); none for
    unequal masses, rings or free ends (their modes are not the sine modes (m, n): see
    ``sim.theory.modes.ModalBasis``).  Vectorised: quick on the largest lattices."""
    if not model.uniform_mass or model.row_ends != "walls":
        return []
    mass = float(np.asarray(model.masses).mean())
    columns = second_difference_eigenvalues(model.nx)[None, :]
    rows = second_difference_eigenvalues(model.ny)[:, None]
    candidates: list[ModeMatch] = []
    for component, (k_columns, k_rows, _, _) in enumerate(polarisations(model)):
        frequencies = np.sqrt(np.maximum((k_columns * columns + k_rows * rows) / mass, 0.0))
        frequencies = (frequencies / (2 * np.pi)).ravel()
        nearest = np.argsort(np.abs(frequencies - frequency), kind="stable")[:count]
        for index in nearest:
            row, column = divmod(int(index), model.nx)
            candidates.append(ModeMatch(column + 1, row + 1, POLARISATION_NAMES[component],
                                        float(frequencies[index])))
    return sorted(candidates, key=lambda mode: abs(mode.frequency - frequency))[:count]


class ProbeSeries:
    """Displacements (m) of chosen particles, sampled at the frames of a run.

    ``add(time, positions)`` with the (n_particles, dim) positions of a frame; ``times`` (k,)
    and ``displacements`` (k, probes, dim) give the series back."""

    def __init__(self, model: Model, particles: list[int], limit: int = 1 << 16) -> None:
        if not particles:
            raise ValueError("probe at least one particle")
        bad = [p for p in particles if not 0 <= int(p) < model.n_particles]
        if bad:
            raise ValueError(f"particle index {bad[0]} is outside the lattice "
                             f"(0 to {model.n_particles - 1})")
        self.model = model
        self.particles = [int(p) for p in particles]
        self.rest = model.rest_positions[self.particles]
        self.limit = int(limit)
        self._times: list[float] = []
        self._values: list[np.ndarray] = []

    def add(self, time: float, positions: np.ndarray) -> None:
        if self._times and time <= self._times[-1]:
            if time < self._times[-1]:  # the run was reset: start again
                self.clear()
            else:
                return
        self._times.append(float(time))
        self._values.append(np.asarray(positions)[self.particles] - self.rest)
        if len(self._times) > self.limit:
            del self._times[: len(self._times) - self.limit]
            del self._values[: len(self._values) - self.limit]

    def clear(self) -> None:
        self._times.clear()
        self._values.clear()

    @property
    def times(self) -> np.ndarray:
        return np.asarray(self._times)

    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """(times, displacements) of the same length, while the run may be adding a sample
        (a sample's time is stored before its displacements)."""
        times = self.times
        displacements = self.displacements
        count = min(times.size, displacements.shape[0])
        return times[:count], displacements[:count]

    @property
    def last_time(self) -> float | None:
        """The latest sample's time (s), None before the first; cheap (no array is made)."""
        try:
            return self._times[-1]
        except IndexError:
            return None

    @property
    def displacements(self) -> np.ndarray:
        if not self._values:
            return np.zeros((0, len(self.particles), self.model.dim))
        return np.stack(self._values)

    def dominant(self, probe: int, component: int, count: int = 3) -> list[tuple[float, float]]:
        """Peaks (Hz, m) of one probe's displacement component (see ``dominant_frequencies``)."""
        values, interval = uniform_series(self.times, self.displacements[:, probe, component])
        return dominant_frequencies(values, interval, count)
