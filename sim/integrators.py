"""The four time integrators as objects that advance a ``State`` of a ``Model``.

An integrator owns its work arrays (allocated once per model shape) and calls the compiled step
loops of ``sim.stepping``.  Switching integrator mid-run loses nothing: the state is (x, v, t) and
only Verlet caches the current acceleration, which it recomputes whenever the state or the model
may have changed (``invalidate``).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from sim import stepping
from sim.model import Model
from sim.state import State

INTEGRATORS: tuple[str, ...] = ("euler", "heun", "verlet", "rk4")
"""Integrator names accepted everywhere (``Simulation(integrator=...)``, the CLI, the web app)."""

LABELS: dict[str, str] = {
    "euler": "explicit Euler",
    "heun": "Heun (predictor-corrector)",
    "verlet": "velocity Verlet",
    "rk4": "classic Runge-Kutta 4",
}

ORDERS: dict[str, int] = {"euler": 1, "heun": 2, "verlet": 2, "rk4": 4}
"""Order of accuracy of each integrator (global error ~ dt**order)."""

FORCE_EVALUATIONS: dict[str, int] = {"euler": 1, "heun": 2, "verlet": 1, "rk4": 4}
"""Force evaluations per step (the cost of a step)."""


class IntegratorError(ValueError):
    """Unknown integrator name."""


def check_integrator_name(name: str) -> str:
    """Normalise an integrator name or raise a clear error listing the valid ones."""
    aliases = {"velocity-verlet": "verlet", "velocity_verlet": "verlet", "runge-kutta": "rk4"}
    key = str(name).strip().lower()
    key = aliases.get(key, key)
    if key not in INTEGRATORS:
        raise IntegratorError(
            f"unknown integrator {name!r}; choose one of: {', '.join(INTEGRATORS)}"
        )
    return key


@dataclasses.dataclass
class KernelArguments:
    """The model as the compiled kernels take it (None marks an absent term)."""

    linear: bool
    out_of_plane: object
    inverse_mass: np.ndarray
    uniform_inverse_mass: float | None
    parameters: tuple[float, float, float, float, float, float]
    dashpot: float | None
    drag: float | None
    gravity: np.ndarray | None

    @classmethod
    def from_model(cls, model: Model) -> KernelArguments:
        origin_x, origin_y = model.origin
        gravity = np.array(model.gravity, dtype=float) if model.has_gravity else None
        return cls(
            linear=model.linear,
            out_of_plane=None if model.dim == 2 else True,
            inverse_mass=np.ascontiguousarray(model.inverse_masses),
            uniform_inverse_mass=(
                float(model.inverse_masses.flat[0]) if model.uniform_mass else None
            ),
            parameters=(
                float(model.stiffness), float(model.rest_length), float(model.tension_stiffness),
                float(model.spacing), float(origin_x), float(origin_y),
            ),
            dashpot=float(model.damping) if model.damping > 0 else None,
            drag=float(model.drag) if model.drag > 0 else None,
            gravity=gravity,
        )


class Integrator:
    """Base class: ``advance(state, n, dt)`` moves the state n steps and returns nothing."""

    name: ClassVar[str]
    work_arrays: ClassVar[int] = 1
    ring_rows: ClassVar[int | None] = None
    """Rows kept by the work arrays when they are ring buffers (None: the whole lattice)."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.kernel = KernelArguments.from_model(model)
        rows = model.ny if self.ring_rows is None else self.ring_rows
        shape = (model.dim, rows, model.nx)
        self.work = [np.zeros(shape) for _ in range(self.work_arrays)]

    def invalidate(self) -> None:
        """The state was changed from outside (a drag, a reset): drop any cached forces."""

    def _common(self, state: State) -> tuple:
        k = self.kernel
        return (
            k.linear, k.out_of_plane, state.positions, state.velocities, k.inverse_mass,
            k.uniform_inverse_mass, k.parameters, k.dashpot, k.drag, k.gravity,
        )

    def advance(self, state: State, n: int, dt: float) -> None:
        raise NotImplementedError


class Euler(Integrator):
    name = "euler"
    work_arrays = 0

    def advance(self, state: State, n: int, dt: float) -> None:
        state.dissipated += stepping.euler_steps(n, dt, *self._common(state))
        state.advance_clock(n, dt)


class Heun(Integrator):
    name = "heun"
    work_arrays = 3
    ring_rows = 2

    def advance(self, state: State, n: int, dt: float) -> None:
        state.dissipated += stepping.heun_steps(n, dt, *self._common(state), *self.work)
        state.advance_clock(n, dt)


class Verlet(Integrator):
    name = "verlet"
    work_arrays = 2

    def __init__(self, model: Model) -> None:
        super().__init__(model)
        self._cached_for: tuple[int, float] | None = None
        self._power = 0.0

    def invalidate(self) -> None:
        self._cached_for = None

    def advance(self, state: State, n: int, dt: float) -> None:
        stamp = (state.revision, state.time)
        if self._cached_for != stamp:
            self._power = stepping.accelerations(*self._common(state), self.work[0])
        dissipated, self._power = stepping.verlet_steps(
            n, dt, *self._common(state), self.work[0], self._power, self.work[1]
        )
        state.dissipated += dissipated
        state.advance_clock(n, dt)
        self._cached_for = (state.revision, state.time)


class RungeKutta4(Integrator):
    name = "rk4"
    work_arrays = 4
    ring_rows = 4

    def advance(self, state: State, n: int, dt: float) -> None:
        state.dissipated += stepping.rk4_steps(n, dt, *self._common(state), *self.work)
        state.advance_clock(n, dt)


_CLASSES: dict[str, type[Integrator]] = {
    "euler": Euler, "heun": Heun, "verlet": Verlet, "rk4": RungeKutta4,
}


def make_integrator(name: str, model: Model) -> Integrator:
    """Build the integrator called ``name`` (see ``INTEGRATORS``) for ``model``."""
    return _CLASSES[check_integrator_name(name)](model)
