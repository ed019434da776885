"""Exact solution of a linearised lattice by normal modes: the reference of the accuracy study.

With linearised springs (``Model.linear``) the equations of motion are linear with constant
coefficients,

    M u'' = -K u - C u' + M g,      u = r - r_rest  (component-major, (dim * ny * nx,) metres)

where K is block diagonal with one 5-point Dirichlet stiffness matrix per displacement component
(stiffness k along a spring, T / a across it), C holds the dashpots (along the springs) and the
drag, and g is gravity.  The matrices are built here from the model's description, independently
of the numba kernels, so that comparing the two checks the kernels too.

Undamped: the symmetric problem A = M^-1/2 K M^-1/2 = V diag(omega^2) V^T is solved once and
every mode evolves as a cosine.  Damped: the first-order system is diagonalised
(``numpy.linalg.eig``); a nearly defective system (critical damping) raises ``NotExactError``.
Dense linear algebra: meant for lattices up to a few thousand degrees of freedom.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from sim.forces import registry
from sim.model.lattice import Model

MAX_DEGREES_OF_FREEDOM = 3000
"""Largest dim * nx * ny solved with dense eigen-decompositions."""


class NotExactError(ValueError):
    """The exact modal solution is not available for this model (says why)."""


def _scalar_matrix(nx: int, ny: int, across_columns: float, across_rows: float) -> np.ndarray:
    """(n, n) coupling matrix of one displacement component on an nx-by-ny lattice with walls:
    ``across_columns`` for the horizontal springs (joining columns), ``across_rows`` for the
    vertical ones."""
    n = nx * ny
    matrix = np.zeros((n, n))
    index = np.arange(n).reshape(ny, nx)
    matrix[np.arange(n), np.arange(n)] = 2.0 * (across_columns + across_rows)
    left, right = index[:, :-1].ravel(), index[:, 1:].ravel()
    matrix[left, right] = matrix[right, left] = -across_columns
    lower, upper = index[:-1, :].ravel(), index[1:, :].ravel()
    matrix[lower, upper] = matrix[upper, lower] = -across_rows
    return matrix


def stiffness_and_damping(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(K, C): (N, N) stiffness (N/m) and damping (N s/m) matrices of the linearised lattice,
    N = dim * ny * nx, in the component-major order of ``sim.State`` arrays."""
    at_rest = registry.linear_stiffness(model)
    k, across, c = at_rest.along, at_rest.tension / model.spacing, model.damping
    couplings = [((k, across), (c, 0.0)), ((across, k), (0.0, c))]
    if model.dim == 3:
        couplings.append(((across, across), (0.0, 0.0)))
    n = model.n_particles
    size = model.dim * n
    stiffness = np.zeros((size, size))
    damping = np.zeros((size, size))
    for component, (spring, dashpot) in enumerate(couplings):
        block = slice(component * n, (component + 1) * n)
        stiffness[block, block] = _scalar_matrix(model.nx, model.ny, *spring)
        damping[block, block] = _scalar_matrix(model.nx, model.ny, *dashpot)
    damping += model.drag * np.eye(size)
    return stiffness, damping


def mass_vector(model: Model) -> np.ndarray:
    """(N,) mass (kg) of each degree of freedom, component-major."""
    return np.tile(np.asarray(model.masses, dtype=float).ravel(), model.dim)


def gravity_vector(model: Model) -> np.ndarray:
    """(N,) gravitational acceleration (m/s^2) of each degree of freedom, component-major."""
    n = model.n_particles
    return np.concatenate([np.full(n, model.gravity[c]) for c in range(model.dim)])


@dataclasses.dataclass(frozen=True)
class NormalModes:
    """Undamped normal modes of the linearised lattice.

    ``omega`` (N,) angular frequencies (rad/s, ascending); ``shapes`` (N, N) orthonormal columns in
    mass-weighted coordinates w = M^1/2 u; ``sqrt_mass`` (N,) sqrt(kg).
    """

    omega: np.ndarray
    shapes: np.ndarray
    sqrt_mass: np.ndarray

    def amplitudes(self, displacement: np.ndarray, velocity: np.ndarray):
        """Modal coordinates (q, q') of a (N,) displacement (m) and velocity (m/s)."""
        return (
            self.shapes.T @ (self.sqrt_mass * displacement),
            self.shapes.T @ (self.sqrt_mass * velocity),
        )

    def phase(self, mode: int, displacement: np.ndarray, velocity: np.ndarray) -> float:
        """Phase (rad) of one mode, q = A cos(phase), q' = -A omega sin(phase)."""
        shape = self.shapes[:, mode]
        q = float(shape @ (self.sqrt_mass * displacement))
        q_dot = float(shape @ (self.sqrt_mass * velocity))
        omega = float(self.omega[mode]) or 1.0
        return math.atan2(-q_dot / omega, q)

    def dominant(self, displacement: np.ndarray, velocity: np.ndarray) -> int:
        """Index of the mode that holds the most energy in the given state."""
        q, q_dot = self.amplitudes(displacement, velocity)
        return int(np.argmax(0.5 * (q_dot**2 + self.omega**2 * q**2)))


