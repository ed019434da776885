"""The exact integrator for linear scenes: the state at any time from the normal-mode solution.

A ``linear=True`` lattice is a set of independent damped oscillators in its normal modes
(``sim.theory.modes``): each modal coordinate obeys q'' + beta q' + omega^2 q = 0 about the static sag
under gravity, and its solution at any time is known in closed form.  ``ExactSolver`` transforms
a state once (a few sine transforms for equal masses, O(N log N); one eigen-decomposition for
unequal masses up to ``sim.theory.modes.DENSE_PARTICLE_LIMIT`` particles) and then gives the state at any
time: no time-step error for any dt, and the energy balance closes to round-off (the dissipated
energy is the modal energy the dampers took).

Damping is exact where the damping operator is diagonal in the modes: spring dashpots and uniform
drag on equal masses; no damping at all with unequal masses.  Elsewhere the integrator does not
apply, and says why (``reason_not_applicable``).  It is registered as the integrator ``exact``
(``kernel=False``): ``Simulation(scene, integrator="exact")``, ``--integrator exact``, the page.
"""

from __future__ import annotations

import math

import numpy as np

from sim.forces import registry
from sim.integrators.registry import IntegratorDescription, register
from sim.model.lattice import Model
from sim.model.state import State
from sim.theory.modes import DENSE_PARTICLE_LIMIT, ModalBasis, static_offset
from sim.theory.prediction import exact_modes


def reason_not_applicable(model: Model) -> str | None:
    """Why the exact solver cannot run ``model`` (None: it can)."""
    if registry.linear_stiffness(model).diagonal:
        return "the exact solver follows one polarisation at a time; diagonal springs couple x and y"
    if model.has_forcing:
        return ("the exact solver follows the free normal modes; a driver or an absorbing "
                "layer acts from outside them")
    if model.row_ends != "walls" and model.n_particles > DENSE_PARTICLE_LIMIT:
        return (f"a {model.boundary} lattice is decomposed up to {DENSE_PARTICLE_LIMIT:,} particles; "
                f"this one has {model.n_particles:,}")
    if not model.linear:
        return ("the exact solver needs linearised springs (linear=true; "
                "--set linear=true, or 'Linearised springs' in the page)")
    if not model.uniform_mass:
        if model.n_particles > DENSE_PARTICLE_LIMIT:
            return (f"with unequal masses it decomposes up to {DENSE_PARTICLE_LIMIT:,} particles; "
                    f"this lattice has {model.n_particles:,}")
        if model.is_damped:
            return ("with unequal masses the damping is not diagonal in the normal modes "
                    "(use equal masses, or no damping)")
    return None


class ExactSolver:
    """The normal-mode solution through a state: ``state_at(time)`` gives (positions,
    velocities) as (dim, ny, nx) arrays (m, m/s) and the dissipated energy (J) at ``time``."""

    def __init__(self, model: Model, state: State) -> None:
        reason = reason_not_applicable(model)
        if reason is not None:
            raise ValueError(reason)
        self.model = model
        self.basis = ModalBasis.of(model)
        self.start_time = float(state.time)
        self.start_dissipated = float(state.dissipated)
        shape = (model.dim, model.ny, model.nx)
        rest = model.rest_positions.T.reshape(shape)
        self.equilibrium = rest + static_offset(model)
        displacement = np.asarray(state.positions, dtype=float) - self.equilibrium
        velocity = np.asarray(state.velocities, dtype=float)
        self.q0 = [self.basis.to_modes(displacement[c], c) for c in range(model.dim)]
        self.v0 = [self.basis.to_modes(velocity[c], c) for c in range(model.dim)]
        self.start_energy = self._modal_energy(self.q0, self.v0)

    def _modal_energy(self, q: list[np.ndarray], v: list[np.ndarray]) -> float:
        return float(sum(
            0.5 * (np.square(v[c]) + self.basis.omega_squared[c] * np.square(q[c])).sum()
            for c in range(self.model.dim)
        ))

    def state_at(self, time: float) -> tuple[np.ndarray, np.ndarray, float]:
        elapsed = float(time) - self.start_time
        positions = np.empty_like(self.equilibrium)
        velocities = np.empty_like(self.equilibrium)
        qs, vs = [], []
        for c in range(self.model.dim):
            q, v = exact_modes(self.basis.omega_squared[c], self.basis.damping_rate[c],
                               self.q0[c], self.v0[c], elapsed)
            qs.append(q)
            vs.append(v)
            positions[c] = self.equilibrium[c] + self.basis.from_modes(q, c)
            velocities[c] = self.basis.from_modes(v, c)
        lost = self.start_energy - self._modal_energy(qs, vs) if self.model.is_damped else 0.0
        return positions, velocities, self.start_dissipated + lost


class ExactStepper:
    """The ``Stepper`` of the exact integrator: re-solves from the state whenever the state was
    changed from outside (a drag, a reset, a rollback), else moves the clock and evaluates the
    solution at the new time (the time is absolute, so no error accumulates)."""

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1):
        self.model = model
        self._solver: ExactSolver | None = None
        self._expected: tuple | None = None

    def invalidate(self) -> None:
        self._solver = None

    def advance(self, state: State, n: int, dt: float) -> None:
        now = (id(state), state.revision, state.step, state.time)
        if self._solver is None or now != self._expected:
            self._solver = ExactSolver(self.model, state)
        state.advance_clock(n, dt)
        positions, velocities, dissipated = self._solver.state_at(state.time)
        state.positions[...] = positions
        state.velocities[...] = velocities
        state.dissipated = dissipated
        self._expected = (id(state), state.revision, state.step, state.time)


EXACT = register(IntegratorDescription(
    name="exact",
    label="exact normal-mode solution",
    short_label="exact",
    order=0,
    force_evaluations=0,
    stability_factor=math.inf,
    stepper=ExactStepper,
    amplification=None,
    kernel=False,
    applies_to=reason_not_applicable,
    colour=(160, 90, 200),
    step_cost=(2.4e-6, 1 / 6.2e7),
    drift_when_gaining="The exact solver has no time-step error; the drift is round-off.",
))
"""The exact integrator's description: order 0 means "no time-step error" (not a convergence
order), force evaluations 0 (its cost is a few sine transforms per call, whatever dt is)."""
