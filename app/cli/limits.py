"""How much computing one command may plan: the step and wall-time limits, and the checks that
refuse a plan over them before anything runs (the estimate comes from the integrator registry,
``sim.integrators.estimated_seconds``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from sim.integrators.registry import estimated_seconds

MAX_STEPS = 10**8
"""Most steps one command may plan (about 100 s of Verlet on the 5-particle chain)."""

MAX_ESTIMATED_SECONDS = 6 * 3600.0
"""Longest estimated wall time of a planned run; longer ones are refused before they start."""


MAX_MEASUREMENT_SECONDS = 600.0
"""Longest time ``bench`` may spend on one measurement (it makes a few dozen)."""


def check_measurement_seconds(seconds: float) -> float:
    """Refuse a benchmark whose measurements would together exceed the wall-time limit."""
    if not seconds <= MAX_MEASUREMENT_SECONDS:
        raise ValueError(f"--seconds {seconds:g} is over the limit of "
                         f"{describe_seconds(MAX_MEASUREMENT_SECONDS)} a measurement (a benchmark "
                         "makes a few dozen)")
    return seconds


def describe_seconds(seconds: float) -> str:
    """``5400`` -> ``"1.5 hours"``: a wall time a person can read."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600),
                       ("minutes", 60)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _over_limits(steps: float, wall_seconds: float) -> bool:
    return steps > MAX_STEPS or wall_seconds > MAX_ESTIMATED_SECONDS


def _limits_text() -> str:
    return f"the limit of {MAX_STEPS:.0e} steps or {describe_seconds(MAX_ESTIMATED_SECONDS)}"


def planned_steps(
    simulation: Any, steps: int | None = None, duration: float | None = None,
    runs: int = 1,
) -> int:
    """The number of steps a command will run: ``steps``, or ``duration / dt``, or the scene's
    duration.  Raises ValueError, naming the estimated run time, when the plan exceeds
    ``MAX_STEPS`` or ``MAX_ESTIMATED_SECONDS`` (``runs`` simulations are advanced together)."""
    dt = simulation.dt
    if steps is not None:
        count = float(steps)
        what = f"{steps} steps"
    else:
        seconds = duration if duration is not None else simulation.scene.duration
        count = max(1.0, round(seconds / dt))
        what = f"{seconds:g} s at dt = {dt:g} s is {count:.3g} steps"
    model = simulation.model
    wall = runs * estimated_seconds(count, model.n_particles, simulation.integrator)
    if _over_limits(count, wall):
        raise ValueError(
            f"{what}: about {describe_seconds(wall)} of computing on {model.n_particles} "
            f"particles, over {_limits_text()}; shorten the run or use a larger --dt"
        )
    return int(count)


def check_plan(runs: Sequence[tuple[float, int, str]], what: str) -> None:
    """Refuse a study whose runs, each (steps, particles, integrator name), exceed the step or
    time limits; ``what`` names the study in the message."""
    most = max(steps for steps, _, _ in runs)
    wall = sum(estimated_seconds(steps, particles, name) for steps, particles, name in runs)
    if _over_limits(most, wall):
        raise ValueError(
            f"{what} plans runs of up to {most:.3g} steps, about {describe_seconds(wall)} of "
            f"computing, over {_limits_text()}"
        )
