"""The time integrators, described as data: the one registry of what each integrator is.

Every integrator is one ``IntegratorDescription`` in one registry: its name, labels, order, force
evaluations per step, stability factor, amplification matrices (for the damped stability limit)
and the stepper class that runs it.  Every table elsewhere (``INTEGRATORS``, ``ORDERS``,
``LABELS``, ``FORCE_EVALUATIONS``, ``STABILITY_FACTORS``, the CLI's choices, the web app's
dropdown, the studies' lists, the stability code in ``sim.theory.observables``) is a live view of that
registry, so adding an integrator is one ``register(...)`` call (``docs/api.md`` shows one).

The compiled steppers that the descriptions name are in ``sim.integrators.steppers``, the amplification
matrices in ``sim.integrators.amplification``; ``make_integrator`` builds a description's stepper.
A Runge-Kutta method is its Butcher table (``sim.integrators.butcher``): ``runge_kutta(table)``
gives its order, cost, stability factor, amplification matrices and stepper, so a new method is
one table and one ``register(IntegratorDescription(..., **runge_kutta(table)))``.

An integrator need not be a compiled kernel stepper (``kernel=False``, e.g. a normal-mode solver
for linear scenes), and it may apply to some models only (``applies_to``): ``INTEGRATORS`` lists
the integrators that apply to every model, ``names(model)`` those that apply to one model, and
``names(kernel_only=True)`` the compiled steppers (what ``oscillators bench`` measures).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from sim.forces import registry as force_terms
from sim.integrators.amplification import AmplificationFunction, taylor_amplification, verlet_amplification
from sim.integrators.butcher import CLASSIC_RK4, HEUN, RALSTON3, ButcherTable
from sim.integrators.splitting import BLANES_MOAN, YOSHIDA4, SplittingTable
from sim.integrators.steppers import Euler, RungeKutta, Splitting, Verlet
from sim.model.lattice import Model
from sim.model.state import State

PRECISIONS: dict[str, type[np.floating]] = {"float64": np.float64, "float32": np.float32}
"""Floating-point precisions of the state and the kernels (energies always sum in float64)."""


class IntegratorError(ValueError):
    """Unknown integrator name, or an integrator that does not apply to the model."""


class Stepper(Protocol):
    """What a ``Simulation`` needs from an integrator: advance a state, drop cached forces."""

    def advance(self, state: State, n: int, dt: float) -> None: ...

    def invalidate(self) -> None: ...


@dataclasses.dataclass(frozen=True)
class IntegratorDescription:
    """Everything the rest of the program needs to know about one integrator.

    ``stability_factor``: on an undamped lattice the step is stable iff omega_max * dt <= factor;
    None means no step is stable there (energy grows at every dt), ``math.inf`` any step is.
    ``amplification`` gives the damped limit by bisection (None: not analysed, the undamped
    factor is used).  ``stepper(model, dtype, threads)`` builds the object that advances states;
    ``kernel`` says whether it is one of the compiled row-sweep steppers; ``applies_to(model)``
    returns None when the integrator can run the model, else the reason it cannot.
    """

    name: str
    label: str
    short_label: str
    order: int
    force_evaluations: int
    stability_factor: float | None
    stepper: Callable[[Model, type[np.floating], int], Stepper]
    amplification: AmplificationFunction | None = None
    kernel: bool = True
    symplectic: bool = False
    aliases: tuple[str, ...] = ()
    applies_to: Callable[[Model], str | None] | None = None
    colour: tuple[int, int, int] = (128, 128, 128)
    """RGB of this integrator's lines wherever integrators are compared (recordings, plots)."""
    step_cost: tuple[float, float] | None = None
    """(fixed seconds per step, seconds per step and particle) measured with ``Simulation.step``
    on a 2-core x86_64 machine (the chain/grid presets for the fixed part, 682x383 for the part
    per particle); None: estimated from ``force_evaluations`` (``estimated_seconds``)."""
    bench_burst: int = 20
    """Steps per timed burst in ``oscillators bench`` (long enough to hide the call overhead)."""
    drift_when_gaining: str = "The integrator does not conserve the energy at this dt."
    """Why the energy balance drifts upwards with this integrator, in plain words (the page)."""
    drift_when_losing: str | None = None
    """Why it drifts downwards (energy lost although nothing in the physics removes it); None:
    the same words as upwards."""
    butcher: ButcherTable | None = None
    """The Butcher table of a Runge-Kutta method (``runge_kutta(table)`` fills the fields that
    follow from it); None for the others."""
    splitting: SplittingTable | None = None
    """The table of a splitting method (``splitting(table, name)`` fills the fields that follow
    from it); None for the others."""
    devices: tuple[str, ...] = ("cpu",)
    """Where it runs (``sim.devices.DEVICES``): the CPU, and "cuda" for the GPU stepper
    (``sim.devices.cuda_stepper``)."""

    def reason_not_applicable(self, model: Model) -> str | None:
        return None if self.applies_to is None else self.applies_to(model)

    def drift_explanation(self, error: float) -> str:
        """Why the energy balance is off by the relative ``error`` (signed) with this integrator."""
        if error < 0 and self.drift_when_losing is not None:
            return self.drift_when_losing
        return self.drift_when_gaining

    def seconds_per_step(self, n_particles: int) -> float:
        """Rough wall time (s) of one step on ``n_particles`` particles."""
        fixed, per_particle = self.step_cost or (
            1.0e-6 + 0.35e-6 * self.force_evaluations, self.force_evaluations / 2.5e8
        )
        return fixed + n_particles * per_particle


