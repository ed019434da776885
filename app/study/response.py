"""Resonance curves: the steady amplitude of a driven lattice against the driver's frequency.

For each frequency f the scene (which must have a driver, ``sim.model.forcing.Driver``) is run from
rest with the driver's frequency replaced by f, for the driver's start and ramp plus a settle time
in which the transient dies out, then the probed particle's displacement along the driver's
direction is sampled over a few drive periods and fitted by least squares with

    u(t) = a cos(omega (t - start)) + b sin(omega (t - start)) + c,    omega = 2 pi f,

giving the amplitude sqrt(a^2 + b^2) and the phase lag behind the drive, atan2(-a, b), from -90 to
270 degrees.  At the driven particle the force's mean power is F0 omega A sin(lag) / 2: the lag
lies between 0 and 180 degrees while the drive does work, and is 0 (a spring-like load) or 180
(a mass-like one, as inside a band gap) when it does none.  The fit is repeated on each half
of the window: when the two amplitudes differ by more than 1 % the point is flagged as not
settled (a longer ``settle`` fixes it).

The theory (normal modes, settle time, modal prediction) is in ``app.study.response_modes``; the
table and the picture in ``app.study.response_report``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

import sim
from app.study.response_modes import (
    ModeLine,
    all_modes,
    damped_oscillator_amplitude,
    driver_of,
    modal_response,
    mode_lines,
    one_particle_parameters,
    settle_time,
)

ProgressCallback = Callable[[str], None]

DEFAULT_PERIODS = 4
"""Drive periods fitted at each frequency."""

SAMPLES_PER_PERIOD = 32
"""Target samples per drive period in the fit (every step when the period is shorter)."""

MIN_STEPS_PER_PERIOD = 10
"""A drive period must span at least this many time steps (else the step is too coarse)."""

DEFAULT_COUNT = 40
"""Evenly spaced frequencies of the default grid (each resolved mode adds three more)."""

SETTLED_TOLERANCE = 0.01
"""Largest relative change of the amplitude between the two halves of the fit window."""

MAX_REFINED_MODES = 40
"""The default grid adds points at each mode only when at most this many are in range."""


@dataclasses.dataclass(frozen=True)
class ResponsePoint:
    """The steady response at one drive frequency: ``amplitude`` (m), ``lag`` (degrees behind the
    drive), ``half_change`` (relative change of the amplitude between the window's halves),
    ``settle`` (s run after the ramp before the fit), ``predicted`` (m, the normal modes'
    prediction for a force driver, ``modal_response``) and ``analytic`` (m, one-particle
    lattices driven by a force only)."""

    frequency: float
    amplitude: float
    lag: float
    half_change: float
    settle: float
    predicted: float | None = None
    analytic: float | None = None

    @property
    def settled(self) -> bool:
        return self.half_change <= SETTLED_TOLERANCE

    def as_dict(self) -> dict[str, Any]:
        return dict(frequency=self.frequency, amplitude=self.amplitude, lag_degrees=self.lag,
                    settle_seconds=self.settle, half_change=self.half_change,
                    settled=self.settled, predicted=self.predicted, analytic=self.analytic)


@dataclasses.dataclass(frozen=True)
class ResponseCurve:
    """Everything ``response_curve`` measured (SI units, frequencies in Hz)."""

    scene: str
    model: sim.Model
    driver: sim.model.forcing.Driver
    probe: tuple[int, int]
    integrator: str
    dt: float
    settle: float | None
    """The settle time given (s), or None: estimated per frequency (``ResponsePoint.settle``)."""
    periods: int
    points: tuple[ResponsePoint, ...]
    modes: tuple[ModeLine, ...]

    @property
    def frequencies(self) -> np.ndarray:
        return np.array([point.frequency for point in self.points])

    @property
    def amplitudes(self) -> np.ndarray:
        return np.array([point.amplitude for point in self.points])

    def peak(self) -> ResponsePoint:
        return max(self.points, key=lambda point: point.amplitude)

    def nearest_mode(self, frequency: float) -> ModeLine | None:
        if not self.modes:
            return None
        return min(self.modes, key=lambda line: abs(line.frequency - frequency))

    def as_dict(self) -> dict[str, Any]:
        return dict(
            scene=self.scene, driver=self.driver.as_table(),
            probe=dict(column=self.probe[0], row=self.probe[1]),
            integrator=self.integrator, dt=self.dt, settle_seconds=self.settle,
            periods=self.periods, points=[point.as_dict() for point in self.points],
            modes=[dict(label=line.label, frequency=line.frequency, decay_rate=line.decay_rate,
                        polarisation=line.polarisation) for line in self.modes],
        )


# --- frequencies -------------------------------------------------------------------------------


def parse_frequencies(text: str) -> np.ndarray:
    """``"F0:F1:N"`` (N evenly spaced frequencies from F0 to F1 Hz), ``"F"`` or ``"F,F,F"``;
    ValueError with the reason otherwise."""
    text = text.strip()
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise ValueError(f"takes F0:F1:N (Hz, Hz, count), got {text!r}")
        try:
            low, high = float(parts[0]), float(parts[1])
            count = int(parts[2])
        except ValueError:
            raise ValueError(
                f"takes F0:F1:N with two numbers and a whole count, got {text!r}") from None
        if not (math.isfinite(low) and math.isfinite(high) and 0 < low < high):
            raise ValueError(f"F0:F1:N needs 0 < F0 < F1, got {text!r}")
        if not 2 <= count <= 2000:
            raise ValueError(f"F0:F1:N needs a count N from 2 to 2000, got {text!r}")
        return np.linspace(low, high, count)
    try:
        values = np.array([float(part) for part in text.split(",") if part.strip()])
    except ValueError:
        raise ValueError(
            f"takes F0:F1:N (e.g. 0.1:2:40) or frequencies separated by commas, got {text!r}"
        ) from None
    if values.size == 0 or not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError(f"frequencies must be positive numbers (Hz), got {text!r}")
    return np.unique(values)


def default_frequencies(lines: Sequence[ModeLine], count: int = DEFAULT_COUNT) -> np.ndarray:
    """``count`` evenly spaced frequencies from half the lowest mode's frequency to the highest
    plus half the lowest, and, when at most ``MAX_REFINED_MODES`` modes are in range, each
    mode's frequency and its half-power points (f +- half width), so the peaks are resolved."""
    if not lines:
        raise ValueError("no normal mode to centre the frequencies on; give --frequencies F0:F1:N")
    low = min(line.frequency for line in lines)
    high = max(line.frequency for line in lines)
    grid = list(np.linspace(0.5 * low, high + 0.5 * low, count))
    if len(lines) <= MAX_REFINED_MODES:
        for line in lines:
            grid += [line.frequency - line.half_width, line.frequency,
                     line.frequency + line.half_width]
    values = np.array(sorted(value for value in grid if value > 0))
    keep = np.concatenate([[True], np.diff(values) > 1e-9 * values[-1]])
    return values[keep]


# --- the measurement -----------------------------------------------------------------------------


def wrap_lag(degrees: np.ndarray | float) -> np.ndarray | float:
    """A lag in degrees brought into [-90, 270): a driven particle lags its force by 0 to 180
    degrees, and by exactly 180 inside a band gap, so 180 sits inside the range, not on its
    edge where round-off would flip it to -180."""
    return (np.asarray(degrees) + 90.0) % 360.0 - 90.0


def fit_oscillation(times: np.ndarray, values: np.ndarray, omega: float
                    ) -> tuple[float, float]:
    """(amplitude, lag in degrees) of the least-squares fit a cos(omega t) + b sin(omega t) + c
    = A sin(omega t - lag) + c: A = sqrt(a^2 + b^2), lag = atan2(-a, b) (``wrap_lag``)."""
    basis = np.stack([np.cos(omega * times), np.sin(omega * times), np.ones_like(times)], axis=1)
    (a, b, _), *_ = np.linalg.lstsq(basis, values, rcond=None)
    return float(math.hypot(a, b)), float(wrap_lag(math.degrees(math.atan2(-a, b))))


def measure_point(
    scene: sim.Scene, frequency: float, probe: int, settle: float,
    periods: int = DEFAULT_PERIODS, integrator: str | None = None, dt: float | None = None,
    precision: str | None = None, threads: int = 1, lines: Sequence[ModeLine] | None = None,
) -> ResponsePoint:
    """Run ``scene`` from rest with its driver at ``frequency`` (Hz) and fit the steady
    response at particle ``probe`` (see the module docstring).  ``lines``: ``all_modes(model,
    driver, probe)`` when already computed (for the prediction)."""
    driver = dataclasses.replace(driver_of(scene), frequency=float(frequency))
    model = scene.model.replace(driver=driver)
    at_rest = dataclasses.replace(scene, model=model,
                                  initial_positions=model.rest_positions.copy(),
                                  initial_velocities=np.zeros_like(model.rest_positions))
    simulation = sim.Simulation(at_rest, integrator=integrator, dt=dt, precision=precision,
                                threads=threads)
    step = simulation.dt
    simulation.step(math.ceil((driver.start + driver.ramp + settle) / step))
    period = 1.0 / frequency
    stride = max(1, int(round(period / (SAMPLES_PER_PERIOD * step))))
    samples = math.ceil(periods * period / (stride * step)) + 1
    direction = np.asarray(driver.direction[: model.dim])
    rest = simulation.rest_positions[probe]
    times = np.empty(samples)
    values = np.empty(samples)
    for index in range(samples):
        if index:
            simulation.step(stride)
        times[index] = simulation.time - driver.start
        values[index] = float((simulation.positions[probe] - rest) @ direction)
    omega = driver.angular_frequency
    amplitude, lag = fit_oscillation(times, values, omega)
    half = samples // 2
    first, _ = fit_oscillation(times[: half + 1], values[: half + 1], omega)
    second, _ = fit_oscillation(times[half:], values[half:], omega)
    change = abs(second - first) / amplitude if amplitude > 0 else 0.0
    parameters = one_particle_parameters(model, driver)
    analytic = damped_oscillator_amplitude(*parameters, omega) if parameters else None
    prediction = modal_response(model, driver, probe, [frequency], lines)
    predicted = None if prediction is None else float(abs(prediction[0]))
    return ResponsePoint(float(frequency), amplitude, lag, change, float(settle), predicted,
                         analytic)


def probe_index(model: sim.Model, probe: tuple[int, int] | None,
                driver: sim.model.forcing.Driver) -> int:
    """Particle index of (column, row), checked; the driven particle when ``probe`` is None."""
    if probe is None:
        return driver.row * model.nx + driver.column
    column, row = probe
    if not (0 <= column < model.nx and 0 <= row < model.ny):
        raise ValueError(f"--probe {column},{row}: the lattice has columns 0-{model.nx - 1} and "
                         f"rows 0-{model.ny - 1}")
    return row * model.nx + column


def check_frequencies(frequencies: Sequence[float], dt: float) -> None:
    """ValueError when a drive period spans fewer than ``MIN_STEPS_PER_PERIOD`` steps."""
    highest = max(frequencies)
    if highest * dt * MIN_STEPS_PER_PERIOD > 1:
        raise ValueError(
            f"{highest:g} Hz is too fast for dt = {dt:g} s (a period needs at least "
            f"{MIN_STEPS_PER_PERIOD} steps): lower the frequencies or use --dt "
            f"{1 / (highest * MIN_STEPS_PER_PERIOD):.3g} or less"
        )


def planned_steps(driver: sim.model.forcing.Driver, frequencies: Sequence[float],
                  settles: Sequence[float], periods: int, dt: float) -> list[int]:
    """Steps of each frequency's run (start, ramp, settle and fit window)."""
    return [math.ceil((driver.start + driver.ramp + settle + periods / frequency) / dt) + 1
            for frequency, settle in zip(frequencies, settles, strict=True)]


@dataclasses.dataclass(frozen=True)
class Plan:
    """A checked response curve: the ``probe`` index, the lattice's modes (``modes``: all of
    the driven polarisations, None when unavailable; ``shown``: those drawn), the
    ``frequencies`` (Hz) and the ``settles`` (s) of each."""

    probe: int
    modes: list[ModeLine] | None
    shown: list[ModeLine]
    frequencies: np.ndarray
    settles: list[float]


def plan(
    scene: sim.Scene, frequencies: Sequence[float] | None = None,
    probe: tuple[int, int] | None = None, settle: float | None = None,
    dt: float | None = None,
) -> Plan:
    """Everything a response curve needs before it runs, checked: ValueError with the reason
    for a scene without driver, a probe outside the lattice, frequencies too fast for the step
    or an undamped lattice."""
    model = scene.model
    driver = driver_of(scene)
    index = probe_index(model, probe, driver)
    try:
        modes: list[ModeLine] | None = all_modes(model, driver, index)
    except sim.ModelError:
        modes = None
    shown = mode_lines(model, driver, index, modes) if modes is not None else []
    chosen = np.asarray(default_frequencies(shown) if frequencies is None else frequencies,
                        dtype=float)
    check_frequencies(chosen, float(dt if dt is not None else scene.dt))
    if settle is not None:
        settles = [float(settle)] * chosen.size
    else:
        if modes is None:
            settle_time(model, driver, float(chosen[0]), index)  # raises with the reason
        settles = [settle_time(model, driver, frequency, index, lines=modes)
                   for frequency in chosen]
    return Plan(index, modes, shown, chosen, settles)


def response_curve(
    scene: sim.Scene, frequencies: Sequence[float] | None = None,
    probe: tuple[int, int] | None = None, settle: float | None = None,
    periods: int = DEFAULT_PERIODS, integrator: str | None = None, dt: float | None = None,
    precision: str | None = None, threads: int = 1, progress: ProgressCallback | None = None,
    prepared: Plan | None = None,
) -> ResponseCurve:
    """The steady response of ``scene`` at each frequency (Hz; default ``default_frequencies``)
    at the particle (column, row) ``probe`` (default the driven one) after ``settle`` seconds
    (default ``settle_time`` of each frequency), fitted over ``periods`` periods.
    ``prepared``: the ``plan`` of these same arguments when already made."""
    checked = prepared or plan(scene, frequencies, probe, settle, dt)
    index = checked.probe
    points = []
    for frequency, settle_seconds in zip(checked.frequencies, checked.settles, strict=True):
        points.append(measure_point(scene, float(frequency), index, settle_seconds, periods,
                                    integrator, dt, precision, threads, checked.modes))
        if progress:
            progress(f"f = {frequency:.4g} Hz")
    row, column = divmod(index, scene.model.nx)
    return ResponseCurve(
        scene=scene.name, model=scene.model, driver=driver_of(scene), probe=(column, row),
        integrator=integrator or scene.integrator,
        dt=float(dt if dt is not None else scene.dt), settle=settle, periods=int(periods),
        points=tuple(points), modes=tuple(checked.shown),
    )
