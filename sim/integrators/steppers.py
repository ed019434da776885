"""The compiled steppers: objects that advance a ``State`` of a ``Model`` with the step loops.

A stepper owns its work arrays (allocated once per model shape, in the simulation's precision)
and picks the loop shape that fits the model and the thread count: the one-thread sweeps of
``sim.loops.row_sweep``, the row blocks of ``sim.loops.row_blocks`` or the leapfrog of ``sim.loops.leapfrog``.
Switching integrator mid-run loses nothing: the state is (x, v, t) and only Verlet caches the
current acceleration, which it recomputes whenever the state or the model may have changed
(``invalidate``).  Each stepper class is named by one ``IntegratorDescription`` in
``sim.integrators.registry``, the registry that the rest of the program reads.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

import numba
import numpy as np

from sim.forces import drive_table as instruments
from sim.forces import registry
from sim.forces.springs import SpringParameters
from sim.forces.term import in_precision
from sim.forces.terms import Terms
from sim.integrators.butcher import ButcherTable
from sim.integrators.splitting import VELOCITY_VERLET, SplittingTable
from sim.loops import host_tuning, leapfrog, row_blocks, wavefront
from sim.loops import row_sweep as stepping
from sim.loops.leapfrog import LeapfrogWork
from sim.loops.stage_updates import Fields
from sim.model.lattice import Model, read_only
from sim.model.state import State


class KernelArguments(NamedTuple):
    """The model as the compiled kernels take it, in one precision: its ``terms``
    (``sim.forces.terms.Terms``, None marking an absent term) and its spring constants
    (``parameters``, ``sim.forces.springs.SpringParameters``), the two records every loop shape
    takes side by side."""

    terms: Terms
    parameters: SpringParameters

    @classmethod
    def from_model(cls, model: Model, dtype: type[np.floating] = np.float64,
                   loop: str = "sweep") -> KernelArguments:
        """The arguments in ``dtype``, with the 1/sqrt variant measured fastest in ``loop``
        (``sim.loops.host_tuning.LOOPS``) in float64."""
        scalar = np.dtype(dtype).type
        values = registry.kernel_values("terms", model)
        terms = Terms(
            linear=True if model.linear else None,
            out_of_plane=None if model.dim == 2 else True,
            inverse_mass=read_only(np.ascontiguousarray(model.inverse_masses, dtype=dtype)),
            uniform_inverse_mass=(
                scalar(model.inverse_masses.flat[0]) if model.uniform_mass else None
            ),
            damped=True if registry.velocity_dependent(model) else None,
            **{field.name: in_precision(field.kind, values[field.name], scalar)
               for field in registry.fields("terms")},
        )
        parameters = model.kernel_parameters.as_type(
            dtype, host_tuning.inverse_sqrt_estimate(loop) if scalar is np.float64 else None
        )
        return cls(terms, parameters)


def leapfrog_family(model: Model) -> str:
    """"leapfrog" where the fused leapfrog sweeps carry every term of ``model`` (nonlinear
    springs, no velocity-dependent force, no term the leapfrog lacks: ``sim.forces.registry``),
    else "sweep"."""
    plain = registry.leapfrog(model) and not (registry.velocity_dependent(model) or model.linear)
    return "leapfrog" if plain else "sweep"


def leapfrog_work(model: Model, blocks: int, dtype: type[np.floating]) -> LeapfrogWork:
    """The fused leapfrog's scratch for ``blocks`` row blocks of ``model``."""
    return LeapfrogWork(boundary=np.zeros((blocks + 1, 3, model.nx), dtype=dtype),
                        below=np.zeros((blocks, 3, model.nx), dtype=dtype),
                        horizontal=np.zeros((blocks, 3, model.nx + 1), dtype=dtype))


