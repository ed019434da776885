"""Resonance curves: the steady amplitude of a driven lattice against the driver's frequency.

For each frequency f the scene (which must have a driver, ``sim.forcing.Driver``) is run from
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

Settle time (``settle_time``, per frequency): about the lattice at rest every normal mode j
obeys q'' + beta_j q' + omega_j^2 q = (its shape at the driver) F(t), and its free transient
decays as exp(-r_j t), r_j = beta_j / 2 (the slow root when overdamped).  beta_j is the mode's
drag and dashpot rate (``sim.modes.ModalBasis``) plus, with absorbing walls, the sponge's rate
averaged over the mode's shape (a Rayleigh quotient, good while the damping is weak).  The
transient a smooth ramp of T seconds leaves in mode j, relative to the steady amplitude at the
probe, is estimated as g(|omega_j - omega| T) |c_j / D_j| / |sum_k c_k / D_k|, with
D_j = omega_j^2 - omega^2 + i beta_j omega, c_j the mode's shape at the driver times its shape at
the probe, and g(x) = |cos(x / 2)| / |1 - (x / pi)^2| the spectrum of the ramp's rate (1 at
x = 0; 1 for every mode without a ramp).  The settle time brings their sum down to 1/1000 of
the steady amplitude: sum_j transient_j exp(-r_j t) = 1/1000 (a bound: on a large lattice many
small transients add up).  Modes far from the drive frequency are excited little by a smooth
ramp and need less time; undamped modes the driver excites never settle: they are refused with a
message.  With a displacement driver (the lattice
is then held at the driven particle) the slowest excited mode sets the time alone.

The normal modes (``mode_lines``) are drawn as vertical lines on the curve, labelled: equal
masses give the sine modes (m, n) of ``sim.modes`` (``n=m`` on a chain), unequal masses the
eigenmodes numbered in rising frequency.  Only modes the driver excites and the probe can see (no
node at either particle) are drawn.  With a displacement driver the driven particle is held to
the prescribed motion, so the resonances are those of the lattice with that particle held, near
but not on the lines drawn.

For a force driver the normal modes also predict the steady response of the linearised lattice
(``modal_response``): u = F0 sum_j c_j / (sqrt(m_d m_p) (omega_j^2 - omega^2 + i beta_j omega)),
exact for equal masses with drag and dashpots, or unequal masses without damping; it is not
given with absorbing walls, whose damping is far from diagonal in the modes.  It is drawn as a
curve under the measured points and listed in the table; for one particle it is the analytic
amplitude F0 / (m sqrt((omega_0^2 - omega^2)^2 + (beta omega)^2)), F0 = A k
(``damped_oscillator_amplitude``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

import sim
from sim.forcing import sponge_rates
from sim.modes import POLARISATION_NAMES, ModalBasis

ProgressCallback = Callable[[str], None]

SETTLE_FACTOR = 1000.0
"""The default settle time brings the estimated transient down to 1/SETTLE_FACTOR of the steady
amplitude."""

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

NO_DRIVER_MESSAGE = (
    "scene {name!r} has no driver, so there is nothing to respond to: add one with "
    "--set driver=column=0,row=0,direction=x,amplitude=0.02,kind=force (its frequency is "
    "replaced by each of --frequencies), or choose a scene with one (resonance, bandgap)"
)


@dataclasses.dataclass(frozen=True)
class ModeLine:
    """A normal mode of a driven polarisation: ``label``, ``frequency`` (Hz), amplitude
    ``decay_rate`` of its free transient (1/s), ``polarisation`` ("x", "y", "z"), its damping
    rate ``beta`` (1/s) and its mass-weighted shape at the driven particle (``at_driver``) and
    at the probe (``at_probe``): the driver cannot excite it when the first is 0, the probe
    cannot see it when the second is."""

    label: str
    frequency: float
    decay_rate: float
    polarisation: str
    at_driver: float
    at_probe: float
    beta: float = 0.0
    """Damping rate (1/s) of q'' + beta q' + omega^2 q = 0 (drag, dashpots, sponge)."""

    @property
    def half_width(self) -> float:
        """Half-width (Hz) of its resonance peak at half power: decay rate / (2 pi)."""
        return self.decay_rate / (2 * math.pi)


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
    driver: sim.forcing.Driver
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


