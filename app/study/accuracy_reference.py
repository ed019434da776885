"""The solution the accuracy study compares every run with, and how errors are measured against it.

``reference_solution(scene, until, smallest_dt)`` gives the state at time T: the exact normal-mode
solution (``app.study.linear``) when the springs are linearised and the lattice small; otherwise
the most accurate compiled integrator (``sim.integrators.most_accurate``: RK4, order p = 4) at
h = (smallest dt) / ``REFINEMENT`` (4: RK4's error there is 4^-4 = 1/256 of its own error at the
smallest dt, the most accurate run of a sweep), with its own error estimated by Richardson
extrapolation from the run at 2 h: |r_h - r_2h| / (2^p - 1).

Errors are relative to the size of the initial disturbance (``disturbance_scale``); states are
(dim, ny, nx) arrays of positions (m) and velocities (m/s).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

import sim
from app.study import linear
from sim.integrators.registry import describe, most_accurate

ProgressCallback = Callable[[str], None]

REFINEMENT = 4
"""The numerical reference's step is the smallest step of the sweep divided by this."""

REFERENCE_STEP_LIMIT = 2_000_000
"""Most steps spent on a numerical reference solution."""


@dataclasses.dataclass(frozen=True)
class Reference:
    """The solution the runs are compared with.

    ``kind`` is "exact normal modes" or "<integrator> (Richardson)"; ``positions`` /
    ``velocities`` are (dim, ny, nx) arrays (m, m/s) at time ``until``; ``error`` is the
    reference's own relative position error (0 for the exact solution, the Richardson estimate
    otherwise); ``dt`` the numerical step (None when exact); ``wall_seconds`` what it cost.
    """

    kind: str
    positions: np.ndarray
    velocities: np.ndarray
    error: float
    dt: float | None
    wall_seconds: float
    note: str = ""


def initial_state(scene: sim.Scene) -> tuple[np.ndarray, np.ndarray]:
    """(positions, velocities) of the scene's initial state as (dim, ny, nx) arrays."""
    state = sim.State.from_particle_arrays(
        scene.model, scene.initial_positions, scene.initial_velocities
    )
    return state.positions, state.velocities


def disturbance_scale(scene: sim.Scene) -> float:
    """Size of the initial disturbance (m): the largest initial displacement from rest, or the
    spacing if the scene starts at rest.  Relative errors are measured against it."""
    displacement = scene.initial_positions - scene.model.rest_positions
    largest = float(np.sqrt((displacement**2).sum(axis=1)).max()) if displacement.size else 0.0
    return largest if largest > 0 else scene.model.spacing


def position_error(positions: np.ndarray, reference: np.ndarray) -> float:
    """Largest distance (m) between a particle and its reference position; arrays (dim, ny, nx)."""
    return float(np.sqrt(((positions - reference) ** 2).sum(axis=0)).max())


def normal_modes_or_none(scene: sim.Scene) -> linear.NormalModes | None:
    """The normal modes of the scene's lattice with linearised springs, None when unavailable."""
    model = scene.model if scene.model.linear else scene.model.replace(linear=True)
    try:
        return linear.normal_modes(model)
    except linear.NotExactError:
        return None


def reference_solution(
    scene: sim.Scene, until: float, smallest_dt: float, progress: ProgressCallback | None = None
) -> Reference:
    """Exact normal modes when possible, else the most accurate integrator at smallest_dt /
    ``REFINEMENT`` (checked against twice that step)."""
    positions, velocities = initial_state(scene)
    started = time.perf_counter()
    reason = ""
    try:
        exact = linear.ExactLinearSolution(scene.model, positions, velocities)
    except linear.NotExactError as error:
        reason = str(error)
    else:
        final_positions, final_velocities = exact.state_at(until)
        return Reference(
            "exact normal modes", final_positions, final_velocities, 0.0, None,
            time.perf_counter() - started,
        )
    integrator = most_accurate(scene.model)
    description = describe(integrator)
    name = description.short_label
    steps = max(16, math.ceil(until / (smallest_dt / REFINEMENT)))
    steps += steps % 2
    steps = min(steps, REFERENCE_STEP_LIMIT)
    steps += steps % 2
    fine_dt = until / steps
    # The coarse half of the Richardson pair runs at 2 fine_dt; when the step count is capped
    # that can exceed the integrator's stability limit, and the reference would blow up.
    limit = sim.Simulation(scene).stable_dt(integrator)
    if limit and 2 * fine_dt > limit:
        longest = REFERENCE_STEP_LIMIT * limit / 2
        raise ValueError(
            f"--until {until:g} s is too long for a numerical reference: it would need more "
            f"than {REFERENCE_STEP_LIMIT} {name} steps to stay below {name}'s stable dt "
            f"({limit:.3g} s); use --until {longest:.3g} or less "
            "(a small scene with --set linear=true uses the exact solution instead)"
        )
    results = []
    for n, dt in ((steps // 2, 2 * fine_dt), (steps, fine_dt)):
        if progress:
            progress(f"reference: {name}, {n} steps of {dt:.3g} s")
        simulation = sim.Simulation(scene, integrator=integrator, dt=dt)
        simulation.chunk_steps = 4096
        try:
            simulation.step(n)
        except sim.BlowUpError as error:
            raise ValueError(
                f"the {name} reference blew up at dt = {dt:.3g} s ({error}); "
                "use a shorter --until or smaller --dts"
            ) from error
        results.append((simulation.state.positions.copy(), simulation.state.velocities.copy()))
    (coarse, _), (fine, fine_velocities) = results
    richardson = 2**description.order - 1
    estimate = position_error(fine, coarse) / richardson / disturbance_scale(scene)
    return Reference(
        f"{name} (Richardson)", fine, fine_velocities, estimate, fine_dt,
        time.perf_counter() - started, note=f"not exact: {reason}",
    )
