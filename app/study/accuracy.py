"""Work against precision: each integrator over a range of steps, error at time T, wall time.

``accuracy_study(scene, integrators, dts, until, tolerance)`` runs every (integrator, dt) on the
scene from its initial state to time T (``accuracy_runs``) and measures its error, energy drift,
phase error and wall time against a reference solution (``accuracy_reference``: exact normal modes
for small linearised lattices, else the most accurate integrator with a Richardson estimate of
its own error).

The compiled integrators run in every precision of ``precisions`` (default float64 and float32:
float32's rounding sets an error floor, and it is faster); orders, the predicted dt and the
recommendation come from the float64 runs.

The recommendation for a tolerance is the fastest measured configuration whose error plus the
reference's own error is within the tolerance; the largest dt each integrator could afford is
also predicted from its measured convergence order, *run*, and kept only if it meets the tolerance.
An integrator without time-step error that applies to the scene (``kernel`` False in
``sim.integrators.registry``, the exact normal-mode solver of linear scenes) is run once for comparison.
``accuracy_report`` shows the result as text and a picture.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

import sim
from app.study import linear
from app.study.accuracy_reference import (
    Reference,
    initial_state,
    normal_modes_or_none,
    reference_solution,
)
from app.study.accuracy_runs import Measurer, Run, jsonable, precisions_of, warm_up
from app.study.executor import serial
from sim.integrators.registry import FORCE_EVALUATIONS, ORDERS, describe, descriptions, most_accurate
from sim.theory.observables import highest_frequency

ProgressCallback = Callable[[str], None]


@dataclasses.dataclass(frozen=True)
class Recommendation:
    """The fastest configuration that met ``tolerance`` (None fields when none did)."""

    tolerance: float
    integrator: str | None
    dt: float | None
    wall_seconds: float | None
    error: float | None
    reason: str

    def as_dict(self) -> dict[str, Any]:
        return jsonable(dataclasses.asdict(self))


@dataclasses.dataclass(frozen=True)
class AccuracyStudy:
    """Everything ``accuracy_study`` measured.  ``orders`` maps integrator -> measured
    convergence order (None if too few usable points); ``limits`` integrator -> stable dt (s)."""

    scene: str
    description: str
    until: float
    omega_max: float
    limits: dict[str, float | None]
    reference: Reference
    runs: list[Run]
    orders: dict[str, float | None]
    recommendation: Recommendation
    exact: Run | None = None
    """The exact normal-mode integrator on the same scene (linear scenes only): no time-step
    error, so it is the reference line of the picture, with its own cost."""

    def runs_of(
        self, integrator: str, refined: bool | None = False, precision: str = "float64"
    ) -> list[Run]:
        """Runs of one integrator in one precision sorted by dt (only the planned ones unless
        refined is None)."""
        chosen = [
            run for run in self.runs
            if run.integrator == integrator and (refined is None or run.refined == refined)
            and run.precision == precision
        ]
        return sorted(chosen, key=lambda run: run.dt)

    def as_dict(self) -> dict[str, Any]:
        reference = dataclasses.asdict(self.reference)
        del reference["positions"], reference["velocities"]
        return jsonable(
            dict(
                scene=self.scene, description=self.description, until=self.until,
                omega_max=self.omega_max, limits=self.limits, reference=reference,
                runs=[run.as_dict() for run in self.runs], orders=self.orders,
                recommendation=self.recommendation.as_dict(),
            )
        )


# --- the study ------------------------------------------------------------------------------------


def default_dts(scene: sim.Scene) -> list[float]:
    """Eight steps from 0.9 of the undamped stability limit of the most accurate integrator
    (RK4: 2 sqrt 2 / omega_max) down to 1/400 of it."""
    omega_max = highest_frequency(scene.model) or 1.0
    factor = describe(most_accurate(scene.model)).stability_factor
    limit = (factor if factor is not None and math.isfinite(factor) else 1.0) / omega_max
    return [limit * fraction for fraction in (0.9, 0.5, 0.25, 0.1, 0.05, 0.025, 0.01, 0.0025)]


SWEEP_BUDGET_SECONDS = 30.0
"""Largest estimated cost (s, the registry's ``seconds_per_step``) of the default sweep with its
reference: on a large lattice the smallest default steps are left out to stay within it."""
SWEEP_FRACTIONS_KEPT = 4
"""Default steps kept whatever they cost (enough for a convergence order)."""


def budgeted_dts(scene: sim.Scene, until: float, integrators: Sequence[str],
                 precisions: Sequence[str], budget: float = SWEEP_BUDGET_SECONDS) -> list[float]:
    """``default_dts`` from the largest down, as many as fit the estimated ``budget`` (s) with
    the numerical reference (RK4 at the smallest dt / 4 and / 2: 6 times its steps), at least
    ``SWEEP_FRACTIONS_KEPT``; all eight on small lattices."""
    n = scene.model.n_particles
    reference = describe(most_accurate(scene.model)).seconds_per_step(n)
    kept: list[float] = []
    spent = 0.0
    for dt in default_dts(scene):
        steps = until / dt
        cost = sum(steps * describe(name).seconds_per_step(n) * len(precisions_of(name, precisions))
                   for name in integrators)
        if len(kept) >= SWEEP_FRACTIONS_KEPT and spent + cost + 6 * steps * reference > budget:
            break
        spent += cost
        kept.append(dt)
    return kept


def default_until(scene: sim.Scene) -> float:
    """Five periods of the dominant normal mode (or 20 periods of the fastest one)."""
    try:
        modes = normal_modes_or_none(scene)
        if modes is None:
            raise linear.NotExactError("no modes")
        positions, velocities = initial_state(scene)
        rest = scene.model.rest_positions.T.reshape(positions.shape)
        dominant = modes.dominant((positions - rest).ravel(), velocities.ravel())
        omega = float(modes.omega[dominant])
        if omega > 0:
            return 5 * 2 * math.pi / omega
    except linear.NotExactError:
        pass
    omega_max = highest_frequency(scene.model) or 1.0
    return 20 * 2 * math.pi / omega_max


def convergence_order(
    runs: Sequence[Run], smallest: float = 1e-10, largest: float = 1e-2, floor: float = 0.0
) -> float | None:
    """Least-squares slope of log(error) against log(dt) over the usable runs whose error lies in
    [max(smallest, 10 * floor), largest] (the asymptotic range, above round-off and the
    reference's own error).  None with fewer than two such runs."""
    low = max(smallest, 10 * floor)
    points = [
        (math.log(run.dt), math.log(run.error))
        for run in runs
        if run.usable and low <= run.error <= largest
    ]
    if len(points) < 2:
        return None
    x, y = np.array(points).T
    slope, _ = np.polyfit(x, y, 1)
    return float(slope)


def accuracy_study(
    scene: sim.Scene,
    integrators: Sequence[str] = sim.INTEGRATORS,
    dts: Sequence[float] | Mapping[str, Sequence[float]] | None = None,
    until: float | None = None,
    tolerance: float = 1e-3,
    refine: bool = True,
    progress: ProgressCallback | None = None,
    minimum_seconds: float = 0.02,
    precisions: Sequence[str] = ("float64", "float32"),
    executor: Any = None,
) -> AccuracyStudy:
    """Measure error and wall time of every integrator at every dt on ``scene`` (see module doc).

    ``dts`` is a list of steps (s) for all integrators, or a mapping integrator -> list; default
    ``budgeted_dts`` (``default_dts`` within ``SWEEP_BUDGET_SECONDS``).  ``until`` is T (s),
    default ``default_until``.  ``tolerance`` is the target
    relative position error of the recommendation.  ``progress`` is called with a short label
    before every run (the CLI drives a progress bar with it).  ``precisions``: the compiled
    integrators run in each of them (float64 always; the others only show on the picture and in
    the table).  The runs at the given dts go through ``executor`` (``app.study.executor``:
    default serial in this process, or a Dask cluster), ``progress`` called as each completes.
    """
    integrators = [sim.integrators.check_integrator_name(name) for name in integrators]
    precisions = ["float64"] + [
        name for name in dict.fromkeys(
            sim.integrators.check_precision(p).__name__ for p in precisions
        ) if name != "float64"
    ]
    until = float(until) if until is not None else default_until(scene)
    if not (math.isfinite(until) and until > 0):
        raise ValueError(f"--until must be a positive, finite time in seconds, got {until}")
    if dts is None:
        dts = budgeted_dts(scene, until, integrators, precisions)
    plan = {
        name: sorted(float(dt) for dt in (dts[name] if isinstance(dts, Mapping) else dts))
        for name in integrators
    }
    bad = [dt for steps in plan.values() for dt in steps if not (math.isfinite(dt) and dt > 0)]
    if bad:
        raise ValueError(f"every dt must be a positive, finite time in seconds, got {bad[0]}")
    if not any(plan.values()):
        raise ValueError("give at least one dt")
    probe = sim.Simulation(scene)
    limits = {name: probe.stable_dt(name) for name in dict.fromkeys([*sim.INTEGRATORS,
                                                                      *integrators])}
    omega_max = highest_frequency(scene.model)
    smallest_dt = min(dt for steps in plan.values() for dt in steps)
    reference = reference_solution(scene, until, min(smallest_dt, until / 16), progress)
    executor = executor or serial()
    executor.prepare(warm_up, scene, integrators, precisions)
    modes = normal_modes_or_none(scene)
    measure = Measurer(scene, until, reference, limits, omega_max, modes, minimum_seconds)
    tasks = [(name, dt, precision) for name in integrators
             for precision in precisions_of(name, precisions) for dt in plan[name]]
    labels = [f"{name} dt={dt:.3g}{'' if precision == 'float64' else ' ' + precision}"
              for name, dt, precision in tasks]
    runs: list[Run] = executor.map(functools.partial(_measure_task, measure), tasks, labels,
                                   progress)
    orders = {
        name: convergence_order(
            [run for run in runs if run.integrator == name and run.precision == "float64"],
            floor=reference.error,
        )
        for name in integrators
    }
    if refine:
        for name in integrators:
            double = [run for run in runs if run.precision == "float64"]
            extra = _refined_run(name, double, orders[name], tolerance, reference.error, limits,
                                 measure, progress)
            if extra is not None:
                runs.append(extra)
    recommendation = recommend(
        [run for run in runs if run.precision == "float64"], tolerance, reference.error
    )
    exact = None
    solver = exact_solver(scene.model)
    if solver is not None:
        description = describe(solver)
        if progress:
            progress(f"{description.short_label} solver")
        exact = measure(solver, until, note=f"{description.label} (any dt)")
    return AccuracyStudy(
        scene=scene.name, description=scene.model.describe(), until=until, omega_max=omega_max,
        limits=limits, reference=reference, runs=runs, orders=orders,
        recommendation=recommendation, exact=exact,
    )


def _measure_task(measure: Measurer, task: tuple[str, float, str]) -> Run:
    """One run of the sweep: (integrator, dt, precision) measured by ``measure``."""
    name, dt, precision = task
    return measure(name, dt, precision=precision)


def exact_solver(model: sim.Model) -> str | None:
    """The first registered integrator without time-step error (not a compiled ``kernel``
    stepper) that applies to ``model``; None when there is none."""
    return next((description.name for description in descriptions()
                 if not description.kernel and description.reason_not_applicable(model) is None),
                None)


def _refined_run(
    name: str, runs: list[Run], order: float | None, tolerance: float, reference_error: float,
    limits: Mapping[str, float | None], measure: Measurer, progress: ProgressCallback | None,
) -> Run | None:
    """Predict the largest dt meeting the tolerance from the measured order and run it."""
    own = sorted((run for run in runs if run.integrator == name), key=lambda run: run.dt)
    passing = [run for run in own if run.usable and run.error + reference_error <= tolerance]
    if not passing or order is None or order <= 0.5:
        return None
    best = passing[-1]
    failing_above = [run.dt for run in own if run.dt > best.dt]
    target = 0.7 * tolerance - reference_error
    if target <= 0 or best.error <= 0:
        return None
    dt = best.dt * (target / best.error) ** (1.0 / order)
    ceiling = min(failing_above) if failing_above else math.inf
    if limits.get(name):
        ceiling = min(ceiling, 0.95 * limits[name])
    dt = min(dt, 0.98 * ceiling)
    if dt <= best.dt * 1.05:
        return None
    if progress:
        progress(f"{name} dt={dt:.3g} (predicted for the tolerance)")
    run = measure(name, dt, refined=True, note="dt predicted from the measured order")
    return run


def recommend(
    runs: Sequence[Run], tolerance: float, reference_error: float = 0.0
) -> Recommendation:
    """Fastest run whose error plus the reference's own error is within ``tolerance``."""
    meeting = [run for run in runs if run.usable and run.error + reference_error <= tolerance]
    if not meeting:
        best = min((run for run in runs if run.usable), key=lambda run: run.error, default=None)
        closest = f"; the most accurate run reached {best.error:.3g}" if best else ""
        return Recommendation(
            tolerance, None, None, None, None,
            f"no configuration reached a relative error of {tolerance:g}{closest}; "
            "try smaller --dts",
        )
    fastest = min(meeting, key=lambda run: run.wall_seconds)
    label = describe(fastest.integrator).label
    return Recommendation(
        tolerance, fastest.integrator, fastest.dt, fastest.wall_seconds, fastest.error,
        f"{label} at dt = {fastest.dt:.4g} s reaches {fastest.error:.3g} <= {tolerance:g} "
        f"in {fastest.wall_seconds * 1e3:.3g} ms of wall time for the whole run to "
        f"T = {fastest.steps * fastest.dt:.3g} s ({FORCE_EVALUATIONS[fastest.integrator]} force "
        f"evaluation(s) per step, order {ORDERS[fastest.integrator]})",
    )