# --- the driver, the modes and the settle time ---------------------------------------------------


def driver_of(scene: sim.Scene) -> sim.forcing.Driver:
    """The scene's driver; ValueError saying how to add one when it has none."""
    driver = scene.model.driver
    if driver is None:
        raise ValueError(NO_DRIVER_MESSAGE.format(name=scene.name))
    return driver


def driven_components(model: sim.Model, driver: sim.forcing.Driver) -> list[int]:
    """The displacement components (0 x, 1 y, 2 z) along which the driver pushes."""
    return [component for component in range(model.dim)
            if abs(driver.direction[component]) > 1e-12]


def _transient_decay(beta: np.ndarray, omega_squared: np.ndarray) -> np.ndarray:
    """Amplitude decay rate (1/s) of q'' + beta q' + omega^2 q = 0: beta / 2, or the slow root
    beta / 2 - sqrt(beta^2 / 4 - omega^2) when overdamped.  A mode without stiffness (a ring or
    a free chain sliding as a whole) drifts to a standstill at the rate beta: its offset is
    the fit's constant c, so only its motion has to die out."""
    beta = np.asarray(beta, dtype=float)
    omega_squared = np.maximum(np.asarray(omega_squared, dtype=float), 0.0)
    excess = np.maximum(beta**2 / 4 - omega_squared, 0.0)
    floating = omega_squared <= 1e-12 * max(float(omega_squared.max(initial=0.0)), 1e-300)
    return np.where(floating, beta, beta / 2 - np.sqrt(excess))


def _chain_label(model: sim.Model, m: int, n: int) -> str:
    if model.n_particles == 1:
        return "omega_0"
    if model.ny == 1:
        return f"n={m}"
    if model.nx == 1:
        return f"n={n}"
    return f"({m},{n})"


def all_modes(model: sim.Model, driver: sim.forcing.Driver, probe: int) -> list[ModeLine]:
    """Every normal mode of the driven polarisations with its transient decay rate (drag,
    dashpots and the sponge's Rayleigh quotient) and its shape at the driver and the probe.
    Raises ``sim.ModelError`` for unequal-mass lattices too large for the dense eigen-solver."""
    basis = ModalBasis.of(model)
    nx, ny = model.nx, model.ny
    sponge = sponge_rates(model) if model.boundary == "absorbing" else np.zeros((ny, nx))
    driver_index = driver.row * nx + driver.column
    probe_row, probe_column = divmod(probe, nx)
    components = driven_components(model, driver)
    several = len(components) > 1
    lines = []
    for component in components:
        name = POLARISATION_NAMES[component]
        omega_squared = np.asarray(basis.omega_squared[component], dtype=float)
        if basis.separable:
            columns, rows = np.arange(1, nx + 1), np.arange(1, ny + 1)
            shape_x = np.sqrt(2 / (nx + 1)) * np.sin(np.pi * np.outer(columns, columns) / (nx + 1))
            shape_y = np.sqrt(2 / (ny + 1)) * np.sin(np.pi * np.outer(rows, rows) / (ny + 1))
            # entries [n-1, m-1]: rows are the y mode numbers, columns the x ones (ModalBasis)
            beta = basis.damping_rate[component] + (shape_y**2).T @ sponge @ (shape_x**2)
            decay = _transient_decay(beta, omega_squared)
            at_driver = np.outer(shape_y[driver.row], shape_x[driver.column])
            at_probe = np.outer(shape_y[probe_row], shape_x[probe_column])
            labels = [[_chain_label(model, m, n) for m in range(1, nx + 1)]
                      for n in range(1, ny + 1)]
            entries = [(labels[n][m], omega_squared[n, m], decay[n, m], at_driver[n, m],
                        at_probe[n, m], beta[n, m]) for n in range(ny) for m in range(nx)]
        else:
            assert basis.vectors is not None
            vectors = basis.vectors[component]
            beta = basis.damping_rate[component] + (sponge.ravel()[:, None] * vectors**2).sum(0)
            decay = _transient_decay(beta, omega_squared)
            entries = [(f"#{index + 1}", omega_squared[index], decay[index],
                        vectors[driver_index, index], vectors[probe, index], beta[index])
                       for index in range(vectors.shape[1])]
        for label, omega_2, rate, driver_shape, probe_shape, damping in entries:
            lines.append(ModeLine(
                f"{name} {label}" if several else label,
                math.sqrt(max(float(omega_2), 0.0)) / (2 * math.pi), float(rate), name,
                float(driver_shape), float(probe_shape), float(damping),
            ))
    return lines


