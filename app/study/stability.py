"""Where each integrator stops being stable: bisection on real runs against the theoretical limit.

For each case (a scene) and integrator, ``measured_limit`` brackets and bisects the time step,
running the scene for a fixed number of steps at every trial dt.  A trial is *unstable* when

* ``sim.BlowUpError`` is raised (the simulation's own NaN / runaway detection), or
* the energy scale |kinetic| + |spring| grows beyond ``RUNAWAY`` times its initial value (or
  times the work gravity has done, which is what a sagging lattice may legitimately turn into
  motion and stretch); a geometrically nonlinear lattice can saturate instead of exploding, so
  this catches instabilities that ``BlowUpError`` (x1e6) does not, or
* the total energy grows at every one of ``CHECKPOINTS`` checkpoints (the slow, steady growth
  of explicit Euler and Heun on an undamped lattice, which never "explodes" in a short run).

A random perturbation of ``PERTURBATION`` spacings is added to every particle so that the fastest
mode, which sets the limit, is always present.  The theoretical limit is
``Simulation.stable_dt()`` (normal modes of the lattice linearised about rest).  A state that
becomes non-finite without a ``BlowUpError`` is recorded as ``silent_nan`` (a bug if it happens).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

import sim
from app.study.executor import serial
from sim.integrators.registry import describe
from sim.runtime.blowup import CHECKS_PER_RUN

ProgressCallback = Callable[[str], None]

RUNAWAY = 100.0
CHECKPOINTS = 20
PERTURBATION = 1e-6
WINDOW_SCAN = (0.9, 0.8, 0.7, 0.6, 0.5)
"""Fractions of the measured limit re-checked for unstable windows below it."""
GROWTH_FLOOR = 1e-9
"""Relative energy growth below which a monotonic rise counts as round-off, not instability."""


@dataclasses.dataclass(frozen=True)
class Case:
    """A scene to study, with a sentence saying what is extreme about it.  ``steps`` overrides
    the number of steps per trial (None: the study's default)."""

    name: str
    description: str
    scene: sim.Scene
    steps: int | None = None


def _grid(**overrides: Any) -> sim.Scene:
    return sim.scenes.build("grid", **overrides)


def _one_different_mass(ratio: float, heavy_one: bool) -> np.ndarray:
    """(8, 12) masses (kg) of the 12x8 grid: all 1 and the centre ``ratio`` (heavy_one), or all
    ``ratio`` and the centre 1."""
    masses = np.ones((8, 12)) if heavy_one else np.full((8, 12), float(ratio))
    masses[4, 6] = float(ratio) if heavy_one else 1.0
    return masses


def _crossing(displacement: tuple[float, float]) -> sim.Scene:
    """The grid with its centre particle dragged by ``displacement`` spacings (through or onto
    its neighbours: springs pass through zero length)."""
    scene = _grid()
    model = scene.model
    centre = (model.ny // 2) * model.nx + model.nx // 2
    positions = model.rest_positions.copy()
    positions[centre] += np.array(displacement) * model.spacing
    return dataclasses.replace(scene, initial_positions=positions)


def default_cases(names: Sequence[str] | None = None) -> list[Case]:
    """The extreme cases (all of them, or those named)."""
    builders: dict[str, tuple[str, Callable[[], sim.Scene], int | None]] = {
        "grid": ("12x8, k = 35 N/m, m = 1 kg, nonlinear springs (the baseline)", _grid, None),
        "grid-linear": ("the baseline with linearised springs", lambda: _grid(linear=True), None),
        "stiff": ("very stiff springs, k = 1e6 N/m", lambda: _grid(stiffness=1e6), None),
        "heavy-among-light-1e3": ("one 1000 kg particle among 1 kg ones",
                                  lambda: _grid(mass=_one_different_mass(1e3, True)), None),
        "heavy-among-light-1e6": ("one 1e6 kg particle among 1 kg ones",
                                  lambda: _grid(mass=_one_different_mass(1e6, True)), None),
        "light-among-heavy-1e3": ("one 1 kg particle among 1000 kg ones",
                                  lambda: _grid(mass=_one_different_mass(1e3, False)), None),
        "light-among-heavy-1e6": ("one 1 kg particle among 1e6 kg ones",
                                  lambda: _grid(mass=_one_different_mass(1e6, False)), None),
        "near-zero-tension": ("pre-tension almost zero, L = 0.999 a (transverse modes soft)",
                              lambda: _grid(rest_length=0.999), None),
        "strong-damping": ("dashpots c = 5 N s/m (every mode damped)",
                           lambda: _grid(damping=5.0), None),
        "over-damping": ("dashpots c = 50 N s/m (the fastest modes over-damped)",
                         lambda: _grid(damping=50.0), None),
        "strong-drag": ("drag 20 N s/m on every particle", lambda: _grid(drag=20.0), None),
        "strong-gravity": ("gravity 100 m/s^2 with dashpots c = 2: the lattice sags and stiffens",
                           lambda: _grid(gravity=100.0, damping=2.0), None),
        "drag-onto-neighbour": ("centre particle dragged exactly onto its neighbour "
                                "(a zero-length spring at t = 0)", lambda: _crossing((1.0, 0.0)),
                                None),
        "drag-across-neighbours": ("centre particle dragged 2.5 spacings, across two neighbours",
                                   lambda: _crossing((2.5, 0.3)), None),
        "1x1": ("a single particle held by four springs", lambda: sim.scenes.build("single"),
                None),
        "1x1000": ("one column of 1000 particles", lambda: _grid(nx=1, ny=1000), None),
        "682x383": ("the interference scene, 261,206 particles, pre-tensioned",
                    lambda: sim.scenes.build("interference"), 80),
    }
    chosen = list(builders) if not names else list(names)
    unknown = [name for name in chosen if name not in builders]
    if unknown:
        raise ValueError(
            f"unknown case(s) {', '.join(unknown)}; choose from: {', '.join(builders)}"
        )
    return [
        Case(name, builders[name][0], builders[name][1](), builders[name][2]) for name in chosen
    ]


@dataclasses.dataclass(frozen=True)
class Trial:
    """One run at one dt: ``stable``, why not (``reason``), and whether a NaN went unreported."""

    dt: float
    stable: bool
    reason: str
    silent_nan: bool = False


@dataclasses.dataclass(frozen=True)
class Limit:
    """Measured and theoretical stability limits of one integrator on one case.

    ``measured`` is the largest dt found stable (s), None if every dt tried was unstable (then
    ``smallest_tried`` says how far down the search went); ``theory`` is ``stable_dt()`` (None:
    no stable dt); ``ratio`` measured / theory; ``omega_max`` (rad/s) of the linearised lattice.
    ``unstable_below`` lists steps *below* ``measured`` that were nevertheless unstable: with
    nonlinear springs Verlet has resonance windows (near omega dt = sqrt 2, sqrt 3), so stability
    is not monotonic in dt and the bisection's answer is only the edge it converged to.
    """

    case: str
    integrator: str
    measured: float | None
    theory: float | None
    omega_max: float
    ratio: float | None
    trials: int
    smallest_tried: float
    silent_nan: bool
    first_failure: str
    wall_seconds: float
    unstable_below: list[float] = dataclasses.field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclasses.dataclass(frozen=True)
class StabilityStudy:
    cases: list[Case]
    limits: list[Limit]

    def limit(self, case: str, integrator: str) -> Limit:
        return next(
            item for item in self.limits if item.case == case and item.integrator == integrator
        )

    def as_dict(self) -> dict[str, Any]:
        return dict(
            cases={case.name: case.description for case in self.cases},
            limits=[limit.as_dict() for limit in self.limits],
        )


def perturbed(scene: sim.Scene, size: float = PERTURBATION, seed: int = 5) -> sim.Scene:
    """The scene with every particle moved by a random ``size`` spacings (excites every mode)."""
    rng = np.random.default_rng(seed)
    positions = scene.initial_positions + size * scene.model.spacing * rng.standard_normal(
        scene.initial_positions.shape
    )
    return dataclasses.replace(scene, initial_positions=positions)


def _energy_scale(simulation: sim.Simulation) -> float:
    model = simulation.model
    energy = simulation.energy()
    gravity_work = float(np.linalg.norm(model.gravity)) * float(model.masses.sum()) * model.spacing
    spring_scale = 0.5 * model.stiffness * (1e-3 * model.spacing) ** 2 * model.n_particles
    return max(abs(energy.kinetic) + abs(energy.potential), gravity_work, spring_scale)


def trial(scene: sim.Scene, integrator: str, dt: float, steps: int) -> Trial:
    """Run ``steps`` steps of ``integrator`` at ``dt`` and judge stability (see module doc)."""
    simulation = sim.Simulation(scene, integrator=integrator, dt=dt)
    scale = _energy_scale(simulation)
    energies = [simulation.energy().total]
    chunk = max(1, steps // CHECKPOINTS)
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        try:
            simulation.step(n)
        except sim.BlowUpError as error:
            return Trial(dt, False, f"BlowUpError at step {error.step}: {error.reason}")
        done += n
        if not simulation.state.is_finite():
            return Trial(dt, False, "non-finite state without BlowUpError", silent_nan=True)
        energy = simulation.energy()
        size = abs(energy.kinetic) + abs(energy.spring)
        allowed = RUNAWAY * max(scale, abs(energy.gravity))
        if size > allowed:
            return Trial(dt, False, f"energy ran away (x{size / scale:.3g}) by step {done}")
        energies.append(energy.total)
    rises = np.diff(energies)
    growth = (energies[-1] - energies[0]) / scale
    if np.all(rises > 0) and growth > GROWTH_FLOOR:
        return Trial(dt, False, f"energy grew at every checkpoint (+{growth:.3g} of its scale)")
    return Trial(dt, True, "")


def whole_run_trial(scene: sim.Scene, integrator: str, dt: float, steps: int = 0) -> Trial:
    """Run the scene as ``oscillators run`` does, unperturbed, over its whole duration at ``dt``
    (``steps`` is ignored), looking at it ``CHECKS_PER_RUN`` times: unstable only if the run stops
    (its own blow-up rule, a NaN).  This
    is the limit a user meets; for large motion (a sag under gravity, big displacements) it can
    be below the small-amplitude theory's."""
    simulation = sim.Simulation(scene, integrator=integrator, dt=dt)
    steps = max(1, math.ceil(scene.duration / dt - 1e-9))
    chunk = max(1, steps // CHECKS_PER_RUN)
    try:
        for done in range(0, steps, chunk):
            simulation.step(min(chunk, steps - done))
    except sim.BlowUpError as error:
        return Trial(dt, False, f"BlowUpError at step {error.step}: {error.reason}")
    if not simulation.state.is_finite():
        return Trial(dt, False, "non-finite state without BlowUpError", silent_nan=True)
    return Trial(dt, True, "")


Judge = Callable[[sim.Scene, str, float, int], Trial]


def measured_limit(
    scene: sim.Scene, integrator: str, guess: float, steps: int, precision: float = 0.005,
    smallest_fraction: float = 1e-4, progress: ProgressCallback | None = None,
    judge: Judge = trial,
) -> tuple[float | None, list[Trial]]:
    """Largest stable dt by bracketing around ``guess`` (s) then bisecting (geometric mean) until
    the bracket is narrower than ``precision`` (relative); ``judge`` runs one trial (``trial``:
    a short perturbed run; ``whole_run_trial``: the scene's own run).  Returns (dt or None,
    trials)."""
    trials: list[Trial] = []

    def stable(dt: float) -> bool:
        if progress:
            progress(f"{integrator} dt={dt:.4g}")
        result = judge(scene, integrator, dt, steps)
        trials.append(result)
        return result.stable

    if stable(guess):
        low, high = guess, guess * 1.5
        while stable(high):
            low, high = high, high * 1.5
            if high > 1e3 * guess:
                return low, trials
    else:
        # step down gently first (finds the top edge, not the bottom of a resonance window),
        # then by halves (Euler and Heun may be unstable at every dt)
        high, low = guess, guess * 0.95
        tries = 1
        while not stable(low):
            tries += 1
            high, low = low, low * (0.95 if tries <= 8 else 0.5)
            if low < smallest_fraction * guess:
                return None, trials
    while high / low - 1 > precision:
        middle = math.sqrt(low * high)
        if stable(middle):
            low = middle
        else:
            high = middle
    return low, trials


SPLITTING_METHODS = tuple(d.name for d in sim.integrators.descriptions()
                          if d.splitting is not None)
"""The splitting methods: studied on the cases they apply to."""


def stability_study(
    cases: Sequence[Case], integrators: Sequence[str] | None = None, steps: int = 400,
    precision: float = 0.005, progress: ProgressCallback | None = None,
    executor: Any = None, whole_run: bool = False,
) -> StabilityStudy:
    """Measured against theoretical stability limits for every case and integrator.  Each
    (case, integrator) is one independent run of ``executor`` (``app.study.executor``; default
    serial in this process); ``progress`` is called as each completes.  ``whole_run``: each
    trial is the scene's own run over its duration (``whole_run_trial``), not a short perturbed
    one."""
    names = [sim.integrators.check_integrator_name(n)
             for n in (integrators or sim.integrators.names(kernel_only=True)
                       + SPLITTING_METHODS)]
    # each integrator on the cases it applies to (splitting methods: undamped, unforced)
    tasks = [(case, name, case.steps or steps, precision, whole_run)
             for case in cases for name in names
             if sim.integrators.describe(name).reason_not_applicable(case.scene.model) is None]
    labels = [f"{task[0].name}: {task[1]}" for task in tasks]
    limits = (executor or serial()).map(case_limit, tasks, labels, progress)
    return StabilityStudy(list(cases), list(limits))


def case_limit(task: tuple[Case, str, int, float, bool]) -> Limit:
    """The measured limit of one (case, integrator, steps per trial, bisection precision, whole
    run)."""
    case, name, run_steps, precision, whole_run = task
    judge: Judge = whole_run_trial if whole_run else trial
    started = time.perf_counter()
    scene = case.scene if whole_run else perturbed(case.scene)
    stability = sim.Simulation(scene).stability(name)
    omega_max = stability.omega_max
    guess = stability.dt or (2.0 / omega_max if omega_max else 0.01)
    if not math.isfinite(guess):
        guess = 0.01
    measured, trials = measured_limit(scene, name, guess, run_steps, precision, judge=judge)
    below: list[float] = []
    if measured:
        for fraction in WINDOW_SCAN:
            check = judge(scene, name, fraction * measured, run_steps)
            trials.append(check)
            if not check.stable:
                below.append(check.dt)
    failures = [t.reason for t in trials if not t.stable]
    return Limit(
        case=case.name, integrator=name, measured=measured, theory=stability.dt,
        omega_max=omega_max,
        ratio=measured / stability.dt if measured and stability.dt else None,
        trials=len(trials), smallest_tried=min(t.dt for t in trials),
        silent_nan=any(t.silent_nan for t in trials),
        first_failure=failures[0] if failures else "",
        wall_seconds=time.perf_counter() - started, unstable_below=below,
    )


def format_report(study: StabilityStudy) -> str:
    """One line per case and integrator."""
    width = max([len("integrator"), *(len(limit.integrator) for limit in study.limits)])
    header = (f"{'case':24s} {'integrator':{width}s} {'omega_max':>10s} {'theory dt':>10s} "
              f"{'measured dt':>11s} {'ratio':>6s}  note")
    lines = [header, "-" * len(header)]
    for limit in study.limits:
        theory = f"{limit.theory:.4g}" if limit.theory else "none"
        measured = (f"{limit.measured:.4g}" if limit.measured
                    else f"<{limit.smallest_tried:.2g}")
        ratio = f"{limit.ratio:.3f}" if limit.ratio else "-"
        note = "SILENT NaN" if limit.silent_nan else ""
        if limit.measured is None:
            note = (note + " unstable at every dt tried").strip()
        if limit.unstable_below:
            windows = ", ".join(f"{dt:.3g}" for dt in limit.unstable_below)
            note = (note + f" unstable again at {windows};").strip()
        if limit.measured is not None and limit.theory is None:
            note = (note + " growth too slow to see in the run (theory: none stable)").strip()
        lines.append(f"{limit.case:24s} {limit.integrator:{width}s} {limit.omega_max:10.4g} "
                     f"{theory:>10s} {measured:>11s} {ratio:>6s}  {note}")
    lines.append("")
    lines.append("theory: Simulation.stable_dt() (lattice linearised about rest); measured: "
                 "largest dt whose run stayed bounded (bisection); '<x': unstable down to x.")
    return "\n".join(lines)


def plot_stability(study: StabilityStudy, path: str) -> None:
    """Measured (filled) and theoretical (open) limits, omega_max * dt, per case; PNG at path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = [case.name for case in study.cases]
    names = list(dict.fromkeys(limit.integrator for limit in study.limits))
    figure, axis = plt.subplots(figsize=(max(8, 0.6 * len(cases) + 3), 5))
    width = 0.8 / max(1, len(names))
    for index, name in enumerate(names):
        x_measured, y_measured, x_theory, y_theory, x_none, y_none = [], [], [], [], [], []
        for position, case in enumerate(cases):
            limit = study.limit(case, name)
            x = position + (index - (len(names) - 1) / 2) * width
            scale = limit.omega_max or 1.0
            if limit.measured:
                x_measured.append(x)
                y_measured.append(limit.measured * scale)
            else:
                x_none.append(x)
                y_none.append(limit.smallest_tried * scale)
            if limit.theory and math.isfinite(limit.theory):
                x_theory.append(x)
                y_theory.append(limit.theory * scale)
        colour = tuple(channel / 255 for channel in describe(name).colour)
        axis.plot(x_measured, y_measured, "o", color=colour, label=f"{name} measured")
        axis.plot(x_theory, y_theory, "_", color=colour, markersize=14, markeredgewidth=2,
                  label=f"{name} theory")
        if x_none:
            axis.plot(x_none, y_none, "v", color=colour, markerfacecolor="none",
                      label=f"{name}: unstable down to")
    factors = [(describe(name).stability_factor, describe(name).short_label) for name in names]
    drawn = [(factor, label) for factor, label in factors
             if factor is not None and math.isfinite(factor)]
    for factor, _ in drawn:
        axis.axhline(factor, color="grey", linestyle=":", linewidth=1)
    axis.set_yscale("log")
    axis.set_xticks(range(len(cases)))
    axis.set_xticklabels(cases, rotation=40, ha="right", fontsize=8)
    axis.set_ylabel("omega_max * dt at the stability limit")
    undamped = ", ".join(f"{factor:.3g} ({label})" for factor, label in drawn)
    axis.set_title("largest stable step: measured (dots) vs theory (bars)"
                   + (f"; dotted: undamped limits {undamped}" if drawn else ""), fontsize=9)
    axis.legend(fontsize=7, ncol=2)
    axis.grid(True, which="both", axis="y", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
