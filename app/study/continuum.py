"""The continuum-limit study: one body (``sim.scenes.bodies``) at several particle counts against the exact
continuum solution (``sim.scenes.continuum``), and the measured order of convergence in the spacing a.

For each n the body's lattice is run with an integrator of the registry at dt = courant * a / c
from its shape, released at rest, and compared at a few times (fractions of the crossing time
2 L0 / c) with:

* the continuum solution at the particles: the **error** (relative L2 distance, the largest over
  the times, relative to the shape's norm at the particles);
* the lattice's own exact normal-mode solution (``sim.theory.exact``): the **time-stepping error** of the
  run.  The step is verified: while it is more than ``TIME_ERROR_SHARE`` of the lattice's
  distance from the continuum (the discretisation error), dt is halved and the run repeated,
  so what the table shows is the continuum limit, not the integrator.

The order p is the least-squares slope of log(error) against log(a) over the runs with at least
``ORDER_FROM`` particles per side.  A smooth shape gives p = 2: the lattice's frequencies
(2c/a) sin(q a / 2) fall below c q by a fraction (q a)^2 / 24, a phase lag growing with time.
A pluck's kink gives p near 1 (``EXPECTED``).  The table and the picture are ``continuum_report``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from sim.model.state import State
from sim.runtime.simulation import BlowUpError, Simulation
from sim.scenes.bodies import DEFAULT_COURANT, Body
from sim.scenes.continuum import ContinuumSolution
from sim.theory.exact import ExactSolver

TIMES = (0.25, 0.5, 0.75, 1.0)
"""Comparison times as fractions of the crossing time 2 L0 / c."""


TIME_ERROR_SHARE = 0.1
"""Largest accepted ratio of time-stepping error to discretisation error."""

MAX_HALVINGS = 4
ORDER_FROM = 32
"""Fewest particles per side of the runs that the order is fitted over (smaller ones are not
yet in the asymptotic range)."""

EXPECTED = {
    True: (2.0, "smooth shape: the lattice's waves lag the continuum's by a phase error "
                "(q a)^2 / 24 per radian, so the error falls as a^2"),
    False: (1.0, "a pluck's kink puts energy in every mode (coefficients fall only as 1/n^2); "
                 "modes up to n ~ a^(-2/3) pick up a dispersion phase error of order one within "
                 "a crossing time, their share of the L2 norm falls only as a: order 1, not 2"),
}
"""(expected order, why) for smooth shapes (True) and a pluck (False)."""


@dataclasses.dataclass
class ContinuumRun:
    """One particle count: spacing (m), step (s), errors (relative L2) at ``TIMES``."""

    particles: int
    spacing: float
    integrator: str
    dt: float
    steps: int
    halvings: int
    errors: list[float]
    discretisation_errors: list[float]
    time_errors: list[float]
    series_terms: int
    series_change: float

    @property
    def error(self) -> float:
        return max(self.errors)

    @property
    def discretisation_error(self) -> float:
        return max(self.discretisation_errors)

    @property
    def time_error(self) -> float:
        return max(self.time_errors)

    @property
    def step_verified(self) -> bool:
        """Whether the time-stepping error is at most ``TIME_ERROR_SHARE`` of the lattice's."""
        return self.time_error <= TIME_ERROR_SHARE * self.discretisation_error

    def as_dict(self) -> dict[str, Any]:
        return dict(particles=self.particles, spacing=self.spacing, error=self.error,
                    errors=self.errors, discretisation_error=self.discretisation_error,
                    time_error=self.time_error, integrator=self.integrator, dt=self.dt,
                    steps=self.steps, halvings=self.halvings, step_verified=self.step_verified,
                    series_terms=self.series_terms,
                    series_change=self.series_change)


@dataclasses.dataclass
class ContinuumStudy:
    """All runs of one body, the fitted order and what was expected."""

    body: Body
    times: list[float]
    runs: list[ContinuumRun]
    order: float | None
    expected_order: float
    why: str

    def as_dict(self) -> dict[str, Any]:
        return dict(body=self.body.kind, description=self.body.describe(),
                    shape=self.body.shape.kind, speed=self.body.speed, length=self.body.length,
                    times=self.times, runs=[run.as_dict() for run in self.runs],
                    order=self.order, expected_order=self.expected_order, why=self.why)


def planned_steps(body: Body, particles: int, courant: float = DEFAULT_COURANT) -> int:
    """Steps of one run at the first dt (a verified step may halve it)."""
    return math.ceil(TIMES[-1] * body.crossing_time / (courant * body.spacing(particles)
                                                         / body.speed))


def planned_runs(body: Body, particles: Sequence[int], integrator: str,
                 courant: float = DEFAULT_COURANT) -> list[tuple[float, int, str]]:
    """(steps, particles, integrator) of each run, for ``app.cli.limits.check_plan``."""
    return [(planned_steps(body, n, courant), n**body.dimensions, integrator) for n in particles]