def _not_at_a_node(values: Sequence[float]) -> np.ndarray:
    """Which shape values are not zero (relative to the largest: nodes are round-off)."""
    magnitudes = np.abs(np.asarray(values, dtype=float))
    if magnitudes.size == 0 or magnitudes.max() == 0:
        return np.zeros(magnitudes.shape, dtype=bool)
    return magnitudes > 1e-9 * magnitudes.max()


def mode_lines(model: sim.Model, driver: sim.forcing.Driver, probe: int,
               lines: Sequence[ModeLine] | None = None) -> list[ModeLine]:
    """The normal modes that can show in the response at ``probe``: no node at the driven
    particle nor at the probe, lowest frequency first (zero-frequency modes left out).
    ``lines``: ``all_modes(model, driver, probe)`` when already computed."""
    lines = all_modes(model, driver, probe) if lines is None else lines
    keep = (_not_at_a_node([line.at_driver for line in lines])
            & _not_at_a_node([line.at_probe for line in lines]))
    shown = [line for line, kept in zip(lines, keep, strict=True) if kept and line.frequency > 0]
    return sorted(shown, key=lambda line: line.frequency)


def ramp_spectrum(detuning: np.ndarray, ramp: float) -> np.ndarray:
    """g(x) = |cos(x / 2)| / |1 - (x / pi)^2|, x = detuning (rad/s) * ramp (s): the transient a
    (1 - cos) / 2 ramp leaves in a mode detuned from the drive, relative to an abrupt start."""
    x = np.abs(np.asarray(detuning, dtype=float)) * ramp
    near_pole = np.abs(x - np.pi) < 1e-6
    safe = np.where(near_pole, np.pi + 1e-3, x)
    return np.where(near_pole, np.pi / 4, np.abs(np.cos(safe / 2) / (1 - (safe / np.pi) ** 2)))


def _undamped_message(line: ModeLine) -> str:
    return (
        f"mode {line.label} ({line.frequency:.4g} Hz) is undamped, so the transient the driver "
        "starts in it never dies out and there is no steady amplitude to measure: add drag "
        "(--set drag=0.1) or absorbing walls (--set boundary=absorbing), or give --settle "
        "SECONDS to measure anyway"
    )


def modal_response(model: sim.Model, driver: sim.forcing.Driver, probe: int,
                   frequencies: Sequence[float] | np.ndarray,
                   lines: Sequence[ModeLine] | None = None) -> np.ndarray | None:
    """Complex steady amplitude (m) of the probe's displacement along the drive predicted by the
    normal modes of the linearised lattice, at each frequency (Hz): the displacement is
    Im(amplitude exp(i omega (t - start))), so its size is |amplitude| and its lag behind the
    drive -arg(amplitude).  None for a displacement driver, with absorbing walls (the sponge's
    damping is far from diagonal in the modes: the sum misses by tens of per cent, measured on
    the bandgap preset) or when the modes are unavailable.  ``lines``: ``all_modes(model,
    driver, probe)`` when already computed."""
    if driver.kind != "force" or model.boundary == "absorbing":
        return None
    if lines is None:
        try:
            lines = all_modes(model, driver, probe)
        except sim.ModelError:
            return None
    masses = np.asarray(model.masses, dtype=float).ravel()
    driver_index = driver.row * model.nx + driver.column
    force = driver.amplitude * model.stiffness / math.sqrt(masses[driver_index] * masses[probe])
    along = np.array([driver.direction[POLARISATION_NAMES.index(line.polarisation)] ** 2
                      for line in lines])
    coupling = np.array([line.at_driver * line.at_probe for line in lines]) * along
    omega_j = np.array([2 * math.pi * line.frequency for line in lines])
    beta = np.array([line.beta for line in lines])
    omega = 2 * math.pi * np.asarray(frequencies, dtype=float)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = coupling / (omega_j**2 - omega**2 + 1j * beta * omega)
    return force * np.where(coupling == 0, 0.0, terms).sum(axis=1)