class Integrator:
    """Base class of the compiled steppers: ``advance(state, n, dt)`` moves the state n steps.

    ``dtype`` is the precision of the state and the arithmetic; ``threads`` the number of row
    blocks the sweeps run on in parallel.
    """

    name: ClassVar[str]
    work_arrays: ClassVar[int] = 1
    drive: np.ndarray | None = None
    """The drive table (``sim.forces.drive_table``) the steps apply, when ``in_step`` has "drive"."""
    sponge: object | None = None
    """The absorbing layer (``sim.forces.absorbing_layer.MatchedLayer``), when ``in_step`` has "sponge"."""
    ring_rows: ClassVar[int | None] = None
    """Rows kept by the work arrays when they are ring buffers (None: the whole lattice)."""

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        self.model = model
        self.dtype = np.dtype(dtype).type
        self.threads = int(threads)
        self.kernel = KernelArguments.from_model(model, self.dtype, self.loop_family(model))
        rows = model.ny if self.ring_rows is None else self.ring_rows
        shape = (model.dim, rows, model.nx)
        self.work = [np.zeros(shape, dtype=self.dtype) for _ in range(self.work_arrays)]
        blocks = min(self.threads, model.ny)
        self._block_starts = np.linspace(0, model.ny, blocks + 1).round().astype(np.int64)
        self._full_work: list[np.ndarray] = []
        self._sweeps_for: tuple[tuple, np.ndarray] | None = None

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

    @classmethod
    def loop_family(cls, model: Model) -> str:
        """The loop family (``sim.loops.host_tuning.LOOPS``) whose 1/sqrt variant the kernels use."""
        return "sweep"

    def invalidate(self) -> None:
        """The state was changed from outside (a drag, a reset): drop any cached forces."""

    def assume_forces_of(self, state: State) -> bool:
        """Take the cached forces as those of ``state`` (whatever they hold), so that the next
        ``advance`` starts with the step loop, not with a force pass of its own, whatever
        happens to the state before it: for compiling the two apart, side by side
        (``sim.runtime.warming``).  Returns whether this stepper has such a first force pass."""
        return False

    def first_forces(self, state: State) -> bool:
        """Compute the forces of ``state`` that the next ``advance`` starts from (its first
        force pass), without stepping: the other half of ``assume_forces_of``.  Returns whether
        this stepper has such a first force pass."""
        return False

    def loop_shares_force_pass(self, n: int) -> bool:
        """Whether the loop of ``advance(n)`` is made of the first force pass's compiled parts
        (compiled after it, it reads them from the cache instead of compiling them too)."""
        return True

    @property
    def in_step(self) -> frozenset[str]:
        """The instruments this stepper applies inside its steps ("drive", "sponge"); the
        simulation applies the others between steps (``sim.model.forcing``)."""
        return frozenset()

    def _common(self, state: State) -> tuple:
        """The arguments every loop takes first: (terms, parameters, position, velocity)."""
        return (*self.kernel, state.positions, state.velocities)

    def _dt(self, dt: float) -> np.floating:
        return self.dtype(dt)

    def _sweeps(self, table: SplittingTable, n: int, dt: float) -> np.ndarray:
        """The (kick, drift) weights of ``n`` steps of ``table`` (``SplittingTable.sweeps``) in
        the state's precision, kept for the next call with the same n and dt (a run calls
        with the same chunk again and again)."""
        key = (table, n, dt)
        if self._sweeps_for is None or self._sweeps_for[0] != key:
            self._sweeps_for = (key, table.sweeps(n, dt).astype(self.dtype))
        return self._sweeps_for[1]

    def advance(self, state: State, n: int, dt: float) -> None:
        raise NotImplementedError


class Euler(Integrator):
    name = "euler"
    work_arrays = 0

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel:
            self._start_threads()
            state.dissipated += row_blocks.euler_steps_parallel(
                n, self._dt(dt), *self._common(state), *self._full_arrays(1), self._block_starts
            )
        else:
            state.dissipated += stepping.euler_steps(n, self._dt(dt), *self._common(state))
        state.advance_clock(n, dt)


class CarriedForces(Integrator):
    """A stepper that keeps the last forces of a call for the next (velocity Verlet and the
    splitting methods: the first kick of a step uses the forces of the last drift), recomputed
    whenever the state may have changed since (``invalidate``, a new revision or time)."""

    @classmethod
    def loop_family(cls, model: Model) -> str:
        """Undamped nonlinear springs: the steps between the first and the last run as fused
        leapfrog sweeps over row blocks (one block per thread), the fastest loop shape; it has
        no diagonal springs, which the row sweeps carry."""
        return leapfrog_family(model)

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        self._cached_for: tuple[int, float] | None = None
        self._assumed = False  # assume_forces_of: the next advance starts with its loop
        self._leapfrog = self.loop_family(model) == "leapfrog"
        self._leapfrog_work = leapfrog_work(model, self._block_starts.size - 1, self.dtype)

    def invalidate(self) -> None:
        self._cached_for = None

    def assume_forces_of(self, state: State) -> bool:
        self._assumed = True
        return True

    def first_forces(self, state: State) -> bool:
        if self.parallel:
            self._start_threads()
        self._first_pass(state)
        self._cached_for = (state.revision, state.time)
        return True

    def _first_pass(self, state: State) -> None:
        """The forces an ``advance`` starts from, into ``work[0]``."""
        self._accelerations(state)

    def _forces_stale(self, state: State) -> bool:
        """Whether ``advance`` must compute its first forces (not assumed, not kept)."""
        return self._cached_for != (state.revision, state.time) and not self._assumed

    def _keep_forces(self, state: State) -> None:
        """The forces in ``work[0]`` are those of ``state`` now (the end of an ``advance``)."""
        self._cached_for = (state.revision, state.time)
        self._assumed = False

    def _accelerations(self, state: State) -> float:
        """a(x, v) of the state into ``work[0]`` (on the row blocks' threads when parallel);
        returns the dissipated power (W)."""
        if self.parallel:
            return row_blocks.accelerations_parallel(
                *self._common(state), self.work[0], self._block_starts
            )
        return stepping.accelerations(*self._common(state), self.work[0])


