"""One run of ``choose``: a small picklable task, the top-level function that runs it, and the
one seam through which every batch of runs goes (``MapRuns``).

``run_setting(task)`` runs ``task.scene`` from its initial state for ``task.steps`` steps of
``task.dt`` s with ``task.integrator`` and returns a ``RunOutcome``: the displacement field at
each of the run's sample times (``sim.runtime.errors.sample_steps``; (samples, dim, ny, nx) m, float64;
kept only when ``task.keep_fields``), the largest energy error over those times
(``sim.runtime.errors.energy_error``), the wall seconds of the stepping alone (the kernels are compiled
by a one-step warm-up first) and the blow-up message, if any.  ``steps_for`` makes the number of
steps a multiple of ``sim.runtime.errors.SAMPLES``, so runs at different steps are sampled at the same
times.  A task with a ``time_limit`` is abandoned (``RunOutcome.abandoned``)
once its stepping has taken longer than that: ``choose`` gives it the wall time of the best
verified setting, which a slower run cannot beat.  Tasks and outcomes are plain data, so
``map_runs`` may be the serial ``serial_map`` (the default), a process pool or a cluster's
``Client.map``-like executor.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Iterable, Sequence

import numpy as np

import sim
from sim.runtime.errors import SAMPLES, displacement, energy_error, sample_steps
from sim.runtime.warming import prepare_reading


@dataclasses.dataclass(frozen=True)
class RunTask:
    """One setting to run: ``scene`` (a ``sim.Scene``) with ``integrator`` at ``dt`` (s) for
    ``steps`` steps; ``role`` says why ("probe", "verify", "reference")."""

    scene: sim.Scene
    integrator: str
    dt: float
    steps: int
    role: str = "verify"
    threads: int = 1
    time_limit: float | None = None
    """Wall seconds after which the run is abandoned (None: never)."""
    keep_fields: bool = True
    """Keep the displacement field at every sample time (False: the energy error alone)."""
    stop: Callable[[], bool] | None = dataclasses.field(default=None, compare=False, repr=False)
    """Looked at about ``1 / STOP_INTERVAL`` times a second: once True the run raises
    ``ChoiceCancelled`` (for runs in this process: a page's Cancel; None for other processes)."""

    @property
    def duration(self) -> float:
        return self.steps * self.dt


@dataclasses.dataclass(frozen=True)
class RunOutcome:
    """What one ``RunTask`` gave: ``fields`` the displacement at every sample time (None if it
    blew up or was not kept), ``energy_error`` the largest over the sample times (inf if it blew
    up), ``final_energy_error`` at the end alone, ``wall_seconds``, ``blew_up`` the message or
    None, ``abandoned`` whether it was stopped at its time limit (then no fields, errors inf)."""

    task: RunTask
    fields: np.ndarray | None
    energy_error: float
    wall_seconds: float
    blew_up: str | None = None
    abandoned: bool = False
    final_energy_error: float = math.inf


STOP_INTERVAL = 0.1
"""Seconds of stepping between two looks at a task's ``stop``."""


class ChoiceCancelled(RuntimeError):
    """A run (and so the choice) was stopped by its ``stop``."""


MapRuns = Callable[[Callable[[RunTask], RunOutcome], Sequence[RunTask]], Iterable[RunOutcome]]
"""How a batch of runs is carried out: ``map_runs(run_setting, tasks)`` yields one outcome per
task (in any order: each outcome names its task)."""


def serial_map(function: Callable[[RunTask], RunOutcome], tasks: Sequence[RunTask]
               ) -> Iterable[RunOutcome]:
    """Run the tasks one after the other in this process (the default ``MapRuns``)."""
    return map(function, tasks)


def steps_for(duration: float, dt: float) -> tuple[int, float]:
    """(whole number of steps, a multiple of ``SAMPLES``, and the dt that lands exactly on
    ``duration``) nearest to ``dt``."""
    steps = SAMPLES * max(1, round(duration / dt / SAMPLES))
    return steps, duration / steps


def run_setting(task: RunTask) -> RunOutcome:
    """Run one task (see the module docstring); top level, so it can be sent to other processes.
    The clock (``time_limit``) is looked at after every sample."""
    scene = task.scene
    simulation = sim.Simulation(scene, integrator=task.integrator, dt=task.dt,
                                threads=task.threads)
    # the kernels read from numba's cache (compiled in a child if missing), so none is
    # compiled in this process, where it would run slower (sim.runtime.warming); not timed
    prepare_reading(simulation)
    simulation.chunk_steps = max(64, min(task.steps, 4096))
    fields: list[np.ndarray] = []
    largest = 0.0
    started = time.perf_counter()
    done = 0
    try:
        for sample in sample_steps(task.steps):
            _step_to(simulation, sample - done, task.stop)
            done = sample
            largest = max(largest, energy_error(simulation))
            if task.keep_fields:
                fields.append(displacement(scene.model, simulation.state.positions))
            wall = time.perf_counter() - started
            if task.time_limit is not None and done < task.steps and wall > task.time_limit:
                return RunOutcome(task, None, math.inf, wall, None, abandoned=True)
    except sim.BlowUpError as error:
        return RunOutcome(task, None, math.inf, time.perf_counter() - started, str(error))
    wall = time.perf_counter() - started
    if not math.isfinite(largest):
        largest = math.inf
    return RunOutcome(task, np.stack(fields) if fields else None, largest, wall,
                      final_energy_error=energy_error(simulation))


def _step_to(simulation: sim.Simulation, steps: int, stop: Callable[[], bool] | None) -> None:
    """``simulation.step(steps)``; with ``stop``, in pieces of about ``STOP_INTERVAL`` seconds
    (sized from the pieces before), raising ``ChoiceCancelled`` once ``stop()`` is True."""
    if stop is None:
        simulation.step(steps)
        return
    piece, left = 1, steps
    while left > 0:
        if stop():
            raise ChoiceCancelled("the choice was cancelled")
        count = min(piece, left)
        started = time.perf_counter()
        simulation.step(count)
        spent = time.perf_counter() - started
        left -= count
        piece = max(1, min(4 * count, int(count * STOP_INTERVAL / max(spent, 1e-9))))
