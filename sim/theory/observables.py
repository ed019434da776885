"""Observables: functions of a model and a state (energies, spring strains, normal modes, stability).

Nothing here advances time.  Conventions:

* energies are in joules and measured from the rest lattice: the spring energy is the stored
  energy minus that of the (possibly pre-tensioned) rest lattice, the gravitational energy is
  -sum m g . (r - r_rest); so an undisturbed lattice has zero potential energy;
* the strain of a spring is (length - L) / L, positive when stretched; in the linearised model the
  length is a + (along-spring displacement difference);
* the stability limit comes from the normal modes of the linearised lattice about its rest state
  (the highest natural frequency, computed, not guessed) and each integrator's amplification matrix.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.forces import registry
from sim.model.lattice import Model, read_only
from sim.model.state import State
from sim.theory import small_matrices
from sim.theory.lattice_waves import diagonal_mode_sample
from sim.theory.modes import polarisations, second_difference_eigenvalues, stiffness_matrix


@dataclasses.dataclass(frozen=True)
class Energy:
    """Energy account of a state (J).  ``total = kinetic + potential``; ``balance`` adds what the
    dampers took out and subtracts what a driver put in, and is conserved by the exact dynamics."""

    kinetic: float
    spring: float
    gravity: float
    dissipated: float
    driven: float = 0.0

    @property
    def potential(self) -> float:
        return self.spring + self.gravity

    @property
    def total(self) -> float:
        return self.kinetic + self.potential

    @property
    def balance(self) -> float:
        return self.total + self.dissipated - self.driven

    def as_dict(self) -> dict[str, float]:
        return dict(
            kinetic=self.kinetic, spring=self.spring, gravity=self.gravity,
            potential=self.potential, dissipated=self.dissipated, driven=self.driven,
            total=self.total,
        )

    def __getitem__(self, key: str) -> float:
        return self.as_dict()[key]


def _padded_displacements(model: Model, positions: np.ndarray) -> np.ndarray:
    """(dim, ny + 2, nx + 2) displacements from rest with the fixed wall ring (zeros) around them;
    for a periodic model the left and right pads are the last and first columns (the ring)."""
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)
    padded = np.zeros((model.dim, model.ny + 2, model.nx + 2))
    padded[:, 1:-1, 1:-1] = positions - rest
    if model.periodic:
        padded[:, 1:-1, 0] = padded[:, 1:-1, -2]
        padded[:, 1:-1, -1] = padded[:, 1:-1, 1]
    elif model.row_ends == "free":  # no wall spring: listed at rest length-a stretch, not counted
        padded[:, 1:-1, 0] = padded[:, 1:-1, 1]
        padded[:, 1:-1, -1] = padded[:, 1:-1, -2]
    return padded


def spring_differences(model: Model, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Displacement differences across every spring (second end minus first end), (dim, ...):
    horizontal springs (dim, ny, nx + 1) and vertical springs (dim, ny + 1, nx)."""
    padded = _padded_displacements(model, positions)
    horizontal = padded[:, 1:-1, 1:] - padded[:, 1:-1, :-1]
    vertical = padded[:, 1:, 1:-1] - padded[:, :-1, 1:-1]
    return horizontal, vertical


def spring_lengths(model: Model, positions: np.ndarray) -> np.ndarray:
    """(n_springs,) current spring lengths (m) in ``Model.springs`` order; in the linearised model,
    the linearised length a + along-spring stretch."""
    horizontal, vertical = spring_differences(model, positions)
    a = model.spacing
    if model.linear:
        return np.concatenate([(a + horizontal[0]).ravel(), (a + vertical[1]).ravel()])
    horizontal[0] += a
    vertical[1] += a
    return np.concatenate(
        [np.sqrt((horizontal**2).sum(axis=0)).ravel(), np.sqrt((vertical**2).sum(axis=0)).ravel()]
    )