class Verlet(CarriedForces):
    name = "verlet"
    work_arrays = 2

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        self._power = 0.0
        blocks = self._block_starts.size - 1
        self._drive_power = 0.0
        self._totals = np.zeros(3)  # drive work (J), layer take (J), drive power (W)
        self._block_totals = np.zeros((blocks, 2))
        self._saved = np.zeros((1, 3))  # velocities of driven particles (m/s)

    def _first_pass(self, state: State) -> None:
        self._driven_accelerations(state, state.time)

    def loop_shares_force_pass(self, n: int) -> bool:
        return not (self._leapfrog and n >= 2)  # the leapfrog fuses its own

    @property
    def in_step(self) -> frozenset[str]:
        if self.parallel and not self._leapfrog:
            return frozenset()
        return frozenset(("drive", "sponge"))

    def _driven_accelerations(self, state: State, time: float, lead: float = 0.0) -> None:
        """Lattice accelerations into ``work[0]`` and the drive at ``time`` added to them; the
        drive's power is taken at the velocities ``lead`` (s) later (half a step for a
        leapfrog's half-step velocities)."""
        self._power = self._accelerations(state)
        if self.drive is not None:
            self._drive_power = instruments.drive_rows(
                time, self.drive, instruments.EVERY_KIND, self.work[0], state.velocities, lead)

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel:
            self._start_threads()
        layer = self.sponge
        if layer is not None:  # half the layer's action before the steps, half after them
            layer.act(state, 0.5 * dt, self.kernel.parameters)
            if self.kernel.terms.damped is not None:
                self.invalidate()  # the forces depend on the velocities it kicked
        if self._forces_stale(state):
            self._driven_accelerations(state, state.time)
        step = self._dt(dt)
        drive = self.drive
        sponge = None
        if layer is not None:
            sponge = layer.arguments(0.5 * dt, self.dtype, self._block_starts.size - 1)
        if drive is not None and self._saved.shape[0] < drive.shape[0]:
            self._saved = np.zeros((drive.shape[0], 3))
        instrumented = drive is not None or sponge is not None
        start = state.time
        # the drive's work is the trapezoid of its power at whole steps on every path: half
        # steps at the ends here, and F . (v_before + v_after) / 2 = F . v(t) per kick between
        if self._leapfrog and n >= 2:
            acceleration = self.work[0]
            half = 0.5 * dt
            state.driven += half * self._drive_power
            sweeps = self._sweeps(VELOCITY_VERLET, n, dt)  # (dt/2, dt), then (dt, dt)s
            stepping.kick_drift_all(sweeps[0, 0], sweeps[0, 1], state.positions,
                                    state.velocities, acceleration)
            steps = leapfrog.leapfrog_steps_parallel if self.parallel else leapfrog.leapfrog_steps
            self._block_totals[:] = 0.0
            steps(
                sweeps[1:], *self._common(state), self._block_starts,
                self._leapfrog_work, start + dt, drive, self._saved, sponge, self._block_totals,
            )
            state.driven += float(self._block_totals[:, 0].sum())
            state.dissipated += float(self._block_totals[:, 1].sum())
            self._driven_accelerations(state, start + n * dt, half)
            stepping.kick_all(self.dtype(half), state.velocities, acceleration)
            state.driven += half * self._drive_power
        elif self.parallel and not instrumented:
            dissipated, self._power = row_blocks.verlet_steps_parallel(
                n, step, *self._common(state), self.work[0], self._power, self.work[1],
                self._block_starts,
            )
            state.dissipated += dissipated
        else:
            totals = self._totals
            totals[:] = (0.0, 0.0, self._drive_power)
            dissipated, self._power = stepping.verlet_steps(
                n, step, *self._common(state), self.work[0], self._power, self.work[1], start,
                drive, sponge, totals,
            )
            state.dissipated += dissipated + totals[1]
            state.driven += totals[0]
            self._drive_power = float(totals[2])
        if layer is not None:
            layer.act(state, 0.5 * dt, self.kernel.parameters)
        state.advance_clock(n, dt)
        self._keep_forces(state)


