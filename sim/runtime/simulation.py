"""``Simulation``: the scripting surface that ties a model, a state and an integrator together.

    >>> import sim
    >>> s = sim.Simulation(sim.scenes.build("chain"), integrator="verlet", dt=0.01)
    >>> s.positions[2, 1] += 0.1      # displace the middle particle transversally
    >>> s.step(1000)
    >>> s.energy().total

Blow-up detection: steps run in chunks; after each chunk the state is checked by the rule of
``sim.runtime.blowup`` (non-finite values, energy beyond what the start, gravity and drivers can supply,
particles beyond a bound set by the lattice's size).  A bad chunk is rolled back and replayed
one step at a time, so the ``BlowUpError`` leaves the state exactly as it was before the step that went wrong.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sim.devices import check_device
from sim.integrators.registry import (
    LABELS,
    check_integrator_name,
    check_precision,
    check_threads,
    describe,
    make_integrator,
    names_on,
)
from sim.model import schema
from sim.model.lattice import Model, ModelError
from sim.model.state import State
from sim.runtime.blowup import BlowUpRule, runaway_factor
from sim.scenes import run_limits
from sim.scenes.building import Scene
from sim.theory import observables


class BlowUpError(RuntimeError):
    """The integration went unstable.  The simulation keeps the state before the bad step.

    Attributes: ``integrator``, ``dt``, ``step`` (index of the step that failed), ``time``,
    ``stable_dt`` (the stability limit, None if there is none) and ``reason``; ``run``: what is
    known of the scene's own run's limit (``sim.scenes.run_limits.describe``), if anything.
    """

    def __init__(
        self, integrator: str, dt: float, step: int, time: float, stable_dt: float | None,
        reason: str, run: str | None = None,
    ) -> None:
        self.integrator = integrator
        self.dt = dt
        self.step = step
        self.time = time
        self.stable_dt = stable_dt
        self.reason = reason
        if stable_dt is None:
            limit = "this integrator has no stable step on this lattice"
        else:  # the theory about the rest lattice; a sag or large motion lowers the real one
            limit = f"the small-amplitude stability limit is dt = {stable_dt:.6g} s"
            if dt <= stable_dt:
                limit += (", above this dt: large displacements or a sag under gravity stiffen "
                          "the springs and lower the limit of this run")
            if run is not None:
                limit += "; " + run
        super().__init__(
            f"{LABELS.get(integrator, integrator)} blew up at step {step} (t = {time:.6g} s, "
            f"dt = {dt:.6g} s): {reason}; {limit}. The state before that step is kept."
        )


def _sentence(text: str) -> str:
    """``text`` as a sentence: a capital first letter and a full stop."""
    return text[:1].upper() + text[1:] + "."


def _check_dt(dt: Any) -> float:
    try:
        value = float(dt)
    except (TypeError, ValueError):
        raise ModelError(f"dt must be a number, got {dt!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise ModelError(f"dt must be a positive finite number of seconds, got {dt!r}")
    return schema.number(value, "dt (s)", *schema.BOUNDS["dt"], low_open=True, error=ModelError)


class _ParticleView:
    """A ``Simulation`` attribute that is a writable (n_particles, dim) view of one of its state's
    arrays (the ``State`` method ``view_method`` gives it).  Assigning it is an edit of the state
    (the energy references are taken again); reading it is not: the simulation remembers the
    state as it was when the view was handed out and counts an edit only if the values written
    through the view changed it (so looking never changes a trajectory)."""

    def __init__(self, view_method: str, doc: str) -> None:
        self.view_method = view_method
        self.__doc__ = doc + "; a writable view of the state."

    def __get__(self, simulation: Simulation | None, owner: type | None = None) -> Any:
        if simulation is None:
            return self
        simulation._view_handed_out()
        return getattr(simulation.state, self.view_method)()

    def __set__(self, simulation: Simulation, value: np.ndarray) -> None:
        simulation._state_touched()
        getattr(simulation.state, self.view_method)()[...] = value


class Simulation:
    """A running lattice.  See the module docstring for an example.

    ``positions`` / ``velocities`` are (n_particles, dim) views (float64, or float32 with
    ``precision="float32"``) that may be written into
    (particle p = j * nx + i); ``time`` in seconds; ``energy()``, ``strains()``, ``stable_dt()``.
    Parameters change mid-run through ``set_parameters`` / ``set_masses``; the integrator and dt
    through the ``integrator`` and ``dt`` properties.  Nothing is lost by any of these changes.
    ``device="cuda"`` runs velocity Verlet of a planar lattice of nearest springs on an NVIDIA GPU
    (``sim.devices.cuda_stepper``; the extra ``gpu``).
    """

    chunk_steps = 64

    def __init__(
        self, scene: Any, integrator: str | None = None, dt: float | None = None,
        precision: str | None = None, threads: int = 1, device: str = "cpu",
    ) -> None:
        if isinstance(scene, Model):
            scene = Scene(name="custom", model=scene)
        if not isinstance(scene, Scene):
            raise TypeError(f"Simulation needs a sim.scenes.Scene or a sim.Model, got {scene!r}")
        self.scene = scene
        self._model = scene.model
        self._device = check_device(device)
        default = scene.integrator
        if integrator is None and default not in names_on(self._device):
            default = names_on(self._device)[0]
        self._integrator_name = check_integrator_name(integrator or default, self._model)
        self._dt = _check_dt(dt if dt is not None else scene.dt)
        self._precision = check_precision(precision or getattr(scene, "precision", "float64"))
        self._threads = check_threads(threads)
        self.state = State.from_particle_arrays(
            self._model, scene.initial_positions, scene.initial_velocities, self._precision
        )
        self._integrator = self._make_integrator()
        self._forcing = self._make_forcing()
        self._stability_cache: dict[str, observables.StabilityLimit] = {}
        self._rule: BlowUpRule | None = None
        self._balance_reference: tuple[float, float] | None = None
        self._driven_at_reference = 0.0
        self._energy_cache: tuple[tuple, observables.Energy] | None = None
        self._checkpoint = self.state.copy()
        self._watched: State | None = None

    # --- state -----------------------------------------------------------------------------------

    @property
    def model(self) -> Model:
        return self._model

    positions = _ParticleView("particle_positions", "(n_particles, dim) positions (m)")
    velocities = _ParticleView("particle_velocities", "(n_particles, dim) velocities (m/s)")

    @property
    def rest_positions(self) -> np.ndarray:
        return self._model.rest_positions

    @property
    def masses(self) -> np.ndarray:
        """(n_particles,) masses (kg), read-only; change them with ``set_masses``."""
        return self._model.masses.reshape(-1)

    @property
    def time(self) -> float:
        return self.state.time

    @property
    def step_count(self) -> int:
        return self.state.step

    def _state_touched(self) -> None:
        self.state.revision += 1
        self._rule = None
        self._balance_reference = None
        self._watched = None

    def _view_handed_out(self) -> None:
        """A writable view is leaving: keep a copy of the state to tell later whether it was
        written through (``_sync``)."""
        if self._watched is None:
            self._watched = self.state.copy()

    def _sync(self) -> None:
        """Count an edit if the state's values differ (bit for bit) from when a view was last
        handed out; reading a view changes nothing."""
        watched = self._watched
        if watched is None:
            return
        self._watched = None
        state = self.state
        if not (_same_bits(watched.positions, state.positions)
                and _same_bits(watched.velocities, state.velocities)):
            self._state_touched()

    def peek_positions(self) -> np.ndarray:
        """A copy of the positions (n_particles, dim) that does not count as an edit (for viewers)."""
        return self.state.particle_positions().copy()

    # --- integrator, step, parameters -------------------------------------------------------------

    @property
    def integrator(self) -> str:
        return self._integrator_name

    @integrator.setter
    def integrator(self, name: str) -> None:
        name = check_integrator_name(name, self._model)
        previous, self._integrator_name = self._integrator_name, name
        try:
            self._integrator = self._make_integrator()
        except ModelError:
            self._integrator_name = previous
            raise

    @property
    def device(self) -> str:
        """Where the steps run: "cpu", or "cuda" (an NVIDIA GPU, ``sim.devices.cuda_stepper``)."""
        return self._device

    def _make_integrator(self, model: Model | None = None):
        model = self._model if model is None else model
        if self._device == "cuda":
            from sim.devices.cuda_stepper import CudaVerlet

            return CudaVerlet(model, self._precision, self._integrator_name)
        return make_integrator(
            self._integrator_name, model, self._precision.__name__, self._threads
        )

    @property
    def precision(self) -> str:
        """"float64" or "float32": the precision of the state and the kernels' arithmetic
        (energies are summed in float64 either way).  Setting it converts the state, so
        ``positions`` / ``velocities`` views taken before refer to the old arrays."""
        return self._precision.__name__

    @precision.setter
    def precision(self, value: str) -> None:
        dtype = check_precision(value)
        if dtype is self._precision:
            return
        self._precision = dtype
        self.state = self.state.as_type(dtype)
        self.state.revision += 1
        self._checkpoint = self.state.copy()
        self._integrator = self._make_integrator()
        self._rule = None

    @property
    def threads(self) -> int:
        """Threads the compiled sweeps run on (row blocks); results equal one thread's to
        round-off (see ``docs/api.md``)."""
        return self._threads

    @threads.setter
    def threads(self, value: int) -> None:
        self._threads = check_threads(value)
        self._integrator = self._make_integrator()

    @property
    def dt(self) -> float:
        return self._dt

    @dt.setter
    def dt(self, value: float) -> None:
        self._dt = _check_dt(value)

    def set_parameters(self, **changes: Any) -> None:
        """Change model parameters mid-run (any keyword of ``Model.create`` except nx, ny, dim),
        e.g. ``stiffness``, ``rest_length``, ``damping``, ``drag``, ``gravity``, ``linear``, ``mass``.
        The state is kept; invalid values raise ``ModelError`` and change nothing."""
        for fixed in ("nx", "ny", "dim"):
            if fixed in changes and changes[fixed] != getattr(self._model, fixed):
                raise ModelError(f"{fixed} cannot change mid-run; build a new scene instead")
        self._set_model(self._model.replace(**changes))

    def set_masses(self, masses: float | np.ndarray) -> None:
        """Replace the masses: a scalar, an (n_particles,) or an (ny, nx) array of kg."""
        self._set_model(self._model.replace(mass=masses))

    def _make_forcing(self):
        from sim.model.forcing import Forcing

        return Forcing(self._model) if self._model.has_forcing else None

    def _set_model(self, model: Model) -> None:
        # check first: a model the current integrator cannot run changes nothing
        check_integrator_name(self._integrator_name, model)
        integrator = self._make_integrator(model)
        self._model = model
        self._integrator = integrator
        self._forcing = self._make_forcing()
        self._stability_cache.clear()
        self._rule = None
        self._balance_reference = None

    def reset(self) -> None:
        """Back to the scene's initial state (time 0) with the current parameters."""
        fresh = State.from_particle_arrays(
            self._model, self.scene.initial_positions, self.scene.initial_velocities,
            self._precision,
        )
        self.state.restore(fresh)
        self.state.time = 0.0
        self.state.step = 0
        self.state.dissipated = 0.0
        self.state.driven = 0.0
        self._integrator.invalidate()
        self._rule = None
        self._balance_reference = None

    # --- observables ------------------------------------------------------------------------------

    def energy(self) -> observables.Energy:
        """Kinetic, spring, gravity, potential, dissipated and total energy (J).

        Computed once per state: the blow-up check after each chunk of steps computes it anyway,
        so a viewer asking for it afterwards gets it for free."""
        self._sync()
        key = (self.state.revision, self.state.step, self.state.time, id(self._model))
        if self._energy_cache is None or self._energy_cache[0] != key:
            self._energy_cache = (key, observables.energy(self._model, self.state))
        return self._energy_cache[1]

    def energy_balance_error(self) -> float:
        """Relative energy-balance error since the state was last set (built, reset, moved,
        or its parameters changed): (kinetic + potential + dissipated - its value then) divided by
        ``energy_scale()``.  Exactly 0 for the exact dynamics; its sign says whether the
        integrator gains (+) or loses (-) energy."""
        self._sync()
        scale = self.energy_scale()
        if scale <= 0.0:
            return 0.0
        return (self.energy().balance - self._balance_reference[0]) / scale

    def energy_scale(self) -> float:
        """The energy in play (J), the denominator of ``energy_balance_error``: the kinetic and
        spring energy (above the rest lattice) when the state was last set, plus the energy
        gravity releases as the lattice sags from rest to its equilibrium (1/2 f.K^-1 f of the
        linearised lattice).  A scene that starts at rest under gravity (the catenary) thus
        measures its error against the energy of its fall, and a driven one against the work
        the driver did since then when that is larger."""
        if self._balance_reference is None:
            self._balance_reference = self._balance_now()
        driven = abs(self.energy().driven - self._driven_at_reference)
        return max(self._balance_reference[1], driven)

    def _balance_now(self) -> tuple[float, float]:
        from sim.theory.prediction import energy_in_play

        energy = self.energy()
        self._driven_at_reference = energy.driven
        return energy.balance, energy_in_play(self._model, energy)

    def strains(self) -> np.ndarray:
        """(n_springs,) strain of every spring, in ``model.springs`` order."""
        return observables.strains(self._model, self.state.positions)

    def stability(self, integrator: str | None = None) -> observables.StabilityLimit:
        """Stability limit of an integrator (default: the current one) with an explanation."""
        name = check_integrator_name(integrator or self._integrator_name, self._model)
        if name not in self._stability_cache:
            limit = observables.stability_limit(self._model, name)
            measured = run_limits.run_limit(self.scene, self._model, name)
            if measured is not None:
                limit = dataclasses.replace(limit, run_dt=measured, reason=(
                    limit.reason + " " + _sentence(
                        run_limits.describe(self.scene.name, name, measured))))
            self._stability_cache[name] = limit
        return self._stability_cache[name]

    def stable_dt(self, integrator: str | None = None) -> float | None:
        """Largest stable dt (s) of the integrator on this model; None if no dt is stable."""
        return self.stability(integrator).dt

    # --- stepping ---------------------------------------------------------------------------------

    def step(self, n: int = 1) -> None:
        """Advance n steps.  Raises ``BlowUpError`` (state kept before the bad step) if the run
        goes unstable; a dt above the stability limit is allowed and only detected while running."""
        if isinstance(n, bool) or int(n) != n or n < 0:
            raise ValueError(f"n must be a whole number of steps >= 0, got {n!r}")
        remaining = int(n)
        self._sync()
        if self._rule is None:
            self._rule = BlowUpRule.starting_from(self._model, self.energy())
        if self._balance_reference is None:
            self._balance_reference = self._balance_now()
        while remaining > 0:
            chunk = min(remaining, self.chunk_steps)
            self._save_checkpoint()
            self._advance(chunk)
            problem = self._problem()
            if problem is not None:
                self.state.restore(self._checkpoint)
                self._integrator.invalidate()
                self._find_bad_step(chunk)
            remaining -= chunk

    def _advance(self, n: int) -> None:
        """n steps of the integrator; with a driver or a sponge, one at a time between their
        half actions (``sim.model.forcing``), else all in one compiled call."""
        forcing = self._forcing
        integrator = self._integrator
        if forcing is None:
            integrator.advance(self.state, n, self._dt)
            return
        dt = self._dt
        in_step = integrator.in_step
        drive_inside = forcing.drives and "drive" in in_step
        sponge_inside = forcing.has_sponge and "sponge" in in_step
        integrator.drive = forcing.drive_table() if drive_inside else None
        integrator.sponge = forcing.sponge_arrays(dt, integrator.dtype) if sponge_inside else None
        if drive_inside and forcing.moves_particles:
            forcing.place(self.state)  # exactly on its prescription at the start
            integrator.invalidate()
        drive_between = forcing.drives and not drive_inside
        sponge_between = forcing.has_sponge and not sponge_inside
        if not drive_between and not sponge_between:
            integrator.advance(self.state, n, dt)
            return
        # the rest between the steps (Strang splitting); forces that depend on velocities, or a
        # moved particle, make cached forces stale
        refresh = (drive_between and forcing.moves_particles) or self._model.is_damped
        if sponge_between:
            forcing.sponge(self.state, 0.5 * dt)
        for remaining in range(n - 1, -1, -1):
            if drive_between:
                forcing.drive_before(self.state, dt)
            if refresh:
                integrator.invalidate()
            integrator.advance(self.state, 1, dt)
            if drive_between:
                forcing.drive_after(self.state, dt)
            if sponge_between:
                forcing.sponge(self.state, 0.5 * dt)
                if remaining:  # the next step's first half: the same as one step at a time
                    forcing.sponge(self.state, 0.5 * dt)
            if refresh:
                integrator.invalidate()

    def _save_checkpoint(self) -> None:
        """Copy the state into the preallocated checkpoint (no allocation per chunk)."""
        if (self._checkpoint.positions.shape != self.state.positions.shape
                or self._checkpoint.positions.dtype != self.state.positions.dtype):
            self._checkpoint = self.state.copy()
            return
        np.copyto(self._checkpoint.positions, self.state.positions)
        np.copyto(self._checkpoint.velocities, self.state.velocities)
        self._checkpoint.time = self.state.time
        self._checkpoint.step = self.state.step
        self._checkpoint.dissipated = self.state.dissipated
        self._checkpoint.driven = self.state.driven

    def _find_bad_step(self, chunk: int) -> None:
        for _ in range(chunk):
            checkpoint = self.state.copy()
            self._advance(1)
            problem = self._problem()
            if problem is not None:
                self.state.restore(checkpoint)
                self._integrator.invalidate()
                raise BlowUpError(
                    self._integrator_name, self._dt, checkpoint.step + 1, checkpoint.time,
                    self.stable_dt(), problem, run=self._run_limit_sentence(),
                )
        # The chunk failed but single steps did not (cannot happen for a deterministic kernel).

    def _run_limit_sentence(self) -> str | None:
        """What is known of this scene's own run's limit, for a blow-up's message."""
        limit = self.stability()
        if limit.run_dt is None:
            return None
        return run_limits.describe(self.scene.name, self._integrator_name, limit.run_dt)

    def _problem(self) -> str | None:
        return self._rule.problem(self._model, self.state, self.energy(),
                                  runaway_factor(describe(self._integrator_name).symplectic))


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two arrays of one shape and type hold the same bits (NaNs included)."""
    if a.shape != b.shape or a.dtype != b.dtype:
        return False
    bits = f"u{a.dtype.itemsize}"
    return bool(np.array_equal(a.view(bits), b.view(bits)))