def _relative(a: np.ndarray, b: np.ndarray, norm: float) -> float:
    return float(np.linalg.norm(a - b) / norm)


def lattice_run(body: Body, particles: int, integrator: str, dt: float, times: Sequence[float],
                on_step: Callable[[Simulation], None] | None = None) -> list[np.ndarray]:
    """The body's lattice run with ``integrator`` at ``dt`` (adjusted down so that every time
    is a whole number of steps); the (ny, nx) displacement at each of ``times`` (s)."""
    simulation = Simulation(body.scene(particles, integrator, dt))
    fields = []
    for time in times:
        remaining = time - simulation.time
        steps = max(1, math.ceil(remaining / dt - 1e-9))
        simulation.dt = remaining / steps
        simulation.step(steps)
        fields.append(body.field(simulation.model, simulation.peek_positions()))
        if on_step is not None:
            on_step(simulation)
    return fields


def exact_lattice(body: Body, particles: int, times: Sequence[float]) -> list[np.ndarray]:
    """The lattice's own exact normal-mode solution (``sim.theory.exact``) at ``times``: (ny, nx) each."""
    scene = body.scene(particles)
    model = scene.model
    solver = ExactSolver(model, State.from_particle_arrays(model, scene.initial_positions,
                                                           scene.initial_velocities))
    rest = model.rest_positions[:, body.component].reshape(model.ny, model.nx)
    return [solver.state_at(time)[0][body.component] - rest for time in times]


def run_particles(body: Body, particles: int, integrator: str = "verlet",
                  courant: float = DEFAULT_COURANT) -> ContinuumRun:
    """One particle count, its step verified against the lattice's exact solution."""
    times = [fraction * body.crossing_time for fraction in TIMES]
    continuum = ContinuumSolution(body, particles)
    reference = [continuum.at(time) for time in times]
    norm = float(np.linalg.norm(continuum.at(0.0)))
    exact = exact_lattice(body, particles, times)
    discretisation = [_relative(e, r, norm) for e, r in zip(exact, reference, strict=True)]
    dt = body.first_step(particles, integrator, courant)
    for halvings in range(MAX_HALVINGS + 1):
        try:
            fields = lattice_run(body, particles, integrator, dt, times)
        except BlowUpError as error:  # a smaller step may be stable; the last one says why not
            if halvings == MAX_HALVINGS:
                raise ValueError(f"{particles} particles: {error}") from None
            dt /= 2.0
            continue
        time_errors = [_relative(f, e, norm) for f, e in zip(fields, exact, strict=True)]
        if max(time_errors) <= TIME_ERROR_SHARE * max(discretisation) or halvings == MAX_HALVINGS:
            break
        dt /= 2.0
    return ContinuumRun(
        particles=particles, spacing=body.spacing(particles), integrator=integrator, dt=dt,
        steps=math.ceil(times[-1] / dt - 1e-9), halvings=halvings,
        errors=[_relative(f, r, norm) for f, r in zip(fields, reference, strict=True)],
        discretisation_errors=discretisation, time_errors=time_errors,
        series_terms=continuum.terms, series_change=continuum.change,
    )


def measured_order(runs: Sequence[ContinuumRun]) -> float | None:
    """Least-squares slope of log(error) against log(a) over runs with >= ``ORDER_FROM``
    particles (all runs if fewer than two have that many); None with fewer than two runs."""
    chosen = [run for run in runs if run.particles >= ORDER_FROM]
    if len(chosen) < 2:
        chosen = list(runs)
    if len(chosen) < 2:
        return None
    x = np.log([run.spacing for run in chosen])
    y = np.log([max(run.error, 1e-300) for run in chosen])
    return float(np.polyfit(x, y, 1)[0])


def continuum_study(body: Body, particles: Sequence[int], integrator: str = "verlet",
                    courant: float = DEFAULT_COURANT,
                    progress: Callable[[str], None] | None = None) -> ContinuumStudy:
    """Run ``body`` at each particle count (rising) and fit the order."""
    runs = []
    for n in sorted(set(int(n) for n in particles)):
        runs.append(run_particles(body, n, integrator, courant))
        if progress is not None:
            progress(f"{n} particles per side")
    expected, why = EXPECTED[body.shape.smooth]
    if body.shape.kind == "sine":
        why = ("one sine mode: it is also a normal mode of the lattice, whose frequency is low by "
               "(q a)^2 / 24, so the error falls as a^2")
    return ContinuumStudy(body=body, times=[f * body.crossing_time for f in TIMES], runs=runs,
                          order=measured_order(runs), expected_order=expected, why=why)
