"""``choose``: the cheapest (integrator, dt) that meets an error tolerance over a scene's whole
duration, verified by running exactly that setting before it is offered.

Both errors of ``sim.runtime.errors`` are measured over the whole run (at
``sim.runtime.errors.SAMPLES`` evenly spaced times): the field error (the largest distance of the
displacement field from a reference, relative to the largest reference field; it carries phase) and
the energy error (the largest energy-balance error).  By default a setting meets the tolerance only
when both do (measure ``BOTH``); ``measure="field"`` or ``"energy"`` checks that one alone, the
other still measured and shown.  The field reference is the exact normal-mode solution of a linear
scene, else RK4 halved until halving changes the sampled field by less than a tenth of the tolerance
(both runs made and compared; the first step predicted from the modes); without ``measure="field"``
it is made only when planned to cost under ``REFERENCE_BUDGET_SECONDS``, and when it would cost more
the energy error alone is used and the note says so.

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
from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np

import sim
from app.study.choose_plan import AIM, predicted_dt, predictor_or_none, step_seconds
from app.study.choose_result import BOTH, Choice, Measured, Reference
from app.study.choose_runs import (
    ChoiceCancelled,
    MapRuns,
    RunOutcome,
    RunTask,
    run_setting,
    serial_map,
    steps_for,
)
from sim.integrators.registry import describe, most_accurate
from sim.runtime.errors import (
    CONVERGED_FRACTION,
    MEASURES,
    SAMPLES,
    exact_displacements,
    exact_reference_reason,
    halving_converged,
    run_field_error,
    sample_times,
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
MAX_HALVINGS = 8
"""Most pairs of reference runs before the reference counts as not affordable."""


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


class _Stoppable:
    """A ``Progress`` that raises ``ChoiceCancelled`` at every report once ``stop()`` is true."""

    def __init__(self, progress: Progress, stop: Callable[[], bool] | None) -> None:
        self.progress = progress
        self.stop = stop

    def check(self) -> None:
        if self.stop is not None and self.stop():
            raise ChoiceCancelled("the choice was cancelled")

    def planned(self, seconds: float) -> None:
        self.check()
        self.progress.planned(seconds)

    def finished(self, seconds: float, label: str) -> None:
        self.progress.finished(seconds, label)
        self.check()


__all__ = ["BOTH", "Choice", "ChoiceCancelled", "Measured", "Reference", "choose"]


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
                 costs: dict[str, float] | None = None,
                 stop: Callable[[], bool] | None = None) -> None:
        self.map_runs = map_runs
        self.progress = progress
        self.costs = costs
        self.stop = stop

    def __call__(self, tasks: Sequence[RunTask], planned: bool = False) -> list[RunOutcome]:
        """Run the tasks; ``planned``: their cost was already announced to the progress."""
        if not tasks:
            return []
        if self.stop is not None:
            tasks = [dataclasses.replace(task, stop=self.stop) for task in tasks]
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


def reference_fields(
    scene: sim.Scene, duration: float, tolerance: float, run: _Runner, threads: int = 1,
    budget: float | None = REFERENCE_BUDGET_SECONDS, predictor: object | None = None,
    step_cost: float | None = None,
) -> tuple[np.ndarray, Reference, list[RunOutcome]] | str:
    """The field reference at the sample times of a run over ``duration`` ((samples, dim, ny,
    nx); see the module docstring) and the numerical runs it took (RK4 settings whose error is
    then known for free); else why there is none (a sentence): a converged numerical reference
    is predicted to cost more than ``budget`` seconds (None: no budget), or the field does not
    converge (a pair at a step at least ``4`` times smaller changed it by more than half the
    change of an earlier pair: a force that jumps, such as a spring passing through zero length,
    or a motion that amplifies small differences keeps the field from settling as the step
    shrinks, so no step gives a field to compare with).

    The first pair (h, h/2) is planned from the normal-mode prediction when there is one (h
    predicted to give a field error of half the allowed change), else from a quarter of the
    stability limit; after a pair whose change is too large the next step is predicted from
    the order p (change ~ h^p, aiming at half the allowed change) instead of halving blindly."""
    if exact_reference_reason(scene.model) is None:
        times = sample_times(duration, SAMPLES)
        return (exact_displacements(scene, times),
                Reference("exact normal modes", None, 0.0, 0.0), [])
    name = most_accurate(scene.model)
    order = describe(name).order or 1
    limit = sim.Simulation(scene).stable_dt(name)
    omega = highest_frequency(scene.model) or 1.0
    wanted = 0.5 * CONVERGED_FRACTION * tolerance
    start = min(0.25 * (limit or 1.0 / omega), duration / 32)
    if predictor is not None:
        start = predicted_dt(predictor, name, wanted / AIM, duration, "field", limit, omega,
                             getattr(run.progress, "check", None))[0]
    steps, dt = steps_for(duration, start)
    per_step = step_cost or describe(name).seconds_per_step(scene.model.n_particles)
    too_costly = (f"a converged field reference is predicted to take over {budget or 0:g} s "
                  "of computing here")
    if budget is not None and 3 * steps * per_step > budget:
        return too_costly
    coarse = run([RunTask(scene, name, dt, steps, "reference", threads)])[0]
    outcomes = [coarse]
    seen: tuple[float, float] | None = None  # (dt, change) of the last pair compared
    pairs: list[tuple[float, float]] = []  # every (dt, change) compared
    for _ in range(MAX_HALVINGS):
        task = RunTask(scene, name, dt / 2, 2 * steps, "reference", threads)
        if budget is not None and task.steps * per_step > budget:
            return too_costly
        fine = run([task])[0]
        outcomes.append(fine)
        if coarse.fields is None or fine.fields is None:
            coarse, dt, steps = fine, dt / 2, 2 * steps
            continue
        converged, change = halving_converged(coarse.fields, fine.fields, tolerance)
        if converged:
            spent = sum(outcome.wall_seconds for outcome in outcomes)
            return fine.fields, Reference(f"{describe(name).short_label} converged", dt / 2,
                                          change, spent), outcomes[:-1]
        earlier = [(c, h) for h, c in pairs if h >= 4 * dt and change > c / 2]
        if earlier:
            least, at = min(earlier)
            label = describe(name).short_label
            return (f"the field does not converge: halving {label}'s step from {at:.3g} s "
                    f"changed the field over the run by {least:.2g}, from {dt:.3g} s by "
                    f"{change:.2g}; a force that jumps (a spring passing through zero length) or "
                    "a motion that amplifies small differences keeps it from settling, so no "
                    "step gives a reference")
        pairs.append((dt, change))
        # the order seen between the last two pairs (a transient with close encounters of
        # particles converges more slowly than the method's order until dt resolves them)
        seen_order = order
        if seen is not None and seen[1] > change > 0 and seen[0] > dt:
            seen_order = min(order, max(0.5, math.log(seen[1] / change) / math.log(seen[0] / dt)))
        seen = (dt, change)
        predicted = dt * (wanted / change) ** (1.0 / seen_order)
        if predicted < dt / 5:  # far off: jump to the predicted pair, skipping halvings
            steps, dt = steps_for(duration, predicted)
            if budget is not None and 3 * steps * per_step > budget:
                return too_costly
            coarse = run([RunTask(scene, name, dt, steps, "reference", threads)])[0]
            outcomes.append(coarse)
        else:
            coarse, dt, steps = fine, dt / 2, 2 * steps
    return f"halving the reference step {MAX_HALVINGS} times did not converge the field"


def _planned_dt(predictor: object, name: str, tolerance: float, duration: float, measure: str,
                limit: float | None, omega: float, check: Callable[[], None]
                ) -> tuple[float, bool]:
    """``predicted_dt`` in the chosen measure; for ``BOTH`` the smaller of the two steps."""
    if measure != BOTH:
        return predicted_dt(predictor, name, tolerance, duration, measure, limit, omega, check)
    field = predicted_dt(predictor, name, tolerance, duration, "field", limit, omega, check)
    energy = predicted_dt(predictor, name, tolerance, duration, "energy", limit, omega, check)
    return min(field[0], energy[0]), field[1] and energy[1]


def choose(
    scene: sim.Scene, tolerance: float, measure: str | None = None,
    integrators: Sequence[str] | None = None, duration: float | None = None,
    map_runs: MapRuns = serial_map, progress: Progress | None = None, threads: int = 1,
    stop: Callable[[], bool] | None = None,
) -> Choice:
    """The cheapest verified setting meeting ``tolerance`` (see the module docstring).

    ``measure`` "field" or "energy" checks that error alone (None: both, the field error where a
    reference is affordable); ``duration`` (s) defaults to the scene's; ``map_runs`` carries out
    each batch of runs; ``threads`` the threads each run's compiled sweeps use; ``stop`` is
    looked at between runs and within each run (about ten times a second): once it returns
    True, ``ChoiceCancelled`` is raised."""
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"the tolerance must be a positive number, got {tolerance!r}")
    if measure is not None and measure not in MEASURES:
        raise ValueError(f"unknown error measure {measure!r}; choose one of: {', '.join(MEASURES)}")
    duration = float(duration if duration is not None else scene.duration)
    names = candidate_integrators(scene, integrators)
    progress = _Stoppable(progress or _Silent(), stop)
    progress.finished(0.0, "planning: the normal modes")
    predictor = predictor_or_none(scene)
    costs = {}
    for name in dict.fromkeys([*names, most_accurate(scene.model)]):
        progress.finished(0.0, f"planning: timing {name}")
        costs[name] = step_seconds(scene, name, threads)
    run = _Runner(map_runs, progress, costs, stop if map_runs is serial_map else None)
    note = ""
    reference = None
    reference_now = None
    reference_runs: list[RunOutcome] = []
    found = reference_fields(scene, duration, tolerance, run, threads,
                             None if measure == "field" else REFERENCE_BUDGET_SECONDS,
                             predictor, costs[most_accurate(scene.model)])
    if isinstance(found, str):
        if measure == "field":
            raise ValueError(f"no field error on this scene: {found}; use --error energy")
        note = f"the energy error alone is used, the field error is not measured: {found}"
        measure = "energy"
    else:
        reference_now, reference, reference_runs = found
        measure = measure or BOTH
    probe = sim.Simulation(scene)
    limits = {name: probe.stable_dt(name) for name in names}
    omega = highest_frequency(scene.model) or 1.0

    def measured(outcome: RunOutcome) -> Measured:
        task = outcome.task
        field = (run_field_error(outcome.fields, reference_now)
                 if outcome.fields is not None and reference_now is not None else None)
        if outcome.blew_up or outcome.abandoned:
            error = math.inf
        elif measure == BOTH:
            error = max(field if field is not None else math.inf, outcome.energy_error)
        else:
            error = field if measure == "field" else outcome.energy_error
        return Measured(task.integrator, task.dt, task.steps, task.duration, error,
                        outcome.energy_error, field, outcome.wall_seconds, outcome.blew_up,
                        error <= tolerance, task.role, outcome.abandoned)

    def task_at(name: str, dt: float, role: str, time_limit: float | None = None) -> RunTask:
        steps, dt = steps_for(duration, min(dt, duration))
        return RunTask(scene, name, dt, steps, role, threads, time_limit,
                       keep_fields=reference_now is not None)

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
        dt, reached = _planned_dt(predictor, name, tolerance, duration, measure, limits[name],
                                  omega, progress.check)
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
