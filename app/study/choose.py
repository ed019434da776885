"""``choose``: the cheapest (integrator, dt) that meets an error tolerance over a scene's whole
duration, verified by running exactly that setting before it is offered.

The error is one of the two measures of ``sim.errors``: the field error (relative L2 distance of
the final displacement field from a reference, which carries phase; the default where a
reference is affordable) or the energy error (the energy balance).  The field reference is the
exact normal-mode solution of a linear scene, else RK4 halved until halving changes the field by
less than a tenth of the tolerance (both runs made and compared).

Few runs: each integrator is probed once at half its stability limit (or at 0.2 / omega_max when
it has none), the step that should just meet the tolerance is predicted from the measured error
and the integrator's order (error ~ dt^p, aiming at half the tolerance, below 0.9 of the limit),
and that step is run over the full duration; a miss is retried once with a smaller step.
Integrators predicted to cost over ``COST_RATIO`` times the cheapest are not run (said so).
The answer is the verified setting with the least measured wall time; the other verified ones
are the runner-ups.  Every batch of runs goes through ``map_runs`` (default: one after the other
in this process), each run being ``choose_runs.run_setting`` of a small ``RunTask``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

import sim
from app.study.accuracy_runs import jsonable
from app.study.choose_runs import MapRuns, RunOutcome, RunTask, run_setting, serial_map, steps_for
from sim.errors import (
    CONVERGED_FRACTION,
    MEASURES,
    exact_final_displacement,
    exact_reference_reason,
    field_error,
    halving_converged,
)
from sim.integrators import describe, most_accurate
from sim.observables import highest_frequency

COST_RATIO = 20.0
"""An integrator predicted to cost more than this times the cheapest prediction is not run."""
RUN_BUDGET_SECONDS = 120.0
"""A candidate run predicted to take longer than this (or than ``COST_RATIO`` times the longest
probe, if more) is not run."""
REFERENCE_BUDGET_SECONDS = 600.0
"""Largest estimated cost of a numerical reference for the field error to be the default."""
MAX_HALVINGS = 5
"""Most halvings of the reference step before the reference counts as not affordable."""


class Progress(Protocol):
    """What ``choose`` reports while it runs (the CLI's bar): estimated seconds of work."""

    def planned(self, seconds: float) -> None: ...

    def finished(self, seconds: float, label: str) -> None: ...


class _Silent:
    def planned(self, seconds: float) -> None:
        pass

    def finished(self, seconds: float, label: str) -> None:
        pass


@dataclasses.dataclass(frozen=True)
class Measured:
    """One setting run over the whole duration: its ``error`` in the chosen measure, the
    ``energy_error`` and ``field_error`` (None without a reference), ``wall_seconds``,
    ``blew_up`` (the message or None) and whether it ``meets`` the tolerance."""

    integrator: str
    dt: float
    steps: int
    duration: float
    error: float
    energy_error: float
    field_error: float | None
    wall_seconds: float
    blew_up: str | None
    meets: bool
    role: str

    def as_dict(self) -> dict[str, Any]:
        return jsonable(dataclasses.asdict(self))

    def describe(self) -> str:
        label = describe(self.integrator).short_label
        if self.blew_up:
            return f"{label} at dt = {self.dt:.5g} s blew up"
        return (f"{label} at dt = {self.dt:.5g} s: error {self.error:.3g} in "
                f"{self.wall_seconds:.3g} s ({self.steps} steps)")


@dataclasses.dataclass(frozen=True)
class Reference:
    """The field reference: ``kind`` ("exact normal modes" or "RK4 converged"), its ``dt``
    (None when exact), ``change`` (field change when its step was halved), ``wall_seconds``."""

    kind: str
    dt: float | None
    change: float
    wall_seconds: float

    def describe(self) -> str:
        if self.dt is None:
            return "the exact normal-mode solution"
        return (f"{self.kind} at dt = {self.dt:.4g} s (halving the step changed the field by "
                f"{self.change:.2g})")


@dataclasses.dataclass(frozen=True)
class Choice:
    """The answer of ``choose`` (``answer`` None when nothing met the tolerance), with every run
    made, the runner-ups, the reference, the stability ``limits`` and the ``skipped``
    integrators with the reason."""

    scene: str
    duration: float
    tolerance: float
    measure: str
    answer: Measured | None
    runner_ups: list[Measured]
    runs: list[Measured]
    reference: Reference | None
    limits: dict[str, float | None]
    skipped: dict[str, str]
    note: str = ""

    @property
    def best_reached(self) -> Measured | None:
        usable = [run for run in self.runs if run.blew_up is None]
        return min(usable, key=lambda run: run.error, default=None)

    def as_dict(self) -> dict[str, Any]:
        answer = self.answer
        return jsonable(dict(
            scene=self.scene, duration=self.duration, tolerance=self.tolerance,
            measure=self.measure, met=answer is not None,
            integrator=answer.integrator if answer else None, dt=answer.dt if answer else None,
            steps=answer.steps if answer else None, error=answer.error if answer else None,
            energy_error=answer.energy_error if answer else None,
            field_error=answer.field_error if answer else None,
            wall_seconds=answer.wall_seconds if answer else None,
            best_reached=self.best_reached.as_dict() if self.best_reached else None,
            runner_ups=[run.as_dict() for run in self.runner_ups],
            runs=[run.as_dict() for run in self.runs],
            reference=dataclasses.asdict(self.reference) if self.reference else None,
            limits=self.limits, skipped=self.skipped, note=self.note,
        ))


def estimated_seconds(task: RunTask) -> float:
    """The registry's estimate of a task's wall time (s)."""
    return describe(task.integrator).seconds_per_step(task.scene.model.n_particles) * task.steps


def candidate_integrators(scene: sim.Scene, integrators: Sequence[str] | None = None) -> list[str]:
    """The time-stepping integrators (compiled kernels) that apply to the scene, or the given ones."""
    if integrators:
        return [sim.integrators.check_integrator_name(name, scene.model) for name in integrators]
    return [name for name in sim.integrators.names(scene.model) if describe(name).kernel]


class _Runner:
    """Runs batches of tasks through ``map_runs`` and reports progress."""

    def __init__(self, map_runs: MapRuns, progress: Progress) -> None:
        self.map_runs = map_runs
        self.progress = progress

    def __call__(self, tasks: Sequence[RunTask]) -> list[RunOutcome]:
        if not tasks:
            return []
        self.progress.planned(sum(estimated_seconds(task) for task in tasks))
        outcomes = []
        for outcome in self.map_runs(run_setting, list(tasks)):
            task = outcome.task
            self.progress.finished(estimated_seconds(task),
                                   f"{task.role} {task.integrator} dt={task.dt:.3g}")
            outcomes.append(outcome)
        order = {id(task): index for index, task in enumerate(tasks)}
        # outcomes may come back in any order (and as copies): match them to their tasks
        if all(id(outcome.task) in order for outcome in outcomes):
            outcomes.sort(key=lambda outcome: order[id(outcome.task)])
        else:
            keys = [(t.integrator, t.dt, t.steps, t.role) for t in tasks]
            outcomes.sort(key=lambda o: keys.index((o.task.integrator, o.task.dt, o.task.steps,
                                                    o.task.role)))
        return outcomes


def reference_field(
    scene: sim.Scene, duration: float, tolerance: float, run: _Runner, threads: int = 1,
) -> tuple[np.ndarray, Reference, list[RunOutcome]] | None:
    """The field reference at ``duration`` (see the module docstring) and the numerical runs it
    took (RK4 settings whose error is then known for free); None when a converged numerical
    reference would cost more than ``REFERENCE_BUDGET_SECONDS`` (estimated).

    After a pair of runs (h, h/2) whose change is too large, the next step is predicted from the
    order p (change ~ h^p, aiming at half the allowed change) instead of halving blindly."""
    if exact_reference_reason(scene.model) is None:
        return (exact_final_displacement(scene, duration),
                Reference("exact normal modes", None, 0.0, 0.0), [])
    name = most_accurate(scene.model)
    order = describe(name).order or 1
    limit = sim.Simulation(scene).stable_dt(name) or 1.0 / (highest_frequency(scene.model) or 1)
    steps, dt = steps_for(duration, min(0.25 * limit, duration / 32))
    coarse = run([RunTask(scene, name, dt, steps, "reference", threads)])[0]
    outcomes = [coarse]
    for _ in range(MAX_HALVINGS):
        task = RunTask(scene, name, dt / 2, 2 * steps, "reference", threads)
        if estimated_seconds(task) > REFERENCE_BUDGET_SECONDS:
            return None
        fine = run([task])[0]
        outcomes.append(fine)
        if coarse.field is None or fine.field is None:
            coarse, dt, steps = fine, dt / 2, 2 * steps
            continue
        converged, change = halving_converged(coarse.field, fine.field, tolerance)
        if converged:
            spent = sum(outcome.wall_seconds for outcome in outcomes)
            return fine.field, Reference(f"{describe(name).short_label} converged", dt / 2,
                                         change, spent), outcomes[:-1]
        wanted = 0.5 * CONVERGED_FRACTION * tolerance
        predicted = dt * (wanted / change) ** (1.0 / order)
        if predicted < dt / 5:  # far off: jump to the predicted pair, skipping halvings
            steps, dt = steps_for(duration, predicted)
            coarse = run([RunTask(scene, name, dt, steps, "reference", threads)])[0]
            outcomes.append(coarse)
        else:
            coarse, dt, steps = fine, dt / 2, 2 * steps
    return None


def choose(
    scene: sim.Scene, tolerance: float, measure: str | None = None,
    integrators: Sequence[str] | None = None, duration: float | None = None,
    map_runs: MapRuns = serial_map, progress: Progress | None = None, threads: int = 1,
) -> Choice:
    """The cheapest verified setting meeting ``tolerance`` (see the module docstring).

    ``measure`` "field" or "energy" (None: field where a reference is affordable, else energy);
    ``duration`` (s) defaults to the scene's; ``map_runs`` carries out each batch of runs;
    ``threads`` the threads each run's compiled sweeps use."""
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"the tolerance must be a positive number, got {tolerance!r}")
    if measure is not None and measure not in MEASURES:
        raise ValueError(f"unknown error measure {measure!r}; choose one of: {', '.join(MEASURES)}")
    duration = float(duration if duration is not None else scene.duration)
    names = candidate_integrators(scene, integrators)
    run = _Runner(map_runs, progress or _Silent())
    note = ""
    reference = None
    reference_field_now = None
    reference_runs: list[RunOutcome] = []
    if measure in (None, "field"):
        found = reference_field(scene, duration, tolerance, run, threads)
        if found is None:
            if measure == "field":
                raise ValueError("no converged reference is affordable for the field error on "
                                 "this scene; use --error energy")
            note = "no affordable field reference: the energy error is used"
            measure = "energy"
        else:
            reference_field_now, reference, reference_runs = found
            measure = "field"
    probe = sim.Simulation(scene)
    limits = {name: probe.stable_dt(name) for name in names}
    omega = highest_frequency(scene.model) or 1.0

    def measured(outcome: RunOutcome) -> Measured:
        task = outcome.task
        field = (field_error(outcome.field, reference_field_now)
                 if outcome.field is not None and reference_field_now is not None else None)
        if outcome.blew_up:
            error = math.inf
        else:
            error = field if measure == "field" else outcome.energy_error
        return Measured(task.integrator, task.dt, task.steps, task.duration, error,
                        outcome.energy_error, field, outcome.wall_seconds, outcome.blew_up,
                        error <= tolerance, task.role)

    def task_at(name: str, dt: float, role: str) -> RunTask:
        steps, dt = steps_for(duration, min(dt, duration))
        return RunTask(scene, name, dt, steps, role, threads)

    def start_dt(name: str) -> float:
        limit = limits[name]
        return 0.5 * limit if limit else 0.2 / omega

    # the reference's own coarser runs are measured settings of its integrator: no probe needed
    runs: list[Measured] = [measured(o) for o in reference_runs if o.task.integrator in names]
    probed = {r.integrator for r in runs}
    runs += [measured(o) for o in run([task_at(n, start_dt(n), "probe")
                                       for n in names if n not in probed])]
    skipped: dict[str, str] = {}
    for attempt in range(3):
        latest = {name: [r for r in runs if r.integrator == name] for name in names}
        plans: dict[str, RunTask] = {}
        for name in names:
            if name in skipped or not latest[name]:
                continue
            last = latest[name][-1]
            if any(r.meets for r in latest[name]) and attempt > 0:
                continue
            next_dt = _next_dt(name, last, tolerance, limits[name], attempt)
            if next_dt is None:
                continue
            plans[name] = task_at(name, next_dt, "verify")
        if not plans:
            break
        costs = {name: _predicted_cost(latest[name][-1], task) for name, task in plans.items()}
        verified = [r.wall_seconds for r in runs if r.meets]
        cheapest = min(list(costs.values()) + verified)
        budget = max(RUN_BUDGET_SECONDS, COST_RATIO * max(r.wall_seconds for r in runs))
        for name in list(plans):
            if costs[name] > min(COST_RATIO * max(cheapest, 1e-3), budget):
                skipped[name] = (f"predicted to need dt = {plans[name].dt:.3g} s, about "
                                 f"{costs[name]:.3g} s of computing, over {COST_RATIO:g} times "
                                 f"the cheapest or {budget:.3g} s")
                del plans[name]
        runs += [measured(o) for o in run(list(plans.values()))]
    meeting = sorted((r for r in runs if r.meets), key=lambda r: r.wall_seconds)
    answer = meeting[0] if meeting else None
    best_of_each = {}
    for r in meeting[1:]:
        if r.integrator != (answer.integrator if answer else None):
            best_of_each.setdefault(r.integrator, r)
    return Choice(scene.name, duration, tolerance, measure, answer, list(best_of_each.values()),
                  runs, reference, limits, skipped, note)


def _predicted_cost(last: Measured, task: RunTask) -> float:
    """Wall seconds the task should take, scaled from the last run of its integrator."""
    if last.steps > 0 and last.wall_seconds > 0:
        return last.wall_seconds * task.steps / last.steps
    return estimated_seconds(task)


def _next_dt(name: str, last: Measured, tolerance: float, limit: float | None,
             attempt: int) -> float | None:
    """The step to run next: predicted from the last run's error and the order (aiming at half
    the tolerance), below 0.9 of the stability limit; a blow-up divides the step by 4."""
    ceiling = 0.9 * limit if limit else math.inf
    if last.blew_up or not math.isfinite(last.error):
        return last.dt / 4
    order = describe(name).order or 1
    if last.error <= 0:
        return None
    factor = (0.5 * tolerance / last.error) ** (1.0 / order)
    if last.meets:
        dt = min(last.dt * factor, ceiling)
        return dt if dt > 1.05 * last.dt else None
    return min(last.dt * min(factor, 0.8), ceiling)
