"""What ``choose`` answers: every run it made (``Measured``), the field reference
(``Reference``) and the answer with its runner-ups (``Choice``), as plain data with ``as_dict()``
for JSON.

Every run carries both errors of ``sim.runtime.errors`` over the whole run (``field_error`` None when no
reference was affordable) and ``error``, the one the tolerance was checked against: the larger of
the two when both are used (the default), else the one the user named."""

from __future__ import annotations

import dataclasses
from typing import Any

from app.study.accuracy_runs import jsonable
from sim.integrators.registry import describe
from sim.runtime.errors import ENERGY_ERROR_DEFINITION, FIELD_ERROR_DEFINITION, SAMPLES

BOTH = "field and energy"
"""The measure of a choice that must meet the tolerance in both errors (the default)."""


@dataclasses.dataclass(frozen=True)
class Measured:
    """One setting run over the whole duration: its ``error`` in the chosen measure (both: the
    larger), the ``energy_error`` and ``field_error`` (None without a reference) over the whole
    run, ``wall_seconds``, ``blew_up`` (the message or None) and whether it ``meets`` the
    tolerance."""

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

    def errors(self) -> str:
        """Both errors in words: "field error 0.0041, energy error 0.0032"."""
        field = (f"field error {self.field_error:.3g}" if self.field_error is not None
                 else "field error not measured")
        return f"{field}, energy error {self.energy_error:.3g}"

    def describe(self) -> str:
        label = describe(self.integrator).short_label
        if self.blew_up:
            return f"{label} at dt = {self.dt:.5g} s blew up"
        if self.abandoned:
            return f"{label} at dt = {self.dt:.5g} s stopped after {self.wall_seconds:.3g} s"
        return (f"{label} at dt = {self.dt:.5g} s: {self.errors()} over the run, in "
                f"{self.wall_seconds:.3g} s ({self.steps} steps)")


@dataclasses.dataclass(frozen=True)
class Reference:
    """The field reference: ``kind`` ("exact normal modes" or "RK4 converged"), its ``dt``
    (None when exact), ``change`` (whole-run field change when its step was halved),
    ``wall_seconds``."""

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
    integrators with the reason.  ``measure`` is what the tolerance was checked against:
    ``BOTH``, "field" or "energy"."""

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
            definitions={"field_error": FIELD_ERROR_DEFINITION,
                         "energy_error": ENERGY_ERROR_DEFINITION,
                         "error": "the error checked against the tolerance: "
                         + ("the larger of the two" if self.measure == BOTH
                            else f"the {self.measure} error"),
                         "samples": SAMPLES},
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
