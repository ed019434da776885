"""The normal modes a driven lattice responds with: which ones show, how long their transients
last, and the steady response they predict (the theory behind ``app.study.response``).

Settle time (``settle_time``, per frequency): about the lattice at rest every normal mode j
obeys q'' + beta_j q' + omega_j^2 q = (its shape at the driver) F(t), and its free transient
decays as exp(-r_j t), r_j = beta_j / 2 (the slow root when overdamped).  beta_j is the mode's
drag and dashpot rate (``sim.theory.modes.ModalBasis``) plus, with absorbing walls, the sponge's rate
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
masses give the sine modes (m, n) of ``sim.theory.modes`` (``n=m`` on a chain), unequal masses the
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
from collections.abc import Sequence

import numpy as np

import sim
from sim.model.forcing import sponge_rates
from sim.theory.modes import POLARISATION_NAMES, ModalBasis

SETTLE_FACTOR = 1000.0
"""The default settle time brings the estimated transient down to 1/SETTLE_FACTOR of the steady
amplitude."""

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


def driver_of(scene: sim.Scene) -> sim.model.forcing.Driver:
    """The scene's driver; ValueError saying how to add one when it has none."""
    driver = scene.model.driver
    if driver is None:
        raise ValueError(NO_DRIVER_MESSAGE.format(name=scene.name))
    return driver


def driven_components(model: sim.Model, driver: sim.model.forcing.Driver) -> list[int]:
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


def all_modes(model: sim.Model, driver: sim.model.forcing.Driver, probe: int) -> list[ModeLine]:
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


def mode_lines(model: sim.Model, driver: sim.model.forcing.Driver, probe: int,
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


def modal_response(model: sim.Model, driver: sim.model.forcing.Driver, probe: int,
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


def settle_time(model: sim.Model, driver: sim.model.forcing.Driver, frequency: float,
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


def one_particle_parameters(model: sim.Model, driver: sim.model.forcing.Driver
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


def damped_oscillator_amplitude(force_per_mass: float, omega_0: float, beta: float,
                                omega: float) -> float:
    """Steady amplitude (m) of x'' + beta x' + omega_0^2 x = (F0 / m) sin(omega t):
    F0 / (m sqrt((omega_0^2 - omega^2)^2 + (beta omega)^2))."""
    return force_per_mass / math.sqrt((omega_0**2 - omega**2) ** 2 + (beta * omega) ** 2)

