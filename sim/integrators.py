"""The time integrators, described as data, and the steppers that advance a ``State`` of a ``Model``.

Every integrator is one ``IntegratorDescription`` in one registry: its name, labels, order, force
evaluations per step, stability factor, amplification matrices (for the damped stability limit)
and the stepper class that runs it.  Every table elsewhere (``INTEGRATORS``, ``ORDERS``,
``LABELS``, ``FORCE_EVALUATIONS``, ``STABILITY_FACTORS``, the CLI's choices, the web app's
dropdown, the studies' lists, the stability code in ``sim.observables``) is a live view of that
registry, so adding an integrator is one ``register(...)`` call (``docs/api.md`` shows one).

A stepper owns its work arrays (allocated once per model shape, in the simulation's precision)
and calls the compiled step loops of ``sim.stepping``.  Switching integrator mid-run loses
nothing: the state is (x, v, t) and only Verlet caches the current acceleration, which it
recomputes whenever the state or the model may have changed (``invalidate``).

An integrator need not be a compiled kernel stepper (``kernel=False``, e.g. a normal-mode solver
for linear scenes), and it may apply to some models only (``applies_to``): ``INTEGRATORS`` lists
the integrators that apply to every model, ``names(model)`` those that apply to one model, and
``names(kernel_only=True)`` the compiled steppers (what ``oscillators bench`` measures).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, ClassVar, NamedTuple, Protocol

import numba
import numpy as np

from sim import host_tuning, stepping
from sim.kernels import SpringParameters
from sim.model import Model
from sim.state import State

PRECISIONS: dict[str, type[np.floating]] = {"float64": np.float64, "float32": np.float32}
"""Floating-point precisions of the state and the kernels (energies always sum in float64)."""


class IntegratorError(ValueError):
    """Unknown integrator name, or an integrator that does not apply to the model."""


class Stepper(Protocol):
    """What a ``Simulation`` needs from an integrator: advance a state, drop cached forces."""

    def advance(self, state: State, n: int, dt: float) -> None: ...

    def invalidate(self) -> None: ...


AmplificationFunction = Callable[[np.ndarray, np.ndarray, float], np.ndarray]
"""(omega_squared (n_modes,), damping_rate (n_modes,), dt) -> (n_modes, s, s) matrices G with
z_{n+1} = G z_n for u'' + beta u' + omega^2 u = 0, the integrator as implemented."""


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
    drift_when_losing: str = "The integrator does not conserve the energy at this dt."
    """Why it drifts downwards (energy lost although nothing in the physics removes it)."""

    def reason_not_applicable(self, model: Model) -> str | None:
        return None if self.applies_to is None else self.applies_to(model)

    def drift_explanation(self, error: float) -> str:
        """Why the energy balance is off by the relative ``error`` (signed) with this integrator."""
        return self.drift_when_losing if error < 0 else self.drift_when_gaining

    def seconds_per_step(self, n_particles: int) -> float:
        """Rough wall time (s) of one step on ``n_particles`` particles."""
        fixed, per_particle = self.step_cost or (
            1.0e-6 + 0.35e-6 * self.force_evaluations, self.force_evaluations / 2.5e8
        )
        return fixed + n_particles * per_particle


def estimated_seconds(steps: float, n_particles: int, integrator: str) -> float:
    """Rough wall time (s) of ``steps`` steps of ``integrator`` on ``n_particles`` particles."""
    return steps * describe(integrator).seconds_per_step(n_particles)


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


# --- amplification matrices of the integrators as implemented in sim.stepping --------------------


def taylor_amplification(terms: int) -> AmplificationFunction:
    """G = sum_{k <= terms} (dt A)^k / k! on z = (u, u'): explicit Euler (1), Heun (2) and RK4 (4)
    reduce to this on a linear system."""

    def amplification(omega_squared, damping_rate, dt: float) -> np.ndarray:
        omega_squared = np.asarray(omega_squared, dtype=float)
        count = omega_squared.shape[0]
        system = np.zeros((count, 2, 2))
        system[:, 0, 1] = 1.0
        system[:, 1, 0] = -omega_squared
        system[:, 1, 1] = -np.asarray(damping_rate, dtype=float)
        step = dt * system
        identity = np.broadcast_to(np.eye(2), step.shape)
        result = identity.copy()
        power = identity.copy()
        for order in range(1, terms + 1):
            power = power @ step / order
            result = result + power
        return result

    return amplification


