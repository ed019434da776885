"""Work against precision: each integrator over a range of steps, error at time T, wall time.

``accuracy_study(scene, integrators, dts, until, tolerance)`` runs every (integrator, dt) on the
scene from its initial state to time T and measures, against a reference solution:

* ``error``: the largest particle position error at T, relative to the size of the initial
  disturbance (max |r0 - r_rest| over particles; the spacing if the scene starts at rest);
* ``energy_drift``: change of the energy balance (total + dissipated) over the run, relative to
  the initial energy scale (|kinetic| + |potential|, or the work gravity can do);
* ``phase_error``: phase error (rad) of the dominant normal mode of the linearised lattice;
* ``wall_seconds`` of ``Simulation.step`` (compilation excluded, short runs repeated).

The compiled integrators run in every precision of ``precisions`` (default float64 and float32:
float32's rounding sets an error floor, and it is faster); orders, the predicted dt and the
recommendation come from the float64 runs.

Reference: the exact normal-mode solution (``app.study.linear``) when the springs are linearised
(``--set linear=true``) and the lattice small; otherwise RK4 at h = (smallest dt) / 8, with its own
error estimated by Richardson extrapolation from the run at 2 h: |r_h - r_2h| / (2^4 - 1).

The recommendation for a tolerance is the fastest measured configuration whose error plus the
reference's own error is within the tolerance; the largest dt each integrator could afford is
also predicted from its measured convergence order, *run*, and kept only if it meets the tolerance.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

import sim
from app.study import linear
from sim.integrators import FORCE_EVALUATIONS, ORDERS

ProgressCallback = Callable[[str], None]

REFERENCE_STEP_LIMIT = 2_000_000
"""Most RK4 steps spent on a numerical reference solution."""


@dataclasses.dataclass(frozen=True)
class Reference:
    """The solution the runs are compared with.

    ``kind`` is "exact normal modes" or "RK4 (Richardson)"; ``positions`` / ``velocities`` are
    (dim, ny, nx) arrays (m, m/s) at time ``until``; ``error`` is the reference's own relative
    position error (0 for the exact solution, the Richardson estimate otherwise); ``dt`` the RK4
    step (None when exact); ``wall_seconds`` what it cost.
    """

    kind: str
    positions: np.ndarray
    velocities: np.ndarray
    error: float
    dt: float | None
    wall_seconds: float
    note: str = ""


@dataclasses.dataclass(frozen=True)
class Run:
    """One (integrator, dt) measurement.  ``error`` is relative (see the module docstring); it is
    ``math.inf`` when the run blew up.  ``dt_over_limit`` is dt / the integrator's stability limit
    (None when the integrator has no stable step); ``omega_dt`` is omega_max * dt."""

    integrator: str
    dt: float
    steps: int
    dt_over_limit: float | None
    omega_dt: float
    wall_seconds: float
    steps_per_second: float
    error: float
    position_error: float
    energy_drift: float
    phase_error: float | None
    blew_up: bool
    refined: bool = False
    note: str = ""
    precision: str = "float64"
    """Precision of the state and the kernels' arithmetic ("float64" or "float32")."""

    @property
    def usable(self) -> bool:
        return not self.blew_up and math.isfinite(self.error)

    def as_dict(self) -> dict[str, Any]:
        return _jsonable(dataclasses.asdict(self))


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
        return _jsonable(dataclasses.asdict(self))


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
        return _jsonable(
            dict(
                scene=self.scene, description=self.description, until=self.until,
                omega_max=self.omega_max, limits=self.limits, reference=reference,
                runs=[run.as_dict() for run in self.runs], orders=self.orders,
                recommendation=self.recommendation.as_dict(),
            )
        )


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {key: _jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(item) for item in value]
    if isinstance(value, (float, np.floating)):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


# --- measuring one run --------------------------------------------------------------------------


def _initial_state(scene: sim.Scene) -> tuple[np.ndarray, np.ndarray]:
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


