"""One run of ``choose``: a small picklable task, the top-level function that runs it, and the
one seam through which every batch of runs goes (``MapRuns``).

``run_setting(task)`` runs ``task.scene`` from its initial state for ``task.steps`` steps of
``task.dt`` s with ``task.integrator`` and returns a ``RunOutcome``: the displacement field at
the end ((dim, ny, nx) m, float64), the energy error (``sim.runtime.errors.energy_error``), the wall
seconds of the stepping alone (the kernels are compiled by a one-step warm-up first) and the
blow-up message, if any.  A task with a ``time_limit`` is abandoned (``RunOutcome.abandoned``)
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
from sim.runtime.errors import displacement, energy_error


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

    @property
    def duration(self) -> float:
        return self.steps * self.dt


@dataclasses.dataclass(frozen=True)
class RunOutcome:
    """What one ``RunTask`` gave: ``field`` the final displacement (None if it blew up),
    ``energy_error`` (inf if it blew up), ``wall_seconds``, ``blew_up`` the message or None,
    ``abandoned`` whether it was stopped at its time limit (then no field, energy error inf)."""

    task: RunTask
    field: np.ndarray | None
    energy_error: float
    wall_seconds: float
    blew_up: str | None = None
    abandoned: bool = False


SLICES = 50
"""A run with a time limit checks the clock this many times."""


MapRuns = Callable[[Callable[[RunTask], RunOutcome], Sequence[RunTask]], Iterable[RunOutcome]]
"""How a batch of runs is carried out: ``map_runs(run_setting, tasks)`` yields one outcome per
task (in any order: each outcome names its task)."""


def serial_map(function: Callable[[RunTask], RunOutcome], tasks: Sequence[RunTask]
               ) -> Iterable[RunOutcome]:
    """Run the tasks one after the other in this process (the default ``MapRuns``)."""
    return map(function, tasks)


def steps_for(duration: float, dt: float) -> tuple[int, float]:
    """(whole number of steps, the dt that lands exactly on ``duration``) nearest to ``dt``."""
    steps = max(1, round(duration / dt))
    return steps, duration / steps


def run_setting(task: RunTask) -> RunOutcome:
    """Run one task (see the module docstring); top level, so it can be sent to other processes."""
    scene = task.scene
    warm = sim.Simulation(scene, integrator=task.integrator, dt=task.dt, threads=task.threads)
    try:
        warm.step(1)  # compiles the kernels in this process; not timed
    except sim.BlowUpError:
        pass
    simulation = sim.Simulation(scene, integrator=task.integrator, dt=task.dt,
                                threads=task.threads)
    simulation.chunk_steps = max(64, min(task.steps, 4096))
    piece = task.steps if task.time_limit is None else max(1, task.steps // SLICES)
    started = time.perf_counter()
    done = 0
    try:
        while done < task.steps:
            count = min(piece, task.steps - done)
            simulation.step(count)
            done += count
            wall = time.perf_counter() - started
            if task.time_limit is not None and done < task.steps and wall > task.time_limit:
                return RunOutcome(task, None, math.inf, wall, None, abandoned=True)
    except sim.BlowUpError as error:
        return RunOutcome(task, None, math.inf, time.perf_counter() - started, str(error))
    wall = time.perf_counter() - started
    field = displacement(scene.model, simulation.state.positions)
    return RunOutcome(task, field, energy_error(simulation), wall)