def verlet_amplification(omega_squared, damping_rate, dt: float) -> np.ndarray:
    """Velocity Verlet with the predicted velocity v + dt a in the damping force, on
    z = (u, u', cached acceleration)."""
    omega_squared = np.asarray(omega_squared, dtype=float)
    beta = np.asarray(damping_rate, dtype=float)
    count = omega_squared.shape[0]
    h = dt
    # v_pred = w + h a; w_half = w + h/2 a; u' = u + h w_half; a' = -omega^2 u' - beta v_pred;
    # w' = w_half + h/2 a'
    matrices = np.zeros((count, 3, 3))
    u_new = np.stack([np.ones(count), np.full(count, h), np.full(count, h * h / 2)], axis=1)
    v_pred = np.stack([np.zeros(count), np.ones(count), np.full(count, h)], axis=1)
    a_new = -omega_squared[:, None] * u_new - beta[:, None] * v_pred
    w_half = np.stack([np.zeros(count), np.ones(count), np.full(count, h / 2)], axis=1)
    matrices[:, 0, :] = u_new
    matrices[:, 1, :] = w_half + (h / 2) * a_new
    matrices[:, 2, :] = a_new
    return matrices


# --- compiled kernel steppers --------------------------------------------------------------------


class KernelArguments(NamedTuple):
    """The model as the compiled kernels take it, in one precision (None marks an absent term).

    ``inverse_mass`` (ny, nx) 1/kg; ``uniform_inverse_mass`` replaces it for equal masses;
    ``parameters`` the spring constants; ``gravity`` (3,) m/s^2.
    """

    linear: bool
    out_of_plane: object
    inverse_mass: np.ndarray
    uniform_inverse_mass: np.floating | None
    parameters: SpringParameters
    dashpot: np.floating | None
    drag: np.floating | None
    gravity: np.ndarray | None

    @classmethod
    def from_model(cls, model: Model, dtype: type[np.floating] = np.float64) -> KernelArguments:
        scalar = np.dtype(dtype).type
        return cls(
            linear=model.linear,
            out_of_plane=None if model.dim == 2 else True,
            inverse_mass=np.ascontiguousarray(model.inverse_masses, dtype=dtype),
            uniform_inverse_mass=(
                scalar(model.inverse_masses.flat[0]) if model.uniform_mass else None
            ),
            parameters=model.kernel_parameters.as_type(
                dtype, host_tuning.inverse_sqrt_estimate() if scalar is np.float64 else None
            ),
            dashpot=scalar(model.damping) if model.damping > 0 else None,
            drag=scalar(model.drag) if model.drag > 0 else None,
            gravity=np.array(model.gravity, dtype=dtype) if model.has_gravity else None,
        )


class Integrator:
    """Base class of the compiled steppers: ``advance(state, n, dt)`` moves the state n steps.

    ``dtype`` is the precision of the state and the arithmetic; ``threads`` the number of row
    blocks the sweeps run on in parallel.
    """

    name: ClassVar[str]
    work_arrays: ClassVar[int] = 1
    ring_rows: ClassVar[int | None] = None
    """Rows kept by the work arrays when they are ring buffers (None: the whole lattice)."""

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        self.model = model
        self.dtype = np.dtype(dtype).type
        self.threads = int(threads)
        self.kernel = KernelArguments.from_model(model, self.dtype)
        rows = model.ny if self.ring_rows is None else self.ring_rows
        shape = (model.dim, rows, model.nx)
        self.work = [np.zeros(shape, dtype=self.dtype) for _ in range(self.work_arrays)]
        blocks = min(self.threads, model.ny)
        self._block_starts = np.linspace(0, model.ny, blocks + 1).round().astype(np.int64)
        self._full_work: list[np.ndarray] = []

    @property
    def parallel(self) -> bool:
        """Whether the sweeps run as row blocks on numba's threads (threads > 1, ny > 1)."""
        return self._block_starts.size > 2

    def _start_threads(self) -> None:
        numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))

    def _full_arrays(self, count: int) -> list[np.ndarray]:
        """``count`` full (dim, ny, nx) work arrays for the parallel loops, allocated at first use."""
        model = self.model
        while len(self._full_work) < count:
            self._full_work.append(np.zeros((model.dim, model.ny, model.nx), dtype=self.dtype))
        return self._full_work[:count]

    def invalidate(self) -> None:
        """The state was changed from outside (a drag, a reset): drop any cached forces."""

    def _common(self, state: State) -> tuple:
        k = self.kernel
        return (
            k.linear, k.out_of_plane, state.positions, state.velocities, k.inverse_mass,
            k.uniform_inverse_mass, k.parameters, k.dashpot, k.drag, k.gravity,
        )

    def _dt(self, dt: float) -> np.floating:
        return self.dtype(dt)

    def advance(self, state: State, n: int, dt: float) -> None:
        raise NotImplementedError