def strains(model: Model, positions: np.ndarray) -> np.ndarray:
    """(n_springs,) strain (length - L) / L of every spring, in ``Model.springs`` order."""
    return (spring_lengths(model, positions) - model.rest_length) / model.rest_length


def spring_energy(model: Model, positions: np.ndarray) -> float:
    """Elastic energy stored in the springs, relative to the rest lattice (J)."""
    positions = np.asarray(positions, dtype=float)
    others = sum(term.numpy_energy(model, positions) for term in registry.present(model)
                 if term.numpy_energy is not None)
    return _nearest_spring_energy(model, positions) + others


def _nearest_spring_energy(model: Model, positions: np.ndarray) -> float:
    k = model.stiffness
    if model.linear:
        horizontal, vertical = spring_differences(model, positions)
        if model.periodic:  # the ring's closing spring is listed at both edges: count it once
            horizontal = horizontal[:, :, :-1]
        elif model.row_ends == "free":  # the end springs do not exist
            horizontal = horizontal[:, :, 1:-1]
        along = (horizontal[0] ** 2).sum() + (vertical[1] ** 2).sum()
        across = (horizontal[1:] ** 2).sum() + (vertical[0] ** 2).sum()
        if model.dim == 3:
            across += (vertical[2] ** 2).sum()
        energy = 0.5 * k * along + 0.5 * model.tension_stiffness * across
        rest = np.array(model.spacing - model.rest_length)
        for term in registry.present(model):  # terms of the law along the springs, about the
            if term.numpy_axial is not None:  # rest extension, less the rest tension's work
                rest_force, rest_energy = term.numpy_axial(model, rest)
                energy += sum((term.numpy_axial(model, rest + stretch)[1] - rest_energy
                               - rest_force * stretch).sum()
                              for stretch in (horizontal[0], vertical[1]))
        return float(energy)
    stretch = spring_lengths(model, positions) - model.rest_length
    if model.row_ends != "walls":  # the closing spring once, or no end springs at all
        listed = np.ones(model.n_springs, dtype=bool)
        listed[model.nx : model.ny * (model.nx + 1) : model.nx + 1] = False
        if model.row_ends == "free":
            listed[0 : model.ny * (model.nx + 1) : model.nx + 1] = False
        stretch = stretch[listed]
    rest_stretch = model.spacing - model.rest_length
    energy = 0.5 * k * (np.dot(stretch, stretch) - stretch.size * rest_stretch**2)
    for term in registry.present(model):  # terms of the law along the springs (FPU's, ...)
        if term.numpy_axial is not None:
            energy += (term.numpy_axial(model, stretch)[1].sum()
                       - stretch.size * term.numpy_axial(model, np.array(rest_stretch))[1])
    return float(energy)


def kinetic_energy(model: Model, velocities: np.ndarray) -> float:
    """Kinetic energy 1/2 sum m |v|^2 (J); velocities (dim, ny, nx)."""
    return float(0.5 * (model.masses * (velocities**2).sum(axis=0)).sum())


def gravity_energy(model: Model, positions: np.ndarray) -> float:
    """Gravitational potential energy -sum m g . (r - r_rest) (J); zero without gravity."""
    if not model.has_gravity:
        return 0.0
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)
    total = 0.0
    for component in range(model.dim):
        if model.gravity[component] != 0.0:
            displacement = positions[component] - rest[component]
            total -= model.gravity[component] * float((model.masses * displacement).sum())
    return total


def energy(model: Model, state: State, compiled: bool = True) -> Energy:
    """Full energy account of ``state`` (kinetic and spring terms from one compiled pass; the
    numpy functions above compute the same terms and serve as its independent check).
    ``compiled`` False: those numpy functions instead, no kernel called (what a listing that must
    answer at once uses: numba's first call in a process costs a few tenths of a second)."""
    if compiled:
        kinetic, spring = _compiled_energy_terms(model, state)
    else:
        kinetic = kinetic_energy(model, state.velocities)
        spring = spring_energy(model, state.positions)
    return Energy(
        kinetic=kinetic,
        spring=spring,
        gravity=gravity_energy(model, state.positions),
        dissipated=state.dissipated,
        driven=state.driven,
    )


