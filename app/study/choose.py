"""``choose``: the cheapest (integrator, dt) that meets an error tolerance over a scene's whole
duration, verified by running exactly that setting before it is offered.

The error is one of the two measures of ``sim.runtime.errors``: the field error (relative L2 distance of
the final displacement field from a reference, which carries phase; the default where a
reference is affordable) or the energy error (the energy balance).  The field reference is the
exact normal-mode solution of a linear scene, else RK4 halved until halving changes the field by
less than a tenth of the tolerance (both runs made and compared; the first step predicted from
the modes); it is the default only when planned to cost under ``REFERENCE_BUDGET_SECONDS``.

Few runs, planned before any is made (``choose_plan``): each integrator's step is predicted from
the normal modes of the scene's initial state (the exact numerical run of the linearised
lattice: the largest step whose predicted error is half the tolerance, below 0.9 of the
stability limit), and its cost is that many steps times a measured cost per step.  Scenes
without a prediction (a driver, an absorbing layer) are probed at half the stability limit (or
0.2 / omega_max without one) instead.  The candidates run over the full duration cheapest first;
a miss is retried with a step predicted from the measured error and the order (error ~ dt^p),
at most ``MAX_ATTEMPTS`` runs per integrator.  Once a setting is verified, a candidate that
would cost more is not started, and a started one is abandoned once it has taken
``ABANDON_FACTOR`` times the verified one's wall time.  Integrators estimated to cost over
``COST_RATIO`` times the cheapest are not run; every integrator not run says why.
Candidates are ranked by the registry's estimate of their cost (steps x the
integrator's calibrated seconds per step), so the same scene and tolerance give the same answer
on every machine and at any load; the answer is the verified setting of least cost (its
measured wall time beside it), the other verified ones are the runner-ups.  Every batch of runs
goes through ``map_runs`` (default: one after the other in this process), each run being
``choose_runs.run_setting`` of a small ``RunTask``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

import sim
from app.study.accuracy_runs import jsonable
from app.study.choose_plan import AIM, predicted_dt, predictor_or_none, step_seconds
from app.study.choose_runs import MapRuns, RunOutcome, RunTask, run_setting, serial_map, steps_for
from sim.integrators.registry import describe, most_accurate
from sim.runtime.errors import (
    CONVERGED_FRACTION,
    MEASURES,
    exact_final_displacement,
    exact_reference_reason,
    field_error,
    halving_converged,
)
from sim.theory.observables import highest_frequency

COST_RATIO = 20.0
"""An integrator predicted to cost more than this times the cheapest prediction is not run."""
ABANDON_FACTOR = 3.0
"""A started candidate is abandoned once its wall time exceeds this times the verified best's:
it cannot beat it (the registry's estimate said it would; the load of a shared machine does not
change wall times threefold between two runs), and never before ``ABANDON_SECONDS``."""
ABANDON_SECONDS = 5.0
"""No run is abandoned before this many seconds (shorter wall times are mostly noise)."""
MAX_ATTEMPTS = 3
"""Most runs of one integrator (a miss is retried with a step predicted from the measured error)."""
BEST_REACHED_SECONDS = 10.0
"""Planned cost (s) of the one run of an integrator predicted to miss the tolerance at every
step (it shows the best that integrator reaches)."""
REFERENCE_BUDGET_SECONDS = 120.0
"""Largest planned cost (s) of a numerical reference for the field error to be the default
(``--error field`` insists whatever it costs)."""
MAX_HALVINGS = 5
"""Most halvings of the reference step before the reference counts as not affordable."""


class Progress(Protocol):
    """What ``choose`` reports while it runs (the CLI's bar): planned seconds of work (a
    negative ``planned`` withdraws work that will not be done) and each run as it finishes."""

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
    abandoned: bool = False

    def as_dict(self) -> dict[str, Any]:
        return jsonable(dataclasses.asdict(self))

    def describe(self) -> str:
        label = describe(self.integrator).short_label
        if self.blew_up:
            return f"{label} at dt = {self.dt:.5g} s blew up"
        if self.abandoned:
            return f"{label} at dt = {self.dt:.5g} s stopped after {self.wall_seconds:.3g} s"
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
        usable = [run for run in self.runs if run.blew_up is None and not run.abandoned]
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


def estimated_seconds(task: RunTask, costs: dict[str, float] | None = None) -> float:
    """A task's planned wall time (s): steps times the measured seconds per step in ``costs``
    (integrator -> s), else the registry's estimate."""
    if costs and task.integrator in costs:
        return costs[task.integrator] * task.steps
    return describe(task.integrator).seconds_per_step(task.scene.model.n_particles) * task.steps


