"""What ``choose`` plans before it runs anything: the step each integrator should need, from the
normal-mode prediction (``sim.theory.prediction``), and what a step costs, measured.

``predicted_dt`` searches the prediction of the linearised lattice (exact for a linear undamped
scene, an estimate otherwise) for the largest dt whose predicted error in the chosen measure is
at most ``AIM`` of the tolerance: from 0.9 of the stability limit (or 0.2 / omega_max without
one) it steps by the integrator's order, dt_next = dt (target / error)^(1/p), a few predictions
in all (each costs one pass over the modes: about a second on the 261,206-particle lattice).
``step_seconds`` times a few real steps of a scene in this process (the kernels compiled first),
so the planned cost of a run is steps x measured seconds per step: the progress bar's ETA is a
time, and a candidate that cannot beat the best verified setting is not started.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

import sim
from sim.integrators.registry import describe
from sim.model.lattice import ModelError
from sim.runtime.warming import prepare_reading
from sim.theory.observables import highest_frequency

AIM = 0.5
"""Fraction of the tolerance a candidate's predicted error aims at (room for the prediction's
own error on nonlinear scenes)."""
SEARCHES = 6
"""Most predictions per integrator in ``predicted_dt``."""
TIMING_SECONDS = 0.15
"""Least wall time (s) spent timing one integrator's steps."""


def predictor_or_none(scene: sim.Scene) -> object | None:
    """The normal-mode ``Predictor`` of the scene's initial state, None when the scene has none
    (a driver or absorbing layer, or modes too costly to compute)."""
    from sim.theory.prediction import predictor_for_scene

    try:
        return predictor_for_scene(scene.model, np.asarray(scene.initial_positions),
                                   np.asarray(scene.initial_velocities))
    except (ModelError, ValueError, MemoryError):
        return None


def predicted_error(predictor: object, integrator: str, dt: float, duration: float,
                    measure: str) -> float:
    """The predicted error of one setting in ``measure`` ("field" or "energy")."""
    prediction = predictor.predict(integrator, dt, duration)  # type: ignore[attr-defined]
    error = prediction.field_error if measure == "field" else abs(prediction.energy_error)
    return error if math.isfinite(error) else math.inf


def predicted_dt(predictor: object, integrator: str, tolerance: float, duration: float,
                 measure: str, limit: float | None, omega_max: float,
                 check: Callable[[], None] | None = None) -> tuple[float, bool]:
    """(dt, reached): the largest dt (s) predicted to keep the error within ``AIM`` of
    ``tolerance`` over ``duration`` (see the module docstring) and True; when no step is found
    in ``SEARCHES`` predictions, the last (smallest) step tried and False.  ``check`` is called
    before each prediction (it raises to stop: a cancelled choice)."""
    target = AIM * tolerance
    order = describe(integrator).order or 1
    ceiling = min(0.9 * limit if limit else 0.2 / omega_max, duration)
    dt = ceiling
    best = None
    for _ in range(SEARCHES):
        if check is not None:
            check()
        error = predicted_error(predictor, integrator, dt, duration, measure)
        if error <= target:
            best = dt if best is None else max(best, dt)
            if dt >= ceiling or error > 0.5 * target:
                return best, True
            grow = (target / max(error, 1e-300)) ** (1.0 / order)
            dt = min(ceiling, dt * min(0.9 * grow, 10.0))
        else:
            if best is not None:
                return best, True
            shrink = (target / error) ** (1.0 / order) if math.isfinite(error) else 0.1
            dt *= max(min(0.9 * shrink, 0.8), 1e-3)
    return (best, True) if best is not None else (dt, False)


def step_seconds(scene: sim.Scene, integrator: str, threads: int = 1) -> float:
    """Measured wall seconds of one step of ``integrator`` on the scene (compiled first, then
    steps doubled until ``TIMING_SECONDS`` have passed); a safe small dt is used, the cost of
    a step does not depend on it."""
    omega = highest_frequency(scene.model) or 1.0
    simulation = sim.Simulation(scene, integrator=integrator, dt=0.05 / omega, threads=threads)
    prepare_reading(simulation)  # kernels compiled here would run slower (sim.runtime.warming)
    try:
        simulation.step(1)  # the single step and, next, the loop of several steps (Verlet's
        simulation.step(2)  # leapfrog is another kernel) run once before the timing
        steps, spent, count = 1, 0.0, 0
        while spent < TIMING_SECONDS and count < 1 << 16:
            started = time.perf_counter()
            simulation.step(steps)
            spent += time.perf_counter() - started
            count += steps
            steps *= 2
    except sim.BlowUpError:
        return describe(integrator).seconds_per_step(scene.model.n_particles)
    return spent / max(count, 1)