def _compiled_energy_terms(model: Model, state: State) -> tuple[float, float]:
    from sim.forces.energy import energy_terms

    position, velocity = state.positions, state.velocities
    z = position[2] if model.dim == 3 else None
    vz = velocity[2] if model.dim == 3 else None
    kinetic, spring = energy_terms(
        position[0], position[1], z, velocity[0], velocity[1], vz, read_only(model.masses), model.linear,
        model.kernel_parameters,
    )
    return float(kinetic), float(spring)


# --- normal modes and stability -------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class StabilityLimit:
    """The largest stable time step of an integrator on a model.

    ``dt`` is None when no step is stable (explicit Euler and Heun on an undamped lattice).
    ``omega_max`` is the highest natural frequency (rad/s) of the linearised undamped lattice.
    ``exact`` is False when the limit is an estimate (damping on a lattice with unequal masses).
    ``run_dt``: see below.
    """

    integrator: str
    dt: float | None
    omega_max: float
    exact: bool
    reason: str
    run_dt: float | None = None
    """The largest dt at which the scene's own run was measured to run to its end, where that
    is below ``dt`` (``sim.scenes.run_limits``); None where it is not known."""

    def __str__(self) -> str:
        return self.reason


@dataclasses.dataclass(frozen=True)
class ModeSet:
    """Natural modes of the linearised lattice: squared frequencies (rad^2/s^2) and damping rates
    beta (1/s), each mode obeying u'' + beta u' + omega^2 u = 0.  ``exact`` is False when the
    damping rates are Rayleigh-quotient estimates (damping that the modes do not diagonalise)."""

    omega_squared: np.ndarray
    damping_rate: np.ndarray
    exact: bool


def _apply_scalar_stiffness(field: np.ndarray, across_columns: float, across_rows: float,
                            ends: str = "walls"):
    """K u for one displacement component field (ny, nx) with fixed walls (rows closed into
    rings, or with free ends, by ``ends``), matrix-free."""
    padded = np.pad(field, 1)
    if ends == "ring":
        padded[1:-1, 0] = field[:, -1]
        padded[1:-1, -1] = field[:, 0]
    elif ends == "free":
        padded[1:-1, 0] = field[:, 0]
        padded[1:-1, -1] = field[:, -1]
    return (
        across_columns * (2 * field - padded[1:-1, :-2] - padded[1:-1, 2:])
        + across_rows * (2 * field - padded[:-2, 1:-1] - padded[2:, 1:-1])
    )


def _largest_eigenvalue_lanczos(apply, n: int, iterations: int = 300, seed: int = 0) -> float:
    """Largest eigenvalue of a symmetric operator by Lanczos (no reorthogonalisation: the extreme
    Ritz value converges regardless)."""
    rng = np.random.default_rng(seed)
    vector = rng.standard_normal(n)
    vector /= np.linalg.norm(vector)
    previous = np.zeros(n)
    alphas: list[float] = []
    betas: list[float] = []
    beta = 0.0
    for _ in range(min(iterations, n)):
        w = apply(vector) - beta * previous
        alpha = float(np.dot(w, vector))
        w -= alpha * vector
        alphas.append(alpha)
        beta = float(np.linalg.norm(w))
        if beta < 1e-14 * max(1.0, abs(alpha)):
            break
        betas.append(beta)
        previous, vector = vector, w / beta
    size = len(alphas)
    tridiagonal = np.diag(alphas) + np.diag(betas[: size - 1], 1) + np.diag(betas[: size - 1], -1)
    return float(np.linalg.eigvalsh(tridiagonal)[-1])


_DENSE_LIMIT = 1600  # particles up to which unequal-mass lattices are solved with a dense eigh