class Euler(Integrator):
    name = "euler"
    work_arrays = 0

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel:
            self._start_threads()
            state.dissipated += stepping.euler_steps_parallel(
                n, self._dt(dt), *self._common(state), *self._full_arrays(1), self._block_starts
            )
        else:
            state.dissipated += stepping.euler_steps(n, self._dt(dt), *self._common(state))
        state.advance_clock(n, dt)


class Heun(Integrator):
    name = "heun"
    work_arrays = 3
    ring_rows = 2

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        # Blocks of at least 4 rows run the wavefront with one halo row (one sweep per step);
        # thinner lattices fall back to a parallel phase for the predictor and the corrector.
        blocks = min(self.threads, model.ny // 4)
        self._blocks: np.ndarray | None = None
        self._block_work: list[np.ndarray] = []
        if blocks >= 2:
            self._blocks = np.linspace(0, model.ny, blocks + 1).round().astype(np.int64)
            ring = (blocks, model.dim, stepping.RK4_RING, model.nx)
            edges = (blocks, model.dim, 2 * (stepping.HEUN_HALO + 1), model.nx)
            self._block_work = [np.zeros(ring, dtype=self.dtype) for _ in range(3)] + [
                np.zeros(edges, dtype=self.dtype) for _ in range(2)
            ]

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel and self._blocks is not None:
            self._start_threads()
            state.dissipated += stepping.heun_steps_blocks(
                n, self._dt(dt), *self._common(state), *self._block_work, self._blocks
            )
        elif self.parallel:
            self._start_threads()
            state.dissipated += stepping.heun_steps_parallel(
                n, self._dt(dt), *self._common(state), *self._full_arrays(3), self._block_starts
            )
        else:
            state.dissipated += stepping.heun_steps(
                n, self._dt(dt), *self._common(state), *self.work
            )
        state.advance_clock(n, dt)


class Verlet(Integrator):
    name = "verlet"
    work_arrays = 2

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        self._cached_for: tuple[int, float] | None = None
        self._power = 0.0

        k = self.kernel
        # Undamped nonlinear springs: the steps between the first and the last run as fused
        # leapfrog sweeps over row blocks (one block per thread), the fastest loop shape.
        self._leapfrog = k.dashpot is None and k.drag is None and not k.linear
        blocks = self._block_starts.size - 1
        self._boundary = np.zeros((blocks + 1, 3, model.nx), dtype=self.dtype)
        self._below = np.zeros((blocks, 3, model.nx), dtype=self.dtype)
        self._horizontal = np.zeros((blocks, 3, model.nx + 1), dtype=self.dtype)

    def invalidate(self) -> None:
        self._cached_for = None

    def _accelerations(self, state: State) -> float:
        """a(x, v) of the state into ``work[0]`` (on the row blocks' threads when parallel);
        returns the dissipated power (W)."""
        if self.parallel:
            return stepping.accelerations_parallel(
                *self._common(state), self.work[0], self._block_starts
            )
        return stepping.accelerations(*self._common(state), self.work[0])

    def advance(self, state: State, n: int, dt: float) -> None:
        stamp = (state.revision, state.time)
        if self.parallel:
            self._start_threads()
        if self._cached_for != stamp:
            self._power = self._accelerations(state)
        step = self._dt(dt)
        if self._leapfrog and n >= 2:
            k = self.kernel
            acceleration = self.work[0]
            stepping.verlet_open(step, state.positions, state.velocities, acceleration)
            leapfrog = stepping.leapfrog_steps_parallel if self.parallel else stepping.leapfrog_steps
            leapfrog(
                n - 1, step, k.out_of_plane, state.positions, state.velocities, k.inverse_mass,
                k.uniform_inverse_mass, k.parameters, k.gravity, self._block_starts,
                self._boundary, self._below, self._horizontal,
            )
            self._power = self._accelerations(state)
            stepping.verlet_close(step, state.velocities, acceleration)
        elif self.parallel:
            dissipated, self._power = stepping.verlet_steps_parallel(
                n, step, *self._common(state), self.work[0], self._power, self.work[1],
                self._block_starts,
            )
            state.dissipated += dissipated
        else:
            dissipated, self._power = stepping.verlet_steps(
                n, step, *self._common(state), self.work[0], self._power, self.work[1]
            )
            state.dissipated += dissipated
        state.advance_clock(n, dt)
        self._cached_for = (state.revision, state.time)


class RungeKutta4(Integrator):
    name = "rk4"
    work_arrays = 4
    ring_rows = 4

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        # Blocks of at least 8 rows run the wavefront with halo rows (one sweep per step); thinner
        # lattices fall back to one parallel phase per stage.
        blocks = min(self.threads, model.ny // 8)
        self._blocks: np.ndarray | None = None
        self._block_work: list[np.ndarray] = []
        if blocks >= 2:
            self._blocks = np.linspace(0, model.ny, blocks + 1).round().astype(np.int64)
            ring = (blocks, model.dim, stepping.RK4_RING, model.nx)
            edges = (blocks, model.dim, 2 * (stepping.RK4_HALO + 1), model.nx)
            self._block_work = [np.zeros(ring, dtype=self.dtype) for _ in range(4)] + [
                np.zeros(edges, dtype=self.dtype) for _ in range(2)
            ]

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel and self._blocks is not None:
            self._start_threads()
            state.dissipated += stepping.rk4_steps_blocks(
                n, self._dt(dt), *self._common(state), *self._block_work, self._blocks
            )
        elif self.parallel:
            self._start_threads()
            state.dissipated += stepping.rk4_steps_parallel(
                n, self._dt(dt), *self._common(state), *self._full_arrays(6), self._block_starts
            )
        else:
            state.dissipated += stepping.rk4_steps(
                n, self._dt(dt), *self._common(state), *self.work
            )
        state.advance_clock(n, dt)


register(IntegratorDescription(
    name="euler", label="explicit Euler", short_label="explicit Euler", order=1,
    force_evaluations=1, stability_factor=None, stepper=Euler,
    amplification=taylor_amplification(1), colour=(220, 50, 50), step_cost=(1.0e-6, 1 / 3.2e8),
    drift_when_gaining=(
        "Explicit Euler adds energy at every step (each mode by 1 + (ω·dt)² per step): "
        "the motion grows without bound at any dt."
    ),
    drift_when_losing=(
        "Explicit Euler adds energy at every step (each mode by 1 + (ω·dt)² per step): "
        "the motion grows without bound at any dt."
    ),
))
register(IntegratorDescription(
    name="heun", label="Heun (predictor-corrector)", short_label="Heun", order=2,
    force_evaluations=2, stability_factor=None, stepper=Heun,
    amplification=taylor_amplification(2), colour=(205, 120, 0), step_cost=(1.3e-6, 1 / 1.3e8),
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
    bench_burst=100,
    drift_when_gaining=(
        "Velocity Verlet keeps a nearby energy exactly, so its error stays bounded, but short "
        "waves travel at the wrong speed (phase error); the error shown is that wobble."
    ),
    drift_when_losing=(
        "Velocity Verlet keeps a nearby energy exactly, so its error stays bounded, but short "
        "waves travel at the wrong speed (phase error); the error shown is that wobble."
    ),
))
register(IntegratorDescription(
    name="rk4", label="classic Runge-Kutta 4", short_label="RK4", order=4,
    force_evaluations=4, stability_factor=2.0 * math.sqrt(2.0), stepper=RungeKutta4,
    amplification=taylor_amplification(4), aliases=("runge-kutta",), colour=(40, 110, 235),
    step_cost=(2.4e-6, 1 / 6.2e7),
    drift_when_losing=(
        "classic Runge-Kutta 4 damps the short waves numerically: energy leaks away although "
        "nothing in the physics removes it."
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


def check_threads(threads: Any) -> int:
    """A thread count: a whole number >= 1, or raise ``IntegratorError``."""
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise IntegratorError(f"threads must be a whole number >= 1, got {threads!r}")
    return int(threads)


def make_integrator(
    name: str, model: Model, precision: str = "float64", threads: int = 1
) -> Stepper:
    """Build the stepper of the integrator called ``name`` for ``model`` in ``precision``."""
    description = _REGISTRY[check_integrator_name(name, model)]
    return description.stepper(model, check_precision(precision), check_threads(threads))
