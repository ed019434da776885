"""The two error measures of a run, defined once: every command, study and page uses these.

* **Energy error** (``energy_error``): the magnitude of the relative energy-balance error at the
  end of the run, ``|Simulation.energy_balance_error()|``: the change of kinetic + potential +
  dissipated - driver work since the start, over the energy in play.  Blind to phase: a wave
  in the wrong place can carry the right energy.
* **Field error** (``field_error``): the relative L2 distance of the displacement field u (all
  particles' displacements from rest, (dim, ny, nx) m) at the end of the run from a reference,
  ||u - u_ref||_2 / ||u_ref||_2.  It carries phase: a wave half a wavelength off counts as an
  error of about 2.

The reference of the field error is the exact normal-mode solution (``sim.theory.exact``) where the
scene is linear and the solver applies (``exact_final_displacement``); otherwise a converged
run of the most accurate integrator: RK4 at a step small enough that halving it changes the
field by less than a tenth of the tolerance (``halving_converged``), checked by running both.
"""

from __future__ import annotations

import math

import numpy as np

from sim.model.lattice import Model
from sim.model.state import State
from sim.scenes.building import Scene

MEASURES = ("field", "energy")
"""The error measures, in the order they are offered (field first: it sees phase)."""

CONVERGED_FRACTION = 0.1
"""A reference run is converged when halving its step changes the field by less than this
fraction of the tolerance."""


def energy_error(simulation: object) -> float:
    """|relative energy-balance error| of a ``sim.Simulation`` since its start (dimensionless)."""
    return abs(float(simulation.energy_balance_error()))  # type: ignore[attr-defined]


def displacement(model: Model, positions: np.ndarray) -> np.ndarray:
    """(dim, ny, nx) displacements from rest (m, float64) of (dim, ny, nx) positions."""
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)
    return np.asarray(positions, dtype=np.float64) - rest


def field_error(field: np.ndarray, reference: np.ndarray) -> float:
    """||field - reference||_2 / ||reference||_2 of two displacement fields of one shape;
    ``math.inf`` when the field is not finite, and the absolute distance (m) when the reference
    is zero (a lattice that ends at rest)."""
    field = np.asarray(field, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    if not np.isfinite(field).all():
        return math.inf
    distance = float(np.linalg.norm((field - reference).ravel()))
    size = float(np.linalg.norm(reference.ravel()))
    return distance / size if size > 0 else distance


def halving_converged(coarse: np.ndarray, fine: np.ndarray, tolerance: float) -> tuple[bool, float]:
    """(whether halving the step changed the field by less than ``CONVERGED_FRACTION`` of the
    tolerance, that change as a field error of the coarse run against the fine one)."""
    change = field_error(coarse, fine)
    return change < CONVERGED_FRACTION * tolerance, change


def exact_reference_reason(model: Model) -> str | None:
    """Why the exact normal-mode solution cannot be the reference (None: it can)."""
    from sim.theory.exact import reason_not_applicable

    return reason_not_applicable(model)


def exact_final_displacement(scene: Scene, duration: float) -> np.ndarray:
    """The exact displacement field (dim, ny, nx) m of a linear scene at time ``duration`` s,
    from the normal-mode solution through its initial state."""
    from sim.theory.exact import ExactSolver

    model = scene.model
    state = State.from_particle_arrays(model, scene.initial_positions, scene.initial_velocities)
    solver = ExactSolver(model, state)
    positions = solver.state_at(float(duration))[0]
    return displacement(model, positions)