def modes(model: Model, sample: int = 48) -> ModeSet:
    """The natural modes that decide stability.

    Equal masses: exact separable sine modes (for large lattices a sample that keeps the highest
    and lowest wavenumbers in each direction).  Unequal masses: dense eigen-decomposition up to
    ``_DENSE_LIMIT`` particles, else the top mode by Lanczos; damping rates are then estimated by
    the Rayleigh quotient of the damping matrix on each mode.
    """
    if registry.linear_stiffness(model).diagonal:  # x and y coupled: plane waves bound the modes
        return ModeSet(*diagonal_mode_sample(model))
    omega_squared: list[np.ndarray] = []
    damping_rate: list[np.ndarray] = []
    exact = True
    nx, ny = model.nx, model.ny
    if model.uniform_mass:
        mass = float(model.masses.flat[0])
        columns = second_difference_eigenvalues(nx, model.row_ends)
        rows = second_difference_eigenvalues(ny)
        columns = _keep_extremes(columns, sample)
        rows = _keep_extremes(rows, sample)
        for k_columns, k_rows, c_columns, c_rows in polarisations(model):
            p, q = np.meshgrid(columns, rows)
            omega_squared.append(((k_columns * p + k_rows * q) / mass).ravel())
            damping_rate.append(((c_columns * p + c_rows * q + model.drag) / mass).ravel())
        return ModeSet(np.concatenate(omega_squared), np.concatenate(damping_rate), True)

    inverse_sqrt_mass = 1.0 / np.sqrt(model.masses)
    n = model.n_particles
    for k_columns, k_rows, c_columns, c_rows in polarisations(model):
        if n <= _DENSE_LIMIT:
            scale = inverse_sqrt_mass.ravel()
            stiffness = stiffness_matrix(nx, ny, k_columns, k_rows, model.row_ends)
            stiffness *= np.outer(scale, scale)
            values, vectors = np.linalg.eigh(stiffness)
            damping = stiffness_matrix(nx, ny, c_columns, c_rows, model.row_ends)
            damping *= np.outer(scale, scale)
            damping += np.diag(model.drag * scale**2)
            rates = np.einsum("im,ij,jm->m", vectors, damping, vectors)
            omega_squared.append(values)
            damping_rate.append(rates)
            exact = exact and not model.is_damped  # damping rates are Rayleigh quotients
        else:

            def apply(vector, k_columns=k_columns, k_rows=k_rows):
                field = vector.reshape(ny, nx) * inverse_sqrt_mass
                return (_apply_scalar_stiffness(field, k_columns, k_rows, model.row_ends)
                        * inverse_sqrt_mass).ravel()

            top = _largest_eigenvalue_lanczos(apply, n)
            omega_squared.append(np.array([top]))
            lightest = float(model.masses.min())
            rate = (2 * (c_columns + c_rows) * 2 + model.drag) / lightest
            damping_rate.append(np.array([rate if model.is_damped else 0.0]))
            exact = exact and not model.is_damped
    return ModeSet(np.concatenate(omega_squared), np.concatenate(damping_rate), exact)