def estimated_seconds(steps: float, n_particles: int, integrator: str) -> float:
    """Rough wall time (s) of ``steps`` steps of ``integrator`` on ``n_particles`` particles."""
    return steps * describe(integrator).seconds_per_step(n_particles)


def runge_kutta(table: ButcherTable) -> dict[str, Any]:
    """The fields of an ``IntegratorDescription`` that follow from a Runge-Kutta method's table:
    its order, force evaluations, stability factor, amplification matrices, its stepper, and
    the table itself."""
    return dict(order=table.order, force_evaluations=table.stages,
                stability_factor=table.stability_factor, amplification=table.amplification,
                stepper=RungeKutta.of(table), butcher=table)


def splitting_applies(model: Model) -> str | None:
    """Why a splitting method with negative weights cannot run ``model``, or None: its steps
    pass through earlier times and kick with forces taken as functions of positions alone."""
    if force_terms.velocity_dependent(model):
        return ("its kicks take the forces as functions of the positions alone; dashpots and "
                "drag depend on the velocities (use velocity Verlet or RK4)")
    if model.has_forcing:
        return ("drivers, sources, pinned particles and absorbing walls act at the times of "
                "whole steps, and its stages step back and forth in time (use velocity Verlet)")
    return None


def splitting(table: SplittingTable, name: str) -> dict[str, Any]:
    """The fields of an ``IntegratorDescription`` that follow from a splitting method's table:
    its order, force evaluations, stability factor, amplification matrices, stepper, the table
    itself; it is symplectic, and applies to undamped lattices without forcing."""
    return dict(order=table.order, force_evaluations=table.force_evaluations,
                stability_factor=table.stability_factor, amplification=table.amplification,
                stepper=Splitting.of(table, name), splitting=table, symplectic=True,
                applies_to=splitting_applies)


_REGISTRY: dict[str, IntegratorDescription] = {}


def register(description: IntegratorDescription) -> IntegratorDescription:
    """Add (or replace) an integrator; every table and front end sees it at once."""
    _REGISTRY[description.name] = description
    return description


def unregister(name: str) -> None:
    """Remove an integrator added with ``register`` (tests use it to clean up)."""
    _REGISTRY.pop(name, None)


def descriptions() -> tuple[IntegratorDescription, ...]:
    """All registered integrators, in registration order."""
    return tuple(_REGISTRY.values())


def names(model: Model | None = None, kernel_only: bool = False) -> tuple[str, ...]:
    """Names of the integrators that apply to every model (``model`` None) or to ``model``;
    with ``kernel_only`` only the compiled row-sweep steppers."""
    return tuple(
        d.name for d in _REGISTRY.values()
        if (not kernel_only or d.kernel)
        and (d.applies_to is None if model is None else d.reason_not_applicable(model) is None)
    )


