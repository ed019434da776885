"""The two error measures of a run, defined once: every command, study and page uses these.

Both look at the whole run, at ``SAMPLES`` evenly spaced times t_k = k T / ``SAMPLES``
(k = 1 .. ``SAMPLES``, T the run's duration; ``sample_steps`` gives the step after which each
is taken), not at its end alone: a damped scene ends at the same equilibrium whatever its
transient was.

* **Energy error** (``energy_error``, over a run ``largest_energy_error``): the largest magnitude,
  over the samples, of the relative energy-balance error ``Simulation.energy_balance_error()``:
  the change of kinetic + potential + dissipated - driver work since the start, over the energy
  in play.  Blind to phase: a wave in the wrong place can carry the right energy.
* **Field error** (``run_field_error``): the largest distance, over the samples, of the
  displacement field u (all particles' displacements from rest, (dim, ny, nx) m) from a reference
  at the same time, relative to the largest reference field of the run:
  max_k ||u(t_k) - u_ref(t_k)||_2 / max_k ||u_ref(t_k)||_2.  It carries phase: a wave half a
  wavelength off counts as an error of about 2.

The reference of the field error is the exact normal-mode solution (``sim.theory.exact``) where the
scene is linear and the solver applies (``exact_displacements``); otherwise a converged run of
the most accurate integrator: RK4 at a step small enough that halving it changes the sampled
field by less than a tenth of the tolerance (``halving_converged``), checked by running both.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sim.model.lattice import Model
from sim.model.state import State
from sim.scenes.building import Scene

MEASURES = ("field", "energy")
"""The error measures, in the order they are offered (field first: it sees phase)."""

SAMPLES = 40
"""Times of a run at which both errors are measured (evenly spaced, the last at its end)."""

FIELD_ERROR_DEFINITION = (
    f"largest over {SAMPLES} evenly spaced times t_k = k T/{SAMPLES} of ||u(t_k) - u_ref(t_k)||_2,"
    " divided by the largest ||u_ref(t_k)||_2 (u: every particle's displacement from rest)")
"""The field error in words (``--help``, JSON, docs)."""
ENERGY_ERROR_DEFINITION = (
    f"largest |energy-balance error| over the same {SAMPLES} times (kinetic + potential + "
    "dissipated - driver work, change since the start over the energy in play)")
"""The energy error in words (``--help``, JSON, docs)."""

CONVERGED_FRACTION = 0.1
"""A reference run is converged when halving its step changes the field by less than this
fraction of the tolerance."""


def energy_error(simulation: object) -> float:
    """|relative energy-balance error| of a ``sim.Simulation`` since its start (dimensionless)."""
    return abs(float(simulation.energy_balance_error()))  # type: ignore[attr-defined]


def sample_steps(steps: int, samples: int = SAMPLES) -> list[int]:
    """The step counts after which a run of ``steps`` steps is sampled: round(k steps / samples)
    for k = 1 .. samples, without repeats (fewer samples when there are fewer steps); exactly
    the times k T / samples when ``steps`` is a multiple of ``samples``."""
    return sorted({max(1, round(k * steps / samples)) for k in range(1, samples + 1)})


def sample_times(duration: float, steps: int, samples: int = SAMPLES) -> np.ndarray:
    """The times (s) of ``sample_steps`` in a run of ``steps`` steps over ``duration`` s."""
    return np.array([duration * n / steps for n in sample_steps(steps, samples)])


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


def run_field_error(fields: np.ndarray, reference: np.ndarray) -> float:
    """The whole-run field error (see the module docstring) of a run sampled as ``fields``
    (samples, dim, ny, nx) against ``reference`` sampled at the same times:
    max_k ||fields[k] - reference[k]||_2 / max_k ||reference[k]||_2; ``math.inf`` when a field
    is not finite, the absolute distance (m) when the reference never moves."""
    fields = np.asarray(fields, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    if fields.shape != reference.shape:
        raise ValueError(f"sampled fields of shape {fields.shape} cannot be compared with a "
                         f"reference of shape {reference.shape}")
    if not np.isfinite(fields).all():
        return math.inf
    count = len(reference)
    distance = float(np.linalg.norm((fields - reference).reshape(count, -1), axis=1).max())
    size = float(np.linalg.norm(reference.reshape(count, -1), axis=1).max())
    return distance / size if size > 0 else distance


def halving_converged(coarse: np.ndarray, fine: np.ndarray, tolerance: float) -> tuple[bool, float]:
    """(whether halving the step changed the sampled field by less than ``CONVERGED_FRACTION``
    of the tolerance, that change as the whole-run field error of the coarse run against the
    fine one); both (samples, dim, ny, nx)."""
    change = run_field_error(coarse, fine)
    return change < CONVERGED_FRACTION * tolerance, change


def exact_reference_reason(model: Model) -> str | None:
    """Why the exact normal-mode solution cannot be the reference (None: it can)."""
    from sim.theory.exact import reason_not_applicable

    return reason_not_applicable(model)


def exact_displacements(scene: Scene, times: Sequence[float]) -> np.ndarray:
    """The exact displacement fields (len(times), dim, ny, nx) m of a linear scene at ``times``
    (s), from the normal-mode solution through its initial state."""
    from sim.theory.exact import ExactSolver

    model = scene.model
    state = State.from_particle_arrays(model, scene.initial_positions, scene.initial_velocities)
    solver = ExactSolver(model, state)
    return np.stack([displacement(model, solver.state_at(float(time))[0]) for time in times])


def exact_final_displacement(scene: Scene, duration: float) -> np.ndarray:
    """The exact displacement field (dim, ny, nx) m of a linear scene at time ``duration`` s."""
    return exact_displacements(scene, [duration])[0]