def _keep_extremes(values: np.ndarray, sample: int) -> np.ndarray:
    if values.size <= 3 * sample:
        return values
    middle = values[sample:-sample]
    step = max(1, middle.size // sample)
    return np.concatenate([values[:sample], middle[::step], values[-sample:]])


def highest_frequency(model: Model) -> float:
    """Highest natural angular frequency omega_max (rad/s) of the linearised undamped lattice."""
    return math.sqrt(max(float(modes(model).omega_squared.max()), 0.0))


def amplification_matrices(integrator: str, omega_squared, damping_rate, dt: float) -> np.ndarray:
    """(n_modes, s, s) matrices G with z_{n+1} = G z_n when ``integrator`` (as implemented in
    ``sim.loops.row_sweep``) integrates u'' + beta u' + omega^2 u = 0 with step ``dt``.  The state z is
    (u, u') for one-step methods and (u, u', cached acceleration) for velocity Verlet; each
    integrator's description (``sim.integrators.registry``) carries its own."""
    from sim.integrators.registry import describe

    amplification = describe(integrator).amplification
    if amplification is None:
        raise ValueError(f"{integrator} has no amplification matrices")
    return amplification(omega_squared, damping_rate, dt)


def _all_stable(integrator: str, mode_set: ModeSet, dt: float) -> bool:
    matrices = amplification_matrices(
        integrator, mode_set.omega_squared, mode_set.damping_rate, dt
    )
    radius = np.abs(small_matrices.eigenvalues(matrices)).max()
    return bool(radius <= 1.0 + 1e-12)


_SMALL_AMPLITUDE = (
    " This is the small-amplitude limit about the rest lattice: large displacements or a sag"
    " under gravity stiffen the springs and lower it."
)


def stability_limit(model: Model, integrator: str) -> StabilityLimit:
    """Largest time step for which ``integrator`` is stable on ``model`` (see ``StabilityLimit``)."""
    limit = _stability_limit(model, integrator)
    if limit.dt is not None and not model.linear:
        limit = dataclasses.replace(limit, reason=limit.reason + _SMALL_AMPLITUDE)
    return limit


def _stability_limit(model: Model, integrator: str) -> StabilityLimit:
    mode_set = modes(model)
    positive = mode_set.omega_squared[mode_set.omega_squared > 0]
    omega_max = math.sqrt(float(positive.max())) if positive.size else 0.0
    buckling = bool((mode_set.omega_squared < 0).any())
    note = (
        " The lattice is under compression (rest length > spacing) and buckles whatever the step."
        if buckling
        else ""
    )
    from sim.integrators.registry import describe

    description = describe(integrator)
    name = description.short_label
    factor = description.stability_factor
    if omega_max == 0.0 or factor == math.inf:
        reason = "no oscillating modes" if omega_max == 0.0 else f"{name} is stable at any step"
        return StabilityLimit(integrator, math.inf, omega_max, True, f"{reason}: any step")
    if not model.is_damped or description.amplification is None:
        if factor is None:
            return StabilityLimit(
                integrator, None, omega_max, True,
                f"{name} has no stable step on an undamped lattice: its energy grows at every dt "
                f"(highest natural frequency {omega_max:.4g} rad/s).{note}",
            )
        dt = factor / omega_max
        return StabilityLimit(
            integrator, dt, omega_max, True,
            f"{name} is stable for dt <= {factor:.4g}/omega_max = {dt:.6g} s "
            f"(omega_max = {omega_max:.6g} rad/s).{note}",
        )
    # Damped: bisect on the amplification matrices of all (sampled) modes.
    tiny = 1e-9 / omega_max
    kept = ModeSet(
        np.maximum(mode_set.omega_squared, 0.0), mode_set.damping_rate, mode_set.exact
    )
    if not _all_stable(integrator, kept, tiny):
        return StabilityLimit(
            integrator, None, omega_max, mode_set.exact,
            f"{name} has no stable step here: some modes are undamped "
            f"(omega_max = {omega_max:.4g} rad/s).{note}",
        )
    fastest = max(omega_max, float(kept.damping_rate.max()))
    low, high = tiny, 8.0 / fastest
    while _all_stable(integrator, kept, high):
        low, high = high, 2 * high
        if high > 1e6 / fastest:
            break
    for _ in range(60):
        middle = 0.5 * (low + high)
        if _all_stable(integrator, kept, middle):
            low = middle
        else:
            high = middle
        if high - low < 1e-10 * high:
            break
    estimate = "" if mode_set.exact else " (estimate: damping on unequal masses)"
    return StabilityLimit(
        integrator, low, omega_max, mode_set.exact,
        f"{name} is stable for dt <= {low:.6g} s with this damping{estimate} "
        f"(omega_max = {omega_max:.6g} rad/s).{note}",
    )