def names_on(device: str) -> tuple[str, ...]:
    """The integrators that run on ``device`` ("cpu", "cuda"), in the registry's order."""
    return tuple(d.name for d in _REGISTRY.values() if device in d.devices)


def most_accurate(model: Model | None = None) -> str:
    """The compiled integrator of highest order (ties: the first registered) that applies to
    ``model``: the numerical reference the studies compare against."""
    candidates = [describe(name) for name in names(model, kernel_only=True)]
    return max(candidates, key=lambda d: d.order).name


def describe(name: str) -> IntegratorDescription:
    """The description of the integrator called ``name`` (aliases accepted)."""
    return _REGISTRY[check_integrator_name(name)]


def check_integrator_name(name: str, model: Model | None = None) -> str:
    """Normalise an integrator name or raise a clear error listing the valid ones; with
    ``model``, also refuse an integrator that does not apply to it (saying why)."""
    key = str(name).strip().lower().replace("_", "-")
    for description in _REGISTRY.values():
        if key == description.name or key in description.aliases:
            key = description.name
            break
    else:
        raise IntegratorError(
            f"unknown integrator {name!r}; choose one of: {', '.join(_REGISTRY)}"
        )
    if model is not None:
        reason = _REGISTRY[key].reason_not_applicable(model)
        if reason is not None:
            raise IntegratorError(f"{_REGISTRY[key].label} does not apply here: {reason}")
    return key


class _LiveNames(Sequence[str]):
    """Integrator names, always current: those that apply to every model, or (``every=True``)
    every registered one."""

    def __init__(self, every: bool = False) -> None:
        self._every = every

    def _names(self) -> tuple[str, ...]:
        return tuple(_REGISTRY) if self._every else names()

    def __getitem__(self, index):  # type: ignore[override]
        return self._names()[index]

    def __len__(self) -> int:
        return len(self._names())

    def __contains__(self, name: object) -> bool:
        return name in self._names()

    def __repr__(self) -> str:
        return repr(self._names())


class _LiveField(Mapping[str, Any]):
    """One field of every registered description, keyed by name, always current."""

    def __init__(self, field: str) -> None:
        self._field = field

    def __getitem__(self, name: str) -> Any:
        return getattr(_REGISTRY[name], self._field)

    def __iter__(self) -> Iterator[str]:
        return iter(tuple(_REGISTRY))

    def __len__(self) -> int:
        return len(_REGISTRY)

    def __repr__(self) -> str:
        return repr(dict(self))


INTEGRATORS: Sequence[str] = _LiveNames()
"""Names accepted for every model (``Simulation(integrator=...)``, the web app, the studies)."""
ALL_INTEGRATORS: Sequence[str] = _LiveNames(every=True)
"""Every registered name (the CLI's choices); some may apply to some models only."""
LABELS: Mapping[str, str] = _LiveField("label")
ORDERS: Mapping[str, int] = _LiveField("order")
"""Order of accuracy of each integrator (global error ~ dt**order)."""
FORCE_EVALUATIONS: Mapping[str, int] = _LiveField("force_evaluations")
"""Force evaluations per step (the cost of a step)."""
STABILITY_FACTORS: Mapping[str, float | None] = _LiveField("stability_factor")
"""Largest stable omega_max * dt on an undamped lattice (None: no stable step)."""