def settle_time(model: sim.Model, driver: sim.forcing.Driver, frequency: float,
                probe: int | None = None, factor: float = SETTLE_FACTOR,
                lines: Sequence[ModeLine] | None = None) -> float:
    """Seconds after the ramp for the transient the driver at ``frequency`` (Hz) starts to fall
    to 1/``factor`` of the steady amplitude at ``probe`` (see the module docstring): the time
    at which the sum of the modes' estimated transients, each decaying at its own rate, is
    1/``factor`` (a bound: they may partly cancel).  ``lines``: ``all_modes(model, driver,
    probe)`` when already computed.  ValueError when undamped modes would keep it from
    settling."""
    driver_index = driver.row * model.nx + driver.column
    probe = driver_index if probe is None else probe
    if lines is None:
        try:
            lines = all_modes(model, driver, probe)
        except sim.ModelError as error:
            raise ValueError(f"{error}; give the settle time with --settle SECONDS") from None
    excited = [line for line, kept in zip(
        lines, _not_at_a_node([line.at_driver for line in lines]), strict=True) if kept]
    if not excited:
        return 0.0
    decay = np.array([line.decay_rate for line in excited])
    undamped = decay <= 1e-12
    if driver.kind != "force":  # the lattice is held at the driver: the slowest mode decides
        if undamped.any():
            raise ValueError(_undamped_message(excited[int(np.argmax(undamped))]))
        return math.log(factor) / float(decay.min())
    omega = 2 * math.pi * frequency
    omega_j = np.array([2 * math.pi * line.frequency for line in excited])
    coupling = np.array([line.at_driver * line.at_probe for line in excited])
    beta = np.array([line.beta for line in excited])
    response = coupling / (omega_j**2 - omega**2 + 1j * beta * omega)
    steady = abs(response.sum())
    if steady == 0.0 or not np.isfinite(steady):
        raise ValueError("the probe does not move at this frequency (a node of every mode the "
                         "driver excites, or an undamped resonance); give --settle SECONDS")
    ramp = ramp_spectrum(omega_j - omega, driver.ramp) if driver.ramp > 0 else 1.0
    transient = ramp * np.abs(response) / steady
    target = 1.0 / factor
    if transient[undamped].sum() >= target:
        lasting = np.where(undamped, transient, 0.0)
        raise ValueError(_undamped_message(excited[int(np.argmax(lasting))]))
    damped = ~undamped
    transient, decay = transient[damped], decay[damped]
    if transient.sum() <= target:
        return 0.0
    low, high = 0.0, float(np.max(np.log(transient * factor * transient.size) / decay))
    for _ in range(60):  # bisection on the decreasing sum of exponentials
        middle = 0.5 * (low + high)
        if (transient * np.exp(-decay * middle)).sum() > target:
            low = middle
        else:
            high = middle
    return high


def one_particle_parameters(model: sim.Model, driver: sim.forcing.Driver
                            ) -> tuple[float, float, float] | None:
    """(F0 / m in N/kg, omega_0 in rad/s, beta in 1/s) of a one-particle lattice driven by a
    force along one axis, for ``damped_oscillator_amplitude``; None for anything else."""
    components = driven_components(model, driver)
    if model.n_particles != 1 or driver.kind != "force" or len(components) != 1:
        return None
    basis = ModalBasis.of(model)
    component = components[0]
    omega_0 = math.sqrt(max(float(np.ravel(basis.omega_squared[component])[0]), 0.0))
    beta = float(np.ravel(basis.damping_rate[component])[0])
    mass = float(model.masses.flat[0])
    return driver.amplitude * model.stiffness / mass, omega_0, beta


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


