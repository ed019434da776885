"""One (integrator, dt) run of the accuracy study: timed, then compared with the reference.

``Measurer(scene, until, reference, ...)(integrator, dt)`` runs the scene from its initial state to
time T (dt adjusted so that a whole number of steps lands on T) and returns a ``Run``:

* ``error``: the largest particle position error at T (m), relative to the size of the initial
  disturbance (``accuracy_reference.disturbance_scale``);
* ``energy_drift``: change of the energy balance (total + dissipated) over the run, relative to
  the initial energy scale (|kinetic| + |potential|, or the work gravity can do);
* ``phase_error``: phase error (rad) of the dominant normal mode of the linearised lattice;
* ``wall_seconds`` of ``Simulation.step`` (compilation excluded by ``warm_up``, short runs
  repeated by ``timed_run``).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

import sim
from app.study import linear
from app.study.accuracy_reference import (
    Reference,
    disturbance_scale,
    initial_state,
    position_error,
)
from sim.integrators.registry import describe
from sim.runtime.warming import prepare_reading


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
        return jsonable(dataclasses.asdict(self))


def jsonable(value: Any) -> Any:
    """``value`` with numpy numbers made Python ones, tuples lists and non-finite floats None."""
    if isinstance(value, dict):
        return {key: jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(item) for item in value]
    if isinstance(value, (float, np.floating)):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def energy_scale(simulation: sim.Simulation, scene: sim.Scene) -> float:
    """The energy (J) drifts are measured against: |kinetic| + |potential| at the start, or for a
    scene starting at rest the work gravity can do over one spacing."""
    energy = simulation.energy()
    scale = abs(energy.kinetic) + abs(energy.potential)
    if scale == 0.0:
        model = scene.model
        scale = float(np.linalg.norm(model.gravity)) * float(model.masses.sum()) * model.spacing
    return scale or 1.0


def precisions_of(integrator: str, precisions: Iterable[str]) -> list[str]:
    """The precisions an integrator runs in: all of them for compiled kernels, else float64."""
    if describe(integrator).kernel:
        return list(precisions)
    return ["float64"]


def warm_up(
    scene: sim.Scene, integrators: Iterable[str], precisions: Iterable[str] = ("float64",)
) -> None:
    """Make the kernels the runs will use ready, so compilation is not timed: read from numba's
    cache, compiled in a child process if missing (kernels compiled in the process that runs
    them run slower there, ``sim.runtime.warming``)."""
    for name in integrators:
        for precision in precisions_of(name, precisions):
            prepare_reading(sim.Simulation(scene, integrator=name, dt=1e-6, precision=precision))


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


@dataclasses.dataclass
class Measurer:
    """Runs one configuration of ``scene`` to time ``until`` (s) and compares it with the
    ``reference``.  ``limits``: integrator -> stable dt (s) or None; ``omega_max`` (rad/s) the
    lattice's highest natural frequency; ``modes`` the linearised lattice's normal modes (None:
    no phase error)."""

    scene: sim.Scene
    until: float
    reference: Reference
    limits: Mapping[str, float | None]
    omega_max: float
    modes: linear.NormalModes | None
    minimum_seconds: float
    scale: float = dataclasses.field(init=False)
    """Size of the initial disturbance (m)."""
    rest: np.ndarray = dataclasses.field(init=False)
    """Rest positions as a (dim, ny, nx) array (m)."""
    dominant: int | None = dataclasses.field(init=False, default=None)
    """Index of the dominant normal mode of the initial state (None without modes)."""
    reference_phase: float = dataclasses.field(init=False, default=0.0)
    """Phase (rad) of the dominant mode in the reference state."""

    def __post_init__(self) -> None:
        self.scale = disturbance_scale(self.scene)
        self.rest = self.scene.model.rest_positions.T.reshape(self.reference.positions.shape)
        if self.modes is not None:
            positions, velocities = initial_state(self.scene)
            self.dominant = self.modes.dominant((positions - self.rest).ravel(),
                                                velocities.ravel())
            self.reference_phase = self.modes.phase(
                self.dominant, (self.reference.positions - self.rest).ravel(),
                self.reference.velocities.ravel(),
            )

    def __call__(
        self, integrator: str, dt: float, refined: bool = False, note: str = "",
        precision: str = "float64",
    ) -> Run:
        steps = max(1, round(self.until / dt))
        dt = self.until / steps
        start = sim.Simulation(self.scene, integrator=integrator, dt=dt, precision=precision)
        scale = energy_scale(start, self.scene)
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
        distance = position_error(positions, self.reference.positions)
        drift = (simulation.energy().balance - balance_start) / scale
        phase_error = None
        if self.modes is not None and self.dominant is not None:
            phase = self.modes.phase(
                self.dominant, (positions - self.rest).ravel(),
                simulation.state.velocities.astype(float).ravel(),
            )
            phase_error = float(np.angle(np.exp(1j * (phase - self.reference_phase))))
        return Run(
            **common, steps_per_second=steps / wall if wall > 0 else math.inf,
            error=distance / self.scale, position_error=distance,
            energy_drift=float(drift), phase_error=phase_error, blew_up=False, note=note,
        )