register(IntegratorDescription(
    name="euler", label="explicit Euler", short_label="explicit Euler", order=1,
    force_evaluations=1, stability_factor=None, stepper=Euler,
    amplification=taylor_amplification(1), colour=(220, 50, 50), step_cost=(1.0e-6, 1 / 3.2e8),
    drift_when_gaining=(
        "Explicit Euler adds energy at every step (each mode by 1 + (ω·dt)² per step): "
        "the motion grows without bound at any dt."
    ),
))
register(IntegratorDescription(
    name="heun", label="Heun (predictor-corrector)", short_label="Heun", **runge_kutta(HEUN),
    colour=(205, 120, 0), step_cost=(1.3e-6, 1 / 1.3e8),
    bench_burst=10,
    drift_when_gaining="Heun's method slowly adds energy to every mode (by 1 + (ω·dt)⁴/4 per step).",
    drift_when_losing=(
        "Heun damps the short waves numerically: energy leaks away although nothing in the "
        "physics removes it."
    ),
))
register(IntegratorDescription(
    name="verlet", label="velocity Verlet", short_label="velocity Verlet", order=2,
    force_evaluations=1, stability_factor=2.0, stepper=Verlet,
    amplification=verlet_amplification, symplectic=True,
    aliases=("velocity-verlet",), colour=(30, 150, 60), step_cost=(1.0e-6, 1 / 3.4e8),
    bench_burst=100, devices=("cpu", "cuda"),
    drift_when_gaining=(
        "Velocity Verlet keeps a nearby energy exactly, so its error stays bounded, but short "
        "waves travel at the wrong speed (phase error); the error shown is that wobble."
    ),
))
register(IntegratorDescription(
    name="rk4", label="classic Runge-Kutta 4", short_label="RK4", **runge_kutta(CLASSIC_RK4),
    aliases=("runge-kutta",), colour=(40, 110, 235),
    step_cost=(2.4e-6, 1 / 6.2e7),
    drift_when_losing=(
        "classic Runge-Kutta 4 damps the short waves numerically: energy leaks away although "
        "nothing in the physics removes it."
    ),
))
register(IntegratorDescription(
    name="ralston3", label="Ralston RK3", short_label="Ralston RK3", **runge_kutta(RALSTON3),
    aliases=("ralston",), colour=(150, 60, 190),
    drift_when_losing=(
        "Ralston's third-order method damps the short waves numerically: energy leaks away "
        "although nothing in the physics removes it."
    ),
))


register(IntegratorDescription(
    name="yoshida4", label=YOSHIDA4.label, short_label="Yoshida 4",
    **splitting(YOSHIDA4, "yoshida4"), aliases=("yoshida", "triple-jump"),
    colour=(0, 150, 150), bench_burst=40,
    drift_when_gaining=(
        "Yoshida's method keeps a nearby energy exactly (it is symplectic), so its error stays "
        "bounded; the error shown is that wobble, smaller than Verlet's at the same dt."
    ),
))
register(IntegratorDescription(
    name="blanes-moan", label=BLANES_MOAN.label, short_label="Blanes-Moan 4",
    **splitting(BLANES_MOAN, "blanes-moan"), aliases=("srkn6b", "bm4"),
    colour=(190, 30, 140), bench_burst=20,
    drift_when_gaining=(
        "The Blanes-Moan method keeps a nearby energy exactly (it is symplectic), so its error "
        "stays bounded; the error shown is that wobble, far smaller than Verlet's."
    ),
))


def check_precision(precision: Any) -> type[np.floating]:
    """The numpy type of a precision name ("float64", "float32") or raise ``IntegratorError``."""
    key = str(getattr(precision, "__name__", precision)).strip().lower()
    if key not in PRECISIONS:
        raise IntegratorError(
            f"unknown precision {precision!r}; choose one of: {', '.join(PRECISIONS)}"
        )
    return PRECISIONS[key]


def max_threads() -> int:
    """The most threads a run may ask for: the threads numba may run (``NUMBA_NUM_THREADS``, by
    default this machine's cores); more would only cut the rows into more blocks."""
    import numba

    return max(1, int(numba.config.NUMBA_NUM_THREADS))


def check_threads(threads: Any) -> int:
    """A thread count: a whole number from 1 to ``max_threads()``, or raise ``IntegratorError``."""
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise IntegratorError(f"threads must be a whole number >= 1, got {threads!r}")
    if threads > max_threads():
        raise IntegratorError(f"threads must be at most {max_threads()} (the threads numba runs "
                              f"on this machine, NUMBA_NUM_THREADS), got {threads}")
    return int(threads)


def make_integrator(
    name: str, model: Model, precision: str = "float64", threads: int = 1
) -> Stepper:
    """Build the stepper of the integrator called ``name`` for ``model`` in ``precision``."""
    description = _REGISTRY[check_integrator_name(name, model)]
    return description.stepper(model, check_precision(precision), check_threads(threads))