class Splitting(CarriedForces):
    """A splitting method given by its table (``sim.integrators.splitting``): kick and drift
    sweeps with the table's weights.  Undamped nonlinear springs run the fused leapfrog sweeps
    (``sim.loops.leapfrog``, row blocks on threads); other lattices a force sweep and a kick and
    drift pass per stage.  The last forces of a call are kept for the next (the first kick of a
    step uses the forces of the last drift), recomputed whenever the state or the model may have
    changed.  ``Splitting.of(table)`` is the stepper class of one table."""

    table: ClassVar[SplittingTable]
    work_arrays = 1

    @classmethod
    def of(cls, table: SplittingTable, name: str) -> type[Splitting]:
        """The stepper class that runs ``table``, registered as ``name``."""
        return type(f"Splitting[{table.label}]", (cls,), {
            "table": table, "name": name, "__doc__": f"{table.label}: {cls.__doc__}"})

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        self._totals = np.zeros((self._block_starts.size - 1, 2))

    def loop_shares_force_pass(self, n: int) -> bool:
        return not self._leapfrog

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel:
            self._start_threads()
        if self._forces_stale(state):
            self._accelerations(state)
        acceleration = self.work[0]
        sweeps = self._sweeps(self.table, n, dt)
        stepping.kick_drift_all(sweeps[0, 0], sweeps[0, 1], state.positions, state.velocities,
                                acceleration)
        if self._leapfrog:
            steps = leapfrog.leapfrog_steps_parallel if self.parallel else leapfrog.leapfrog_steps
            steps(sweeps[1:], *self._common(state), self._block_starts, self._leapfrog_work,
                  state.time, None, None, None, self._totals)
        else:
            for kick, drift in sweeps[1:]:
                self._accelerations(state)
                stepping.kick_drift_all(kick, drift, state.positions, state.velocities,
                                        acceleration)
        self._accelerations(state)
        stepping.kick_all(self.dtype(self.table.kicks[-1] * dt), state.velocities, acceleration)
        state.advance_clock(n, dt)
        self._keep_forces(state)


class RungeKutta(Integrator):
    """A Runge-Kutta method given by its table (``sim.integrators.butcher``): one wavefront per step
    over the whole lattice on one thread; on several threads one wavefront per row block (blocks
    of at least 2 (halo + 1) rows, one sweep per step), or on lattices too thin for that one
    parallel phase per stage.  ``RungeKutta.of(table)`` is the stepper class of one table."""

    table: ClassVar[ButcherTable]
    work_arrays = 4

    @classmethod
    def of(cls, table: ButcherTable) -> type[RungeKutta]:
        """The stepper class that runs ``table``."""
        return type(f"RungeKutta[{table.label}]", (cls,), {
            "table": table, "name": table.label, "ring_rows": table.stages,
            "__doc__": f"{table.label}: {cls.__doc__}",
        })

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64, threads: int = 1) -> None:
        super().__init__(model, dtype, threads)
        self._coefficients = self.table.coefficients
        halo = wavefront.halo_rows(self.table.stages)
        blocks = min(self.threads, model.ny // (2 * (halo + 1)))
        self._blocks: np.ndarray | None = None
        self._block_work: tuple[Fields, ...] = ()
        if blocks >= 2:
            self._blocks = np.linspace(0, model.ny, blocks + 1).round().astype(np.int64)
            ring = (blocks, model.dim, wavefront.block_ring(self.table.stages), model.nx)
            edges = (blocks, model.dim, 2 * (halo + 1), model.nx)
            self._block_work = (  # stage inputs, sums, deferred rows
                *(Fields(*(np.zeros(ring, dtype=self.dtype) for _ in range(2))) for _ in range(2)),
                Fields(*(np.zeros(edges, dtype=self.dtype) for _ in range(2))),
            )

    @property
    def in_step(self) -> frozenset[str]:
        return frozenset(("drive",))

    def advance(self, state: State, n: int, dt: float) -> None:
        if self.parallel:
            self._start_threads()
        work = np.zeros(1)  # the drive's work (J)
        instruments_arguments = (state.time, self.drive, work)
        table = self._coefficients
        if self.parallel and self._blocks is not None:
            state.dissipated += row_blocks.runge_kutta_blocks(
                table, n, self._dt(dt), *self._common(state), *self._block_work,
                self._blocks, *instruments_arguments,
            )
        elif self.parallel:
            full = self._full_arrays(6)  # stage inputs, next inputs, sums
            state.dissipated += row_blocks.runge_kutta_phases(
                table, n, self._dt(dt), *self._common(state), Fields(*full[0:2]),
                Fields(*full[2:4]), Fields(*full[4:6]), self._block_starts,
                *instruments_arguments,
            )
        else:
            state.dissipated += stepping.runge_kutta_steps(
                table, n, self._dt(dt), *self._common(state), Fields(*self.work[0:2]),
                Fields(*self.work[2:4]), *instruments_arguments,
            )
        state.driven += float(work[0])
        state.advance_clock(n, dt)