@functools.lru_cache(maxsize=4)
def normal_modes(model: Model) -> NormalModes:
    """Normal modes of ``model`` linearised about its rest lattice (gravity and damping ignored).
    Cached per model object (models are immutable)."""
    size = model.dim * model.n_particles
    if size > MAX_DEGREES_OF_FREEDOM:
        raise NotExactError(
            f"{size} degrees of freedom is too many for dense normal modes "
            f"(limit {MAX_DEGREES_OF_FREEDOM})"
        )
    stiffness, _ = stiffness_and_damping(model)
    sqrt_mass = np.sqrt(mass_vector(model))
    values, vectors = np.linalg.eigh(stiffness / np.outer(sqrt_mass, sqrt_mass))
    return NormalModes(np.sqrt(np.maximum(values, 0.0)), vectors, sqrt_mass)


class ExactLinearSolution:
    """u(t) of a linearised model from an initial state, evaluated at any time.

    ``state_at(t)`` returns (positions, velocities), each (dim, ny, nx) like ``sim.State`` arrays.
    Raises ``NotExactError`` for nonlinear springs, compression (buckling), too large lattices, or
    a damped system too close to defective to diagonalise reliably.
    """

    def __init__(self, model: Model, positions: np.ndarray, velocities: np.ndarray) -> None:
        if not model.linear:
            raise NotExactError("the springs are not linearised (use --set linear=true)")
        if model.rest_length > model.spacing:
            raise NotExactError("the lattice is under compression and buckles")
        self.model = model
        self.shape = (model.dim, model.ny, model.nx)
        rest = model.rest_positions.T.reshape(self.shape).ravel()
        self.rest = rest
        stiffness, damping = stiffness_and_damping(model)
        masses = mass_vector(model)
        force = masses * gravity_vector(model)
        self.modes = normal_modes(model)
        sqrt_mass = self.modes.sqrt_mass
        if np.any(self.modes.omega == 0) and np.any(force != 0):
            raise NotExactError("gravity acts on a mode without stiffness (no equilibrium)")
        self.equilibrium = (
            np.linalg.solve(stiffness, force) if np.any(force != 0) else np.zeros_like(rest)
        )
        displacement = np.asarray(positions, dtype=float).ravel() - rest - self.equilibrium
        velocity = np.asarray(velocities, dtype=float).ravel()
        self.damped = model.is_damped
        if not self.damped:
            self.q0, self.q_dot0 = self.modes.amplitudes(displacement, velocity)
            return
        size = masses.size
        scaled_stiffness = stiffness / np.outer(sqrt_mass, sqrt_mass)
        scaled_damping = damping / np.outer(sqrt_mass, sqrt_mass)
        system = np.block(
            [[np.zeros((size, size)), np.eye(size)], [-scaled_stiffness, -scaled_damping]]
        )
        eigenvalues, eigenvectors = np.linalg.eig(system)
        if np.linalg.cond(eigenvectors) > 1e8:
            raise NotExactError("the damped system is (nearly) defective, e.g. critically damped")
        self.eigenvalues = eigenvalues
        self.eigenvectors = eigenvectors
        start = np.concatenate([sqrt_mass * displacement, sqrt_mass * velocity])
        self.coefficients = np.linalg.solve(eigenvectors, start)

    def state_at(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """(positions, velocities) at ``time`` (s), (dim, ny, nx) arrays in m and m/s."""
        sqrt_mass = self.modes.sqrt_mass
        if not self.damped:
            omega = self.modes.omega
            safe = np.where(omega > 0, omega, 1.0)
            cosine, sine = np.cos(omega * time), np.sin(omega * time)
            q = np.where(omega > 0, self.q0 * cosine + self.q_dot0 / safe * sine,
                         self.q0 + self.q_dot0 * time)
            q_dot = np.where(omega > 0, -self.q0 * omega * sine + self.q_dot0 * cosine, self.q_dot0)
            displacement = self.modes.shapes @ q / sqrt_mass
            velocity = self.modes.shapes @ q_dot / sqrt_mass
        else:
            state = (self.eigenvectors @ (np.exp(self.eigenvalues * time) * self.coefficients)).real
            size = sqrt_mass.size
            displacement = state[:size] / sqrt_mass
            velocity = state[size:] / sqrt_mass
        positions = self.rest + self.equilibrium + displacement
        return positions.reshape(self.shape), velocity.reshape(self.shape)