def _energy_scale(simulation: sim.Simulation, scene: sim.Scene) -> float:
    energy = simulation.energy()
    scale = abs(energy.kinetic) + abs(energy.potential)
    if scale == 0.0:  # a scene starting at rest: the work gravity can do over one spacing
        model = scene.model
        scale = float(np.linalg.norm(model.gravity)) * float(model.masses.sum()) * model.spacing
    return scale or 1.0


def _position_error(positions: np.ndarray, reference: np.ndarray) -> float:
    """Largest distance (m) between a particle and its reference position; arrays (dim, ny, nx)."""
    return float(np.sqrt(((positions - reference) ** 2).sum(axis=0)).max())


def warm_up(
    scene: sim.Scene, integrators: Iterable[str], precisions: Iterable[str] = ("float64",)
) -> None:
    """Compile the kernels the runs will use, so compilation is not timed."""
    for name in integrators:
        for precision in _precisions_of(name, precisions):
            simulation = sim.Simulation(scene, integrator=name, dt=1e-6, precision=precision)
            simulation.step(1)


def _precisions_of(integrator: str, precisions: Iterable[str]) -> list[str]:
    """The precisions an integrator runs in: all of them for compiled kernels, else float64."""
    if sim.integrators.describe(integrator).kernel:
        return list(precisions)
    return ["float64"]


def timed_run(
    scene: sim.Scene, integrator: str, dt: float, steps: int, minimum_seconds: float = 0.02,
    precision: str = "float64",
) -> tuple[sim.Simulation, float, bool]:
    """Run ``steps`` steps from the scene's initial state; returns (simulation at the end,
    wall seconds of one run, blew up).  A run is repeated from the start (the stepping is
    deterministic) until ``minimum_seconds`` have been spent, at least 3 times if it takes less
    than 0.2 s, and the fastest repeat is returned (the least disturbed by other processes)."""
    times: list[float] = []
    while True:
        simulation = sim.Simulation(scene, integrator=integrator, dt=dt, precision=precision)
        simulation.chunk_steps = max(32, min(steps, 4096))
        started = time.perf_counter()
        try:
            simulation.step(steps)
        except sim.BlowUpError:
            return simulation, time.perf_counter() - started, True
        times.append(time.perf_counter() - started)
        enough = sum(times) >= minimum_seconds and (len(times) >= 3 or times[0] >= 0.2)
        if enough or len(times) >= 200:
            return simulation, min(times), False


# --- reference ----------------------------------------------------------------------------------