def damped_oscillator_amplitude(force_per_mass: float, omega_0: float, beta: float,
                                omega: float) -> float:
    """Steady amplitude (m) of x'' + beta x' + omega_0^2 x = (F0 / m) sin(omega t):
    F0 / (m sqrt((omega_0^2 - omega^2)^2 + (beta omega)^2))."""
    return force_per_mass / math.sqrt((omega_0**2 - omega**2) ** 2 + (beta * omega) ** 2)


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
                driver: sim.forcing.Driver) -> int:
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


def planned_steps(driver: sim.forcing.Driver, frequencies: Sequence[float],
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


# --- report and picture --------------------------------------------------------------------------


def format_report(curve: ResponseCurve) -> str:
    """The table of frequency, amplitude and lag (and the analytic amplitude for one particle),
    the peak and the modes in range."""
    driver = curve.driver
    lines = [
        f"{curve.scene}: {driver.describe()} (frequency replaced by each below); probe particle "
        f"(column {curve.probe[0]}, row {curve.probe[1]}), displacement along the drive",
        f"{curve.integrator}, dt = {curve.dt:g} s; each run from rest: start {driver.start:g} s "
        f"+ ramp {driver.ramp:g} s + settle ("
        + ("estimated per frequency from the damping" if curve.settle is None
           else f"{curve.settle:g} s") + f"), then a fit over {curve.periods} periods",
        "",
    ]
    with_analytic = any(point.analytic is not None for point in curve.points)
    with_prediction = not with_analytic and any(point.predicted for point in curve.points)
    header = f"{'f (Hz)':>9s} {'amplitude (m)':>14s} {'lag (deg)':>9s} {'settle (s)':>10s}"
    if with_analytic:
        header += f" {'analytic (m)':>13s} {'error':>8s}"
    if with_prediction:
        header += f" {'modes (m)':>11s} {'error':>8s}"
    lines.append(header + "  nearest mode")
    for point in curve.points:
        row = (f"{point.frequency:9.4f} {point.amplitude:14.4e} {point.lag:9.1f} "
               f"{point.settle:10.4g}")
        if with_analytic and point.analytic is not None:
            row += f" {point.analytic:13.4e} {point.amplitude / point.analytic - 1:+8.2%}"
        if with_prediction and point.predicted:
            row += f" {point.predicted:11.4e} {point.amplitude / point.predicted - 1:+8.2%}"
        near = curve.nearest_mode(point.frequency)
        if near is not None:
            row += f"  {near.label} ({near.frequency:.4f} Hz)"
        if not point.settled:
            row += f"  not settled ({point.half_change:.1%} between halves)"
        lines.append(row)
    peak = curve.peak()
    near = curve.nearest_mode(peak.frequency)
    lines += ["", f"largest response {peak.amplitude:.4g} m at {peak.frequency:.4f} Hz"
              + (f", next to mode {near.label} at {near.frequency:.4f} Hz" if near else "")]
    unsettled = sum(not point.settled for point in curve.points)
    if unsettled:
        lines.append(f"{unsettled} point(s) not settled: give a longer --settle SECONDS")
    if with_prediction:
        lines.append(_prediction_caption(curve.model) + " in the column 'modes'")
    if driver.kind == "displacement":
        lines.append("displacement driver: the resonances are those of the lattice with the "
                     "driven particle held, near the free lattice's modes listed")
        if (driver.column, driver.row) == curve.probe:
            lines.append("the probe is the driven particle, which follows the prescribed "
                         "motion: probe another one with --probe I,J")
    return "\n".join(lines)


def _prediction_caption(model: sim.Model) -> str:
    what = "normal-mode prediction"
    notes = []
    if not model.linear:
        notes.append("linearised springs")
    return what + (f" ({'; '.join(notes)})" if notes else "")


def _same_frequency(lines: Sequence[ModeLine]) -> list[tuple[float, list[str]]]:
    """(frequency, labels) of the lines, degenerate modes (equal frequencies to 1e-9) merged."""
    groups: list[tuple[float, list[str]]] = []
    for line in sorted(lines, key=lambda line: line.frequency):
        if groups and abs(line.frequency - groups[-1][0]) <= 1e-9 * max(line.frequency, 1e-300):
            groups[-1][1].append(line.label)
        else:
            groups.append((line.frequency, [line.label]))
    return groups


def plot_response(curve: ResponseCurve, path: str) -> None:
    """Amplitude (log scale) and lag against frequency, measured points on the normal modes'
    prediction (force drivers), the modes as labelled vertical lines; PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (axis, lag_axis) = plt.subplots(
        2, 1, figsize=(10, 6.4), sharex=True, gridspec_kw=dict(height_ratios=(3, 1)))
    frequencies = curve.frequencies
    low, high = float(frequencies.min()), float(frequencies.max())
    margin = 0.02 * (high - low or high)
    shown = [line for line in curve.modes if low - margin <= line.frequency <= high + margin]
    groups = _same_frequency(shown)
    for index, (frequency, labels) in enumerate(groups):
        for target in (axis, lag_axis):
            target.axvline(frequency, color="tab:grey", linewidth=0.8, alpha=0.6,
                           linestyle="--", label="normal modes" if index == 0 and
                           target is axis else None)
        if len(groups) <= 30:
            text = " / ".join(labels[:2]) + (" ..." if len(labels) > 2 else "")
            axis.text(frequency, 1.01, text, rotation=90, fontsize=7,
                      ha="center", va="bottom", transform=axis.get_xaxis_transform())
    probe = curve.probe[1] * curve.model.nx + curve.probe[0]
    dense = np.unique(np.concatenate([np.linspace(low, high, 3000),
                                      [line.frequency for line in shown]]))
    prediction = modal_response(curve.model, curve.driver, probe, dense)
    if prediction is not None:
        label = (_prediction_caption(curve.model) if curve.model.n_particles > 1 else
                 "analytic F0 / (m sqrt((w0^2 - w^2)^2 + (beta w)^2))")
        axis.plot(dense, np.abs(prediction), "-", color="black", linewidth=0.8, alpha=0.7,
                  label=label)
        lag_axis.plot(dense, wrap_lag(-np.degrees(np.angle(prediction))), "-", color="black",
                      linewidth=0.6, alpha=0.6)
    else:
        axis.plot(frequencies, curve.amplitudes, "-", color="tab:blue", linewidth=1.0)
    settled = np.array([point.settled for point in curve.points])
    axis.plot(frequencies[settled], curve.amplitudes[settled], "o", color="tab:blue",
              markersize=3.5, label="measured (steady amplitude)")
    if not settled.all():
        axis.plot(frequencies[~settled], curve.amplitudes[~settled], "x", color="tab:red",
                  label="not settled")
    axis.set_yscale("log")
    axis.set_ylabel("steady amplitude (m)")
    axis.legend(fontsize=8, loc="lower left")
    axis.grid(True, which="major", alpha=0.25)
    lag_axis.plot(frequencies, np.array([point.lag for point in curve.points]), "o",
                  color="tab:blue", markersize=2.5)
    lag_axis.set_ylabel("lag (deg)")
    lag_axis.set_yticks([-90, 0, 90, 180, 270])
    lag_axis.set_ylim(-100, 280)
    lag_axis.set_xlabel("drive frequency (Hz)")
    lag_axis.grid(True, alpha=0.25)
    driver = curve.driver
    figure.suptitle(
        f"response of {curve.scene}{' (linearised springs)' if curve.model.linear else ''}: "
        f"{driver.kind} drive A = {driver.amplitude:g} m at (column "
        f"{driver.column}, row {driver.row}), probe (column {curve.probe[0]}, row "
        f"{curve.probe[1]}); {curve.integrator} dt = {curve.dt:g} s",
        fontsize=9,
    )
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