def candidate_integrators(scene: sim.Scene, integrators: Sequence[str] | None = None) -> list[str]:
    """The time-stepping integrators (compiled kernels) that apply to the scene, or the given ones."""
    if integrators:
        return [sim.integrators.check_integrator_name(name, scene.model) for name in integrators]
    return [name for name in sim.integrators.names(scene.model) if describe(name).kernel]


class _Runner:
    """Runs batches of tasks through ``map_runs`` and reports progress."""

    def __init__(self, map_runs: MapRuns, progress: Progress,
                 costs: dict[str, float] | None = None) -> None:
        self.map_runs = map_runs
        self.progress = progress
        self.costs = costs

    def __call__(self, tasks: Sequence[RunTask], planned: bool = False) -> list[RunOutcome]:
        """Run the tasks; ``planned``: their cost was already announced to the progress."""
        if not tasks:
            return []
        if not planned:
            self.progress.planned(sum(estimated_seconds(task, self.costs) for task in tasks))
        outcomes = []
        for outcome in self.map_runs(run_setting, list(tasks)):
            task = outcome.task
            self.progress.finished(estimated_seconds(task, self.costs),
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
    budget: float | None = REFERENCE_BUDGET_SECONDS, predictor: object | None = None,
    step_cost: float | None = None,
) -> tuple[np.ndarray, Reference, list[RunOutcome]] | None:
    """The field reference at ``duration`` (see the module docstring) and the numerical runs it
    took (RK4 settings whose error is then known for free); None when a converged numerical
    reference is predicted to cost more than ``budget`` seconds (None: no budget).

    The first pair (h, h/2) is planned from the normal-mode prediction when there is one (h
    predicted to give a field error of half the allowed change), else from a quarter of the
    stability limit; after a pair whose change is too large the next step is predicted from
    the order p (change ~ h^p, aiming at half the allowed change) instead of halving blindly."""
    if exact_reference_reason(scene.model) is None:
        return (exact_final_displacement(scene, duration),
                Reference("exact normal modes", None, 0.0, 0.0), [])
    name = most_accurate(scene.model)
    order = describe(name).order or 1
    limit = sim.Simulation(scene).stable_dt(name)
    omega = highest_frequency(scene.model) or 1.0
    wanted = 0.5 * CONVERGED_FRACTION * tolerance
    start = min(0.25 * (limit or 1.0 / omega), duration / 32)
    if predictor is not None:
        start = predicted_dt(predictor, name, wanted / AIM, duration, "field", limit, omega)[0]
    steps, dt = steps_for(duration, start)
    per_step = step_cost or describe(name).seconds_per_step(scene.model.n_particles)
    if budget is not None and 3 * steps * per_step > budget:
        return None
    coarse = run([RunTask(scene, name, dt, steps, "reference", threads)])[0]
    outcomes = [coarse]
    for _ in range(MAX_HALVINGS):
        task = RunTask(scene, name, dt / 2, 2 * steps, "reference", threads)
        if budget is not None and task.steps * per_step > budget:
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
    progress = progress or _Silent()
    progress.finished(0.0, "planning: the normal modes")
    predictor = predictor_or_none(scene)
    costs = {}
    for name in dict.fromkeys([*names, most_accurate(scene.model)]):
        progress.finished(0.0, f"planning: timing {name}")
        costs[name] = step_seconds(scene, name, threads)
    run = _Runner(map_runs, progress, costs)
    note = ""
    reference = None
    reference_field_now = None
    reference_runs: list[RunOutcome] = []
    if measure in (None, "field"):
        found = reference_field(scene, duration, tolerance, run, threads,
                                REFERENCE_BUDGET_SECONDS if measure is None else None,
                                predictor, costs[most_accurate(scene.model)])
        if found is None:
            if measure == "field":
                raise ValueError("no converged reference is affordable for the field error on "
                                 "this scene; use --error energy")
            note = (f"the energy error is used: a converged field reference is predicted to "
                    f"take over {REFERENCE_BUDGET_SECONDS:g} s here (--error field insists)")
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
        if outcome.blew_up or outcome.abandoned:
            error = math.inf
        else:
            error = field if measure == "field" else outcome.energy_error
        return Measured(task.integrator, task.dt, task.steps, task.duration, error,
                        outcome.energy_error, field, outcome.wall_seconds, outcome.blew_up,
                        error <= tolerance, task.role, outcome.abandoned)

    def task_at(name: str, dt: float, role: str, time_limit: float | None = None) -> RunTask:
        steps, dt = steps_for(duration, min(dt, duration))
        return RunTask(scene, name, dt, steps, role, threads, time_limit)

    # the reference's own coarser runs are measured settings of its integrator
    runs: list[Measured] = [measured(o) for o in reference_runs if o.task.integrator in names]
    skipped: dict[str, str] = {}
    plans: dict[str, tuple[float, str]] = {}  # integrator -> (next dt, role)
    n = scene.model.n_particles

    def estimate(name: str, dt: float) -> float:
        """The registry's estimate of a run's seconds: how candidates are ranked and cut."""
        return steps_for(duration, min(dt, duration))[0] * describe(name).seconds_per_step(n)

    def cost(run: Measured) -> float:
        """The registry's estimate of a run's seconds: what settings are ranked by, so the same
        scene and tolerance give the same answer on every machine and at any load."""
        return run.steps * describe(run.integrator).seconds_per_step(n)

    def planned(name: str, dt: float) -> float:
        """A run's seconds at the cost per step measured now: what the progress bar counts."""
        return steps_for(duration, min(dt, duration))[0] * costs[name]

    for name in names:
        progress.finished(0.0, f"planning: predicting {name}")
        if predictor is None:
            plans[name] = (0.5 * limits[name] if limits[name] else 0.2 / omega, "probe")
            continue
        dt, reached = predicted_dt(predictor, name, tolerance, duration, measure, limits[name],
                                   omega)
        if not reached:  # run once anyway, to show the best it reaches, at an affordable step
            dt = max(dt, duration * describe(name).seconds_per_step(n) / BEST_REACHED_SECONDS)
        plans[name] = (dt, "predicted" if reached else "predicted best")
    for name in {r.integrator for r in runs}:  # RK4 measured by the reference: step from there
        last = [r for r in runs if r.integrator == name][-1]
        next_dt = _next_dt(name, last, tolerance, limits[name])
        if next_dt is None:
            plans.pop(name, None)
        else:
            plans[name] = (next_dt, "verify")
    cheapest = min((estimate(name, dt) for name, (dt, _) in plans.items()), default=0.0)
    for name, (dt, _) in list(plans.items()):
        if estimate(name, dt) > COST_RATIO * max(cheapest, 1e-6):
            skipped[name] = (f"predicted to need dt = {dt:.3g} s, {steps_for(duration, dt)[0]} "
                             f"steps, over {COST_RATIO:g} times the cheapest candidate's cost")
            del plans[name]
    progress.planned(sum(planned(name, dt) for name, (dt, _) in plans.items()))
    attempts = dict.fromkeys(plans, 0)
    while plans:
        name = min(plans, key=lambda other: estimate(other, plans[other][0]))
        dt, role = plans.pop(name)
        verified = [r for r in runs if r.meets]
        best = min(verified, key=lambda r: (cost(r), r.wall_seconds)) if verified else None
        if best is not None and estimate(name, dt) >= cost(best):
            if not any(r.meets for r in runs if r.integrator == name):
                skipped[name] = (f"predicted to need dt = {dt:.3g} s, {steps_for(duration, dt)[0]} "
                                 f"steps: it cannot beat the verified {best.integrator} setting")
            progress.planned(-planned(name, dt))
            continue
        limit = (max(ABANDON_FACTOR * best.wall_seconds, ABANDON_SECONDS)
                 if best is not None else None)
        latest = measured(run([task_at(name, dt, role, limit)], planned=True)[0])
        runs.append(latest)
        attempts[name] += 1
        if latest.abandoned:
            skipped[name] = (f"at dt = {latest.dt:.3g} s stopped after {latest.wall_seconds:.3g} "
                             f"s, over {ABANDON_FACTOR:g} times the verified setting's wall time")
            continue
        next_dt = _next_dt(name, latest, tolerance, limits[name])
        if next_dt is not None and attempts[name] < MAX_ATTEMPTS and role != "predicted best":
            plans[name] = (next_dt, "verify")
            progress.planned(planned(name, next_dt))
    meeting = sorted((r for r in runs if r.meets), key=lambda r: (cost(r), r.wall_seconds))
    answer = meeting[0] if meeting else None
    best_of_each = {}
    for r in meeting[1:]:
        if r.integrator != (answer.integrator if answer else None):
            best_of_each.setdefault(r.integrator, r)
    return Choice(scene.name, duration, tolerance, measure, answer, list(best_of_each.values()),
                  runs, reference, limits, skipped, note)


def _next_dt(name: str, last: Measured, tolerance: float, limit: float | None) -> float | None:
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