def reference_solution(
    scene: sim.Scene, until: float, smallest_dt: float, progress: ProgressCallback | None = None
) -> Reference:
    """Exact normal modes when possible, else RK4 at smallest_dt / 8 (checked against / 4)."""
    positions, velocities = _initial_state(scene)
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
    steps = max(16, math.ceil(until / (smallest_dt / 8)))
    steps += steps % 2
    steps = min(steps, REFERENCE_STEP_LIMIT)
    steps += steps % 2
    fine_dt = until / steps
    # The coarse half of the Richardson pair runs at 2 fine_dt; when the step count is capped
    # that can exceed RK4's stability limit, and the reference would blow up.
    rk4_limit = sim.Simulation(scene).stable_dt("rk4")
    if rk4_limit and 2 * fine_dt > rk4_limit:
        longest = REFERENCE_STEP_LIMIT * rk4_limit / 2
        raise ValueError(
            f"--until {until:g} s is too long for a numerical reference: it would need more "
            f"than {REFERENCE_STEP_LIMIT} RK4 steps to stay below RK4's stable dt "
            f"({rk4_limit:.3g} s); use --until {longest:.3g} or less "
            "(a small scene with --set linear=true uses the exact solution instead)"
        )
    results = []
    for n, dt in ((steps // 2, 2 * fine_dt), (steps, fine_dt)):
        if progress:
            progress(f"reference: RK4, {n} steps of {dt:.3g} s")
        simulation = sim.Simulation(scene, integrator="rk4", dt=dt)
        simulation.chunk_steps = 4096
        try:
            simulation.step(n)
        except sim.BlowUpError as error:
            raise ValueError(
                f"the RK4 reference blew up at dt = {dt:.3g} s ({error}); "
                "use a shorter --until or smaller --dts"
            ) from error
        results.append((simulation.state.positions.copy(), simulation.state.velocities.copy()))
    (coarse, _), (fine, fine_velocities) = results
    estimate = _position_error(fine, coarse) / (2**4 - 1) / disturbance_scale(scene)
    return Reference(
        "RK4 (Richardson)", fine, fine_velocities, estimate, fine_dt,
        time.perf_counter() - started, note=f"not exact: {reason}",
    )


# --- the study ----------------------------------------------------------------------------------


def default_dts(scene: sim.Scene) -> list[float]:
    """Eight steps from 0.9 of the RK4 limit (2 sqrt 2 / omega_max) down to 1/400 of it."""
    omega_max = sim.Simulation(scene).stability("verlet").omega_max or 1.0
    rk4_limit = 2 * math.sqrt(2) / omega_max
    return [rk4_limit * fraction for fraction in (0.9, 0.5, 0.25, 0.1, 0.05, 0.025, 0.01, 0.0025)]


def default_until(scene: sim.Scene) -> float:
    """Five periods of the dominant normal mode (or 20 periods of the fastest one)."""
    try:
        modes = _modes_or_none(scene)
        if modes is None:
            raise linear.NotExactError("no modes")
        positions, velocities = _initial_state(scene)
        rest = scene.model.rest_positions.T.reshape(positions.shape)
        dominant = modes.dominant((positions - rest).ravel(), velocities.ravel())
        omega = float(modes.omega[dominant])
        if omega > 0:
            return 5 * 2 * math.pi / omega
    except linear.NotExactError:
        pass
    omega_max = sim.Simulation(scene).stability("verlet").omega_max or 1.0
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
) -> AccuracyStudy:
    """Measure error and wall time of every integrator at every dt on ``scene`` (see module doc).

    ``dts`` is a list of steps (s) for all integrators, or a mapping integrator -> list; default
    ``default_dts``.  ``until`` is T (s), default ``default_until``.  ``tolerance`` is the target
    relative position error of the recommendation.  ``progress`` is called with a short label
    before every run (the CLI drives a progress bar with it).  ``precisions``: the compiled
    integrators run in each of them (float64 always; the others only show on the picture and in
    the table).
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
        dts = default_dts(scene)
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
    limits = {name: probe.stable_dt(name) for name in sim.INTEGRATORS}
    omega_max = probe.stability("verlet").omega_max
    smallest_dt = min(dt for steps in plan.values() for dt in steps)
    reference = reference_solution(scene, until, min(smallest_dt, until / 16), progress)
    warm_up(scene, integrators, precisions)
    modes = _modes_or_none(scene)
    measure = _Measurer(scene, until, reference, limits, omega_max, modes, minimum_seconds)
    runs: list[Run] = []
    for name in integrators:
        for precision in _precisions_of(name, precisions):
            for dt in plan[name]:
                if progress:
                    suffix = "" if precision == "float64" else f" {precision}"
                    progress(f"{name} dt={dt:.3g}{suffix}")
                runs.append(measure(name, dt, precision=precision))
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
    if "exact" in sim.integrators.names(scene.model):
        if progress:
            progress("exact solver")
        exact = measure("exact", until, note="exact normal-mode solver (any dt)")
    return AccuracyStudy(
        scene=scene.name, description=scene.model.describe(), until=until, omega_max=omega_max,
        limits=limits, reference=reference, runs=runs, orders=orders,
        recommendation=recommendation, exact=exact,
    )


def _modes_or_none(scene: sim.Scene) -> linear.NormalModes | None:
    model = scene.model if scene.model.linear else scene.model.replace(linear=True)
    try:
        return linear.normal_modes(model)
    except linear.NotExactError:
        return None


class _Measurer:
    """Runs one configuration and compares it with the reference."""

    def __init__(self, scene, until, reference, limits, omega_max, modes, minimum_seconds):
        self.scene = scene
        self.until = until
        self.reference = reference
        self.limits = limits
        self.omega_max = omega_max
        self.modes = modes
        self.minimum_seconds = minimum_seconds
        self.scale = disturbance_scale(scene)
        self.rest = scene.model.rest_positions.T.reshape(reference.positions.shape)
        self.dominant = None
        if modes is not None:
            positions, velocities = _initial_state(scene)
            self.dominant = modes.dominant((positions - self.rest).ravel(), velocities.ravel())
            self.reference_phase = modes.phase(
                self.dominant, (reference.positions - self.rest).ravel(),
                reference.velocities.ravel(),
            )

    def __call__(
        self, integrator: str, dt: float, refined: bool = False, note: str = "",
        precision: str = "float64",
    ) -> Run:
        steps = max(1, round(self.until / dt))
        dt = self.until / steps
        start = sim.Simulation(self.scene, integrator=integrator, dt=dt, precision=precision)
        energy_scale = _energy_scale(start, self.scene)
        balance_start = start.energy().balance
        simulation, wall, blew_up = timed_run(
            self.scene, integrator, dt, steps, self.minimum_seconds, precision
        )
        limit = self.limits.get(integrator)
        ratio = dt / limit if limit else None
        common = dict(
            integrator=integrator, dt=dt, steps=steps, dt_over_limit=ratio,
            omega_dt=self.omega_max * dt, wall_seconds=wall, refined=refined,
            precision=precision,
        )
        if blew_up:
            return Run(
                **common, steps_per_second=simulation.step_count / wall if wall > 0 else 0.0,
                error=math.inf, position_error=math.inf, energy_drift=math.inf, phase_error=None,
                blew_up=True, note=(note + "; " if note else "") + "blew up",
            )
        positions = simulation.state.positions.astype(float)
        position_error = _position_error(positions, self.reference.positions)
        drift = (simulation.energy().balance - balance_start) / energy_scale
        phase_error = None
        if self.dominant is not None:
            phase = self.modes.phase(
                self.dominant, (positions - self.rest).ravel(),
                simulation.state.velocities.astype(float).ravel(),
            )
            phase_error = float(np.angle(np.exp(1j * (phase - self.reference_phase))))
        return Run(
            **common, steps_per_second=steps / wall if wall > 0 else math.inf,
            error=position_error / self.scale, position_error=position_error,
            energy_drift=float(drift), phase_error=phase_error, blew_up=False, note=note,
        )


def _refined_run(
    name: str, runs: list[Run], order: float | None, tolerance: float, reference_error: float,
    limits: Mapping[str, float | None], measure: _Measurer, progress: ProgressCallback | None,
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
    label = sim.integrators.LABELS[fastest.integrator]
    return Recommendation(
        tolerance, fastest.integrator, fastest.dt, fastest.wall_seconds, fastest.error,
        f"{label} at dt = {fastest.dt:.4g} s reaches {fastest.error:.3g} <= {tolerance:g} "
        f"in {fastest.wall_seconds * 1e3:.3g} ms of wall time for the whole run to "
        f"T = {fastest.steps * fastest.dt:.3g} s ({FORCE_EVALUATIONS[fastest.integrator]} force "
        f"evaluation(s) per step, order {ORDERS[fastest.integrator]})",
    )


# --- presentation -------------------------------------------------------------------------------


def _format(value: float | None, spec: str = ".3g") -> str:
    if value is None:
        return "-"
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return format(value, spec)


def format_table(study: AccuracyStudy) -> str:
    """The runs as a fixed-width text table."""
    header = (
        f"{'integrator':10s} {'precision':9s} {'dt (s)':>10s} {'dt/limit':>8s} {'wall (s)':>9s} "
        f"{'steps/s':>9s} {'error':>9s} {'energy':>9s} {'phase':>9s}"
    )
    lines = [header, "-" * len(header)]
    for run in sorted(study.runs, key=lambda run: (run.integrator, run.precision, run.dt)):
        marker = " *" if run.refined else ""
        lines.append(
            f"{run.integrator:10s} {run.precision:9s} {run.dt:10.4g} {_format(run.dt_over_limit, '.3f'):>8s} "
            f"{run.wall_seconds:9.3g} {run.steps_per_second:9.3g} "
            f"{'blew up' if run.blew_up else _format(run.error):>9s} "
            f"{_format(run.energy_drift):>9s} {_format(run.phase_error):>9s}{marker}"
        )
    return "\n".join(lines)


def format_report(study: AccuracyStudy) -> str:
    """Table, orders, reference and recommendation as text."""
    reference = study.reference
    ref_text = (
        f"reference: {reference.kind}"
        + (f", dt = {reference.dt:.3g} s, own error ~ {reference.error:.2g}"
           if reference.dt else "")
        + (f" ({reference.note})" if reference.note else "")
    )
    limits = ", ".join(
        f"{name} {_format(limit, '.4g')}" for name, limit in study.limits.items()
    )
    orders = ", ".join(
        f"{name} {_format(order, '.2f')} (theory {ORDERS[name]})"
        for name, order in study.orders.items()
    )
    return "\n".join(
        [
            f"scene {study.scene}: {study.description}",
            f"error at T = {study.until:.4g} s; omega_max = {study.omega_max:.4g} rad/s; "
            f"stable dt: {limits}",
            ref_text,
            "error = max particle position error / initial disturbance; energy = relative drift "
            "of kinetic + potential + dissipated; phase = dominant mode (rad)",
            "",
            format_table(study),
            "(* dt predicted from the measured order to just meet the tolerance)",
            "",
            f"measured convergence orders: {orders}",
            f"recommendation for tolerance {study.recommendation.tolerance:g}: "
            f"{study.recommendation.reason}",
        ]
    )


def plot_work_precision(study: AccuracyStudy, path: str, ax=None) -> None:
    """Error against wall time, log-log, one curve per integrator; saved as a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    single_precisions = sorted({run.precision for run in study.runs} - {"float64"})
    for name in study.orders:
        runs = [run for run in study.runs_of(name, refined=None) if run.usable and run.error > 0]
        if not runs:
            continue
        order = study.orders[name]
        label = f"{name} (order {order:.2f})" if order is not None else name
        lines = left.loglog([r.wall_seconds for r in runs], [r.error for r in runs], "o-",
                            label=label)
        colour = lines[0].get_color()
        right.loglog([r.dt for r in runs], [r.error for r in runs], "o-", color=colour,
                     label=label)
        for precision in single_precisions:  # hollow markers, dashed: same integrator, float32
            other = [run for run in study.runs_of(name, refined=None, precision=precision)
                     if run.usable and run.error > 0]
            if not other:
                continue
            style = dict(color=colour, linestyle="--", marker="o", markerfacecolor="none",
                         label=f"{name} {precision}")
            left.loglog([r.wall_seconds for r in other], [r.error for r in other], **style)
            right.loglog([r.dt for r in other], [r.error for r in other], **style)
    tolerance = study.recommendation.tolerance
    for axis in (left, right):
        axis.axhline(tolerance, color="grey", linestyle=":", label=f"tolerance {tolerance:g}")
        if study.reference.error > 0:
            axis.axhline(study.reference.error, color="grey", linestyle="--",
                         label="reference's own error")
        axis.set_ylabel("relative position error at T")
        axis.grid(True, which="both", alpha=0.3)
    if study.recommendation.integrator:
        left.plot([study.recommendation.wall_seconds], [study.recommendation.error], "k*",
                  markersize=14, label="recommended")
    if study.exact is not None and not study.exact.blew_up:
        left.axvline(study.exact.wall_seconds, color="black", linestyle="-.",
                     label=f"exact solver: {study.exact.wall_seconds * 1e3:.2g} ms, "
                     f"error {study.exact.error:.0e} (any dt)")
    left.set_xlabel("wall time (s)")
    left.set_title("work-precision")
    right.set_xlabel("dt (s)")
    right.set_title("convergence")
    left.legend(fontsize=8)
    figure.suptitle(f"{study.scene}: {study.description}; T = {study.until:.3g} s", fontsize=9)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
