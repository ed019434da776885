"""Predicted accuracy of a run before running it: energy and phase error per (integrator, dt).

About rest the lattice is a set of independent damped oscillators, its normal modes
(``sim.theory.modes``).  An explicit integrator advances each mode (q, q') by a fixed matrix per step,
its amplification matrix G(omega dt, beta dt) (``sim.theory.observables.amplification_matrices``), so
after n steps a mode is G^n (q0, q0'): the whole numerical run of the linearised lattice is known
from the initial state's modal content without stepping it.  From it:

* **energy error**: (numerical modal energy - exact modal energy) after ``duration``, divided by
  the run's energy scale (``Simulation.energy_scale``): the energy-balance error the run will show,
  exactly (to round-off) for a linear undamped scene; with damping it assumes the integrator's
  dissipated-energy quadrature is exact, so it is the error of the energy left in the lattice;
* **phase error**: per mode n (arg(lambda) - omega_d dt), lambda the dominant eigenvalue of G;
  reported as the energy-weighted root mean square over the modes (rad);
* **field error**: ||u_n - u(t)|| / ||u(t)||, the relative L2 distance of the numerical
  displacement field from the exact one of the linearised lattice after ``duration`` (the field
  error of ``sim.runtime.errors``, in mass-weighted modal coordinates: equal to it for equal masses).

Cost: the modal transform of the initial state (a few sine transforms for equal masses, one
eigen-decomposition otherwise, ``sim.theory.modes.DENSE_PARTICLE_LIMIT``) and log2(n) products of
small matrices per mode (``sim.theory.small_matrices``); the transform is shared by every
(integrator, dt) asked of one ``Predictor``.  Nonlinear scenes are predicted from their
linearisation (docs/accuracy.md says how far that holds).  ``app.study.choose`` plans its
candidates from these predictions and verifies the one it picks by running it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.integrators.registry import FORCE_EVALUATIONS
from sim.model.lattice import Model, ModelError
from sim.theory import small_matrices
from sim.theory.modes import ModalBasis, static_offset
from sim.theory.observables import amplification_matrices


@dataclasses.dataclass(frozen=True)
class Prediction:
    """Predicted accuracy of one run: ``energy_error`` relative to the energy in play (signed:
    + gains, - loses), ``phase_error`` (rad, energy-weighted RMS over the modes), ``stable``
    (False when some excited mode grows without bound), and the cost."""

    integrator: str
    dt: float
    duration: float
    steps: int
    energy_error: float
    phase_error: float
    stable: bool
    force_evaluations_per_second: float
    field_error: float = math.nan
    """Relative L2 distance of the final displacement field from the exact linearised one."""

    def describe(self) -> str:
        if not self.stable:
            return (f"{self.integrator} at dt = {self.dt:.4g} s: unstable for this scene "
                    f"(a mode grows at every step)")
        return (f"{self.integrator} at dt = {self.dt:.4g} s: predicted energy error after "
                f"{self.duration:g} s {self.energy_error:+.2%}, phase error "
                f"{self.phase_error:.2g} rad")


class Predictor:
    """Predictions for one model and initial state (positions, velocities: (n, dim), m, m/s);
    ``scale`` is the energy in play (J) the energy error is divided by."""

    def __init__(self, model: Model, positions: np.ndarray, velocities: np.ndarray,
                 scale: float) -> None:
        if model.has_forcing:
            raise ModelError("predictions follow the free lattice's normal modes; a driver or an "
                             "absorbing layer acts from outside them (measure the run instead)")
        self.model = model
        self.scale = float(scale)
        self.basis = ModalBasis.of(model)
        rest = model.rest_positions
        offset = static_offset(model)
        shape = (model.dim, model.ny, model.nx)
        displacement = (np.asarray(positions, float) - rest).T.reshape(shape) - offset
        velocity = np.asarray(velocities, float).T.reshape(shape)
        omega_squared, rates, q0, v0, static = [], [], [], [], []
        for component in range(model.dim):
            static.append(np.ravel(self.basis.to_modes(offset[component], component)))
            omega_squared.append(np.ravel(self.basis.omega_squared[component]))
            rates.append(np.ravel(self.basis.damping_rate[component]))
            q0.append(np.ravel(self.basis.to_modes(displacement[component], component)))
            v0.append(np.ravel(self.basis.to_modes(velocity[component], component)))
        self.omega_squared = np.concatenate(omega_squared)
        self.damping_rate = np.concatenate(rates)
        self.q0 = np.concatenate(q0)
        self.v0 = np.concatenate(v0)
        energies = 0.5 * (self.v0**2 + self.omega_squared * self.q0**2)
        keep = energies > 1e-30 * max(float(energies.sum()), 1e-300)
        static_modes = np.concatenate(static)
        self.static = static_modes[keep]
        """The static offset (gravity's sag) in the kept modes; ``static_rest`` the rest's norm."""
        self.static_rest = float(np.linalg.norm(static_modes[~keep]))
        self.omega_squared, self.damping_rate = self.omega_squared[keep], self.damping_rate[keep]
        self.q0, self.v0, self.energies = self.q0[keep], self.v0[keep], energies[keep]

    def exact_energy(self, time: float) -> float:
        """Modal energy (J) of the exact linearised dynamics at ``time``."""
        q, v = exact_modes(self.omega_squared, self.damping_rate, self.q0, self.v0, time)
        return float(0.5 * (v**2 + self.omega_squared * q**2).sum())

    def _start_vectors(self, size: int) -> np.ndarray:
        """(n_modes, size) initial modal states: (q, q') for a one-step method, and for a method
        that carries the acceleration from step to step (amplification matrices of size 3) also
        q'' = -omega^2 q - beta q'."""
        components = [self.q0, self.v0]
        if size == 3:
            components.append(-self.omega_squared * self.q0 - self.damping_rate * self.v0)
        return np.stack(components, axis=1)

    def predict(self, integrator: str, dt: float, duration: float) -> Prediction:
        """The accuracy of running ``integrator`` at ``dt`` for ``duration`` seconds."""
        steps = max(1, int(round(duration / dt)))
        cost = FORCE_EVALUATIONS.get(integrator, 1) / dt
        if self.energies.size == 0:
            return Prediction(integrator, dt, duration, steps, 0.0, 0.0, True, cost, 0.0)
        matrices = amplification_matrices(integrator, self.omega_squared, self.damping_rate, dt)
        start = self._start_vectors(matrices.shape[-1])
        eigenvalues = small_matrices.eigenvalues(matrices)
        radius = np.abs(eigenvalues).max(axis=1)
        stable = bool(np.all(radius <= 1.0 + 1e-12))
        end = small_matrices.power_apply(matrices, steps, start)
        q, v = end[:, 0], end[:, 1]
        with np.errstate(over="ignore", invalid="ignore"):
            numerical = float(0.5 * (v**2 + self.omega_squared * q**2).sum())
        exact = self.exact_energy(steps * dt)
        exact_q = exact_modes(self.omega_squared, self.damping_rate, self.q0, self.v0,
                              steps * dt)[0]
        size = math.hypot(float(np.linalg.norm(exact_q + self.static)), self.static_rest)
        with np.errstate(over="ignore", invalid="ignore"):
            distance = float(np.linalg.norm(q - exact_q))
        field_error = distance / size if size > 0 else distance
        if not math.isfinite(field_error):
            field_error = math.inf
        error = (numerical - exact) / self.scale if self.scale > 0 else 0.0
        dominant = eigenvalues[np.arange(len(eigenvalues)), np.argmax(np.abs(eigenvalues), axis=1)]
        damped = self.omega_squared - 0.25 * self.damping_rate**2
        omega_d = np.sqrt(np.maximum(damped, 0.0))
        phase = steps * (np.abs(np.angle(dominant)) - omega_d * dt)
        weights = self.energies / self.energies.sum()
        phase_error = float(np.sqrt((weights * phase**2).sum()))
        if not (math.isfinite(error) and math.isfinite(field_error)):
            stable = False
        return Prediction(integrator, dt, duration, steps, float(error), phase_error, stable, cost,
                          field_error)


def exact_modes(omega_squared: np.ndarray, damping_rate: np.ndarray, q0: np.ndarray,
                v0: np.ndarray, time: float) -> tuple[np.ndarray, np.ndarray]:
    """(q, q') at ``time`` of independent oscillators q'' + beta q' + omega^2 q = 0 started at
    (q0, v0): under-, critically and over-damped cases, written so that none divides by zero."""
    beta = np.asarray(damping_rate, float)
    omega_squared = np.asarray(omega_squared, float)
    if not beta.any() and omega_squared.min(initial=1.0) > 0.0:  # undamped: the common case
        omega = np.sqrt(omega_squared)
        cosine, sine = np.cos(omega * time), np.sin(omega * time)
        return q0 * cosine + v0 * (sine / omega), v0 * cosine - q0 * (omega * sine)
    half = 0.5 * beta
    discriminant = np.asarray(omega_squared, float) - half**2
    decay = np.exp(-half * time)
    root = np.sqrt(np.abs(discriminant))
    under = discriminant > 0
    # c(t) = cos(w t) (or cosh), s(t) = sin(w t)/w (or sinh/w), -> t as w -> 0
    argument = root * time
    cosine = np.where(under, np.cos(argument), np.cosh(np.where(under, 0.0, argument)))
    with np.errstate(invalid="ignore", divide="ignore"):
        sine_over = np.where(
            root * time > 1e-8,
            np.where(under, np.sin(argument), np.sinh(np.where(under, 0.0, argument)))
            / np.where(root > 0, root, 1.0),
            time,
        )
    derivative_cosine = np.where(under, -root * np.sin(argument),
                                 root * np.sinh(np.where(under, 0.0, argument)))
    q = decay * (q0 * cosine + (v0 + half * q0) * sine_over)
    # q' = -half q + decay (q0 c' + (v0 + half q0) s'), s' = c
    v = -half * q + decay * (q0 * derivative_cosine + (v0 + half * q0) * cosine)
    return q, v


def energy_in_play(model: Model, energy: object) -> float:
    """The energy in play (J) of a state with this energy account: its kinetic and spring energy
    (above the rest lattice) plus what gravity releases as the lattice sags from rest to its
    equilibrium (1/2 f.K^-1 f of the linearised lattice; without tension across the pull, the
    weight times the lattice's size).  The denominator of the energy-balance error."""
    from sim.theory.modes import gravity_release_energy

    scale = max(float(energy.kinetic), 0.0) + max(float(energy.spring), 0.0)  # type: ignore[attr-defined]
    release = gravity_release_energy(model)
    if math.isfinite(release):
        return scale + release
    weight = float(model.masses.sum()) * float(np.linalg.norm(model.gravity))
    return scale + weight * (max(model.nx, model.ny) + 1) * model.spacing


def predictor_for(simulation: object) -> Predictor:
    """A ``Predictor`` for a ``sim.Simulation``'s current state and energy scale."""
    state = simulation.state  # type: ignore[attr-defined]
    return Predictor(
        simulation.model,  # type: ignore[attr-defined]
        state.particle_positions(), state.particle_velocities(),
        simulation.energy_scale(),  # type: ignore[attr-defined]
    )


def predictor_for_scene(model: Model, positions: np.ndarray, velocities: np.ndarray,
                        compiled: bool = True) -> Predictor:
    """A ``Predictor`` for ``model`` started from (positions, velocities) ((n, dim) m, m/s), e.g.
    a scene's initial state with the parameters a user has changed since; ``compiled`` False:
    its energy from numpy (``observables.energy``), no kernel called."""
    from sim.model.state import State
    from sim.theory.observables import energy

    state = State.from_particle_arrays(model, positions, velocities)
    account = energy(model, state, compiled)
    return Predictor(model, positions, velocities, energy_in_play(model, account))
