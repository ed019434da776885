"""What the web page can ask of the simulation, as commands posted to the runner.

No viser here: the GUI and the scene callbacks call ``SimulationControl`` methods, which only
``post`` commands to the runner (they run in the simulation thread between steps, never in the
middle of one).  Every method returns the command's ``concurrent.futures.Future``, so tests (and
callers that care) can wait for it.

``LatticeRunner`` is ``sim.runtime.runner.Runner`` plus *pins*: particles held at a position while a
browser drags them.  Pins belong to an owner (a client id), so a browser that disconnects
mid-drag is released with ``release(owner)`` and nothing stays stuck.

Drive and boundary commands (``drive``, ``stop_driving``, ``set_boundary``) build the changed
model first and refuse (raising, changing nothing) when the running integrator cannot run it, e.g.
the exact normal-mode solver on a driven or absorbing lattice.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

import sim
from sim.model.forcing import Driver
from sim.runtime.blowup import reach as blowup_reach
from sim.runtime.runner import Runner
from sim.runtime.warming import KernelPreparer, shared_preparer

MASS_PATTERNS = ("uniform", "ionic")
"""Mass patterns the page offers: one mass everywhere, or a heavy/light checkerboard."""
MAX_STEPS_PER_FRAME = 100
"""Most steps the loop runs between two published frames (Pause waits for at most that many)."""
DRIVE_RAMP = 2.0
"""Seconds over which a drive started from the page ramps up (so it does not kick the lattice)."""


class LatticeRunner(Runner):
    """A ``Runner`` that can hold particles in place (pins) while they are dragged.

    Pins are only touched from commands (the simulation thread), so they need no lock.  While any
    pin exists the runner's public ``before_step`` hook puts pinned particles back (velocity
    zero) before each step and after the last, so a dragged particle follows the pointer exactly;
    without pins the hook is off and the steps run as one compiled chunk.

    Its kernels are prepared before it steps (``preparer``, default the process's own,
    ``sim.runtime.warming``), so the page's commands answer while a scene's kernels compile.
    """

    def __init__(self, simulation: sim.Simulation, steps_per_frame: int = 1,
                 max_fps: float = 60.0, preparer: KernelPreparer | None = None) -> None:
        super().__init__(simulation, steps_per_frame=steps_per_frame, max_fps=max_fps,
                         preparer=preparer or shared_preparer())
        self.pins: dict[Hashable, dict[int, np.ndarray]] = {}

    def pinned_particles(self) -> dict[int, np.ndarray]:
        """Every held particle index -> its target position (dim,) in m (later owners win)."""
        merged: dict[int, np.ndarray] = {}
        for held in self.pins.values():
            merged.update(held)
        return merged

    def hold(self, owner: Hashable, targets: dict[int, np.ndarray]) -> None:
        """Hold particles (index -> position) for ``owner`` (call from a command)."""
        self.pins.setdefault(owner, {}).update(targets)
        self.before_step = self.apply_pins

    def let_go(self, owner: Hashable | None = None, everyone: bool = False) -> None:
        """Release ``owner``'s particles, or every pin (call from a command)."""
        if everyone:
            self.pins.clear()
        else:
            self.pins.pop(owner, None)
        if not self.pins:
            self.before_step = None

    def apply_pins(self, simulation: sim.Simulation) -> None:
        """Put every held particle at its target, at rest (runs in the simulation thread)."""
        pinned = self.pinned_particles()
        if not pinned:
            return
        indices = np.fromiter(pinned, dtype=np.int64, count=len(pinned))
        targets = np.stack([pinned[index] for index in pinned.keys()])
        positions = simulation.positions
        positions[indices] = targets
        simulation.velocities[indices] = 0.0


def check_targets(model: sim.Model, indices: np.ndarray, targets: np.ndarray) -> None:
    """Refuse (ValueError) targets for particles ``indices`` that are not finite or lie further
    from the particles' rest positions than a run may move them (``sim.runtime.blowup.reach``)."""
    where = targets[:, : model.dim]
    if not np.all(np.isfinite(where)):
        raise ValueError("target positions must be finite")
    if indices.size and (indices.min() < 0 or indices.max() >= model.n_particles):
        raise IndexError("particle index out of range")
    reach = blowup_reach(model)
    if indices.size and np.max(np.abs(where - model.rest_positions[indices])) > reach:
        raise ValueError(f"a particle may be moved at most {reach:.3g} m from its rest position")


class SimulationControl:
    """The page's commands.  Each method posts to the runner and returns a Future."""

    def __init__(self, runner: LatticeRunner) -> None:
        self.runner = runner
        self.page_driver: Driver | None = None
        """The last driver started by ``drive`` (only touched in commands): Reset starts it
        again at time 0 instead of at the time it was first started."""

    @property
    def simulation(self) -> sim.Simulation:
        return self.runner.simulation

    # --- run -------------------------------------------------------------------------------------

    def play(self) -> None:
        self.runner.play()

    def pause(self) -> None:
        self.runner.pause()

    def single_step(self) -> concurrent.futures.Future:
        self.runner.pause()
        return self.runner.single_step()

    def reset(self) -> concurrent.futures.Future:
        def command(simulation: sim.Simulation) -> None:
            self.runner.let_go(everyone=True)
            self.runner.error = None
            driver = simulation.model.driver
            if driver is not None and driver == self.page_driver and driver.start > 0.0:
                simulation.set_parameters(driver=dataclasses.replace(driver, start=0.0))
                self.page_driver = simulation.model.driver
            simulation.reset()

        return self.runner.post(command)

    def set_steps_per_frame(self, steps: int) -> None:
        """Steps between two frames, 1 to ``MAX_STEPS_PER_FRAME``; anything else: ValueError."""
        if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)):
            raise ValueError(f"steps per frame must be a whole number, got {steps!r}")
        if not 1 <= steps <= MAX_STEPS_PER_FRAME:
            raise ValueError(f"steps per frame must be 1 to {MAX_STEPS_PER_FRAME}, got {steps}")
        self.runner.steps_per_frame = int(steps)

    # --- integrator ------------------------------------------------------------------------------

    def set_integrator(self, name: str) -> concurrent.futures.Future:
        def command(simulation: sim.Simulation) -> None:
            simulation.integrator = name

        return self.runner.post(command)

    def set_precision(self, precision: str) -> concurrent.futures.Future:
        """"float64" or "float32" state and kernels (the state is converted between steps)."""

        def command(simulation: sim.Simulation) -> None:
            simulation.precision = precision

        return self.runner.post(command)

    def set_threads(self, threads: int) -> concurrent.futures.Future:
        """Threads the compiled sweeps use (1 to the machine's cores)."""

        def command(simulation: sim.Simulation) -> None:
            simulation.threads = threads

        return self.runner.post(command)

    def set_dt(self, dt: float) -> concurrent.futures.Future:
        def command(simulation: sim.Simulation) -> None:
            simulation.dt = float(dt)

        return self.runner.post(command)

    # --- physics ---------------------------------------------------------------------------------

    def set_parameters(self, **changes: Any) -> concurrent.futures.Future:
        """Any of ``Simulation.set_parameters``' keywords; a bad value leaves everything as is."""
        return self.runner.post(lambda simulation: simulation.set_parameters(**changes))

    def set_gravity(self, enabled: bool, strength: float = 9.81) -> concurrent.futures.Future:
        """Gravity (m/s^2) pointing down (-y), or none."""
        return self.set_parameters(gravity=float(strength) if enabled else 0.0)

    def set_damping(self, enabled: bool, coefficient: float) -> concurrent.futures.Future:
        """Dashpots beside every spring with coefficient ``coefficient`` (N s/m), or none."""
        return self.set_parameters(damping=float(coefficient) if enabled else 0.0)

    def set_stiffness(self, stiffness: float) -> concurrent.futures.Future:
        return self.set_parameters(stiffness=float(stiffness))

    def set_rest_length_ratio(self, ratio: float) -> concurrent.futures.Future:
        """Rest length as a fraction of the spacing (below 1 pre-tensions the lattice)."""

        def command(simulation: sim.Simulation) -> None:
            simulation.set_parameters(rest_length=float(ratio) * simulation.model.spacing)

        return self.runner.post(command)

    def set_linear(self, linear: bool) -> concurrent.futures.Future:
        return self.set_parameters(linear=bool(linear))

    def set_mass_pattern(self, pattern: str, heavy: float = 4.0,
                         light: float = 1.0) -> concurrent.futures.Future:
        """``uniform`` (every mass = ``light``) or ``ionic`` (checkerboard heavy/light, kg)."""
        if pattern not in MASS_PATTERNS:
            raise ValueError(f"mass pattern must be one of {MASS_PATTERNS}, got {pattern!r}")

        def command(simulation: sim.Simulation) -> None:
            model = simulation.model
            if pattern == "uniform":
                simulation.set_masses(float(light))
            else:
                rows, columns = np.indices((model.ny, model.nx))
                simulation.set_masses(np.where((rows + columns) % 2 == 0, heavy, light))

        return self.runner.post(command)

    def set_particle_masses(self, indices: Sequence[int],
                            mass: float) -> concurrent.futures.Future:
        """Give the particles ``indices`` the mass ``mass`` (kg); others keep theirs."""
        chosen = np.asarray(list(indices), dtype=np.int64)

        def command(simulation: sim.Simulation) -> None:
            masses = np.array(simulation.masses, dtype=float)
            masses[chosen] = float(mass)
            simulation.set_masses(masses)

        return self.runner.post(command)

    # --- driver and walls -------------------------------------------------------------------------

    @staticmethod
    def _change_model(simulation: sim.Simulation, **changes: Any) -> None:
        """``simulation.set_parameters(**changes)``, refused first (nothing changes) when the
        changed model is invalid or the running integrator cannot run it."""
        changed = simulation.model.replace(**changes)  # ModelError on a bad value
        reason = sim.integrators.describe(simulation.integrator).reason_not_applicable(changed)
        if reason is not None:
            raise sim.integrators.IntegratorError(
                f"{simulation.integrator} cannot run this: {reason}; choose another integrator "
                "first"
            )
        simulation.set_parameters(**changes)

    def drive(self, column: int, row: int, direction: str | Sequence[float], amplitude: float,
              frequency: float, kind: str,
              ramp: float = DRIVE_RAMP) -> concurrent.futures.Future:
        """Drive particle (``column``, ``row``) from now on (replacing any driver): amplitude A
        (m), frequency f (Hz), kind "force" or "displacement", along ``direction`` ("x", "y",
        "z" or a vector), starting at the current time and ramping up over ``ramp`` s.  The
        Future holds the model's new ``Driver``; a bad value raises and changes nothing."""
        fields = dict(column=column, row=row, direction=direction, amplitude=amplitude,
                      frequency=frequency, kind=kind, ramp=ramp)

        def command(simulation: sim.Simulation) -> Driver:
            driver = Driver.create({**fields, "start": simulation.time})
            self._change_model(simulation, driver=driver)
            self.page_driver = simulation.model.driver
            return simulation.model.driver

        return self.runner.post(command)

    def stop_driving(self) -> concurrent.futures.Future:
        """No driver from now on (the work it did stays in the energy account)."""

        def command(simulation: sim.Simulation) -> None:
            if simulation.model.driver is not None:
                self._change_model(simulation, driver=None)
            self.page_driver = None

        return self.runner.post(command)

    def set_sources(self, sources: Sequence[Driver]) -> concurrent.futures.Future:
        """Replace the scene's sources (``sim.model.sources``) from now on; a bad one raises and changes
        nothing.  The Future holds the model's new sources."""
        chosen = tuple(sources)

        def command(simulation: sim.Simulation) -> tuple:
            self._change_model(simulation, sources=chosen)
            return simulation.model.sources

        return self.runner.post(command)

    def set_barriers(self, barriers: Sequence[Any]) -> concurrent.futures.Future:
        """Replace the scene's barriers (``sim.model.sources.Barrier``: pinned particles with openings)
        from now on; a bad one raises and changes nothing.  The Future holds the new barriers."""
        chosen = tuple(barriers)

        def command(simulation: sim.Simulation) -> tuple:
            self._change_model(simulation, barriers=chosen)
            return simulation.model.barriers

        return self.runner.post(command)

    def set_boundary(self, boundary: str, sponge_width: int) -> concurrent.futures.Future:
        """Walls "fixed", "absorbing" (behind a sponge layer ``sponge_width`` particles deep),
        "periodic" (rows closed into rings) or "free" (no wall springs at the rows' ends); a
        lattice too small for the layer raises ``ModelError`` and changes nothing."""

        def command(simulation: sim.Simulation) -> sim.Model:
            self._change_model(simulation, boundary=boundary, sponge_width=sponge_width)
            return simulation.model

        return self.runner.post(command)

    # --- particles -------------------------------------------------------------------------------

    def move_particles(
        self, indices: Sequence[int], targets: np.ndarray, owner: Hashable | None = None,
        pin: bool = False,
    ) -> concurrent.futures.Future:
        """Put particles ``indices`` at ``targets`` ((k, dim) or (k, 3) m), at rest.

        With ``pin`` they are also held there (by ``owner``) until ``release(owner)``.
        """
        chosen = np.asarray(list(indices), dtype=np.int64)
        targets = np.asarray(targets, dtype=float).reshape(len(chosen), -1)
        check_targets(self.runner.simulation.model, chosen, targets)

        def command(simulation: sim.Simulation) -> None:
            dim = simulation.model.dim
            where = targets[:, :dim]
            if not np.all(np.isfinite(where)):
                raise ValueError("target positions must be finite")
            if chosen.size and (chosen.min() < 0 or chosen.max() >= simulation.model.n_particles):
                raise IndexError("particle index out of range")
            simulation.positions[chosen] = where
            simulation.velocities[chosen] = 0.0
            if pin:
                self.runner.hold(owner, {int(p): where[k].copy() for k, p in enumerate(chosen)})

        return self.runner.post(command)

    def release(self, owner: Hashable | None = None) -> concurrent.futures.Future:
        """Let go of every particle held by ``owner``."""
        return self.runner.post(lambda simulation: self.runner.let_go(owner))

    # --- scenes ----------------------------------------------------------------------------------

    def replace_scene(self, scene: sim.Scene, integrator: str | None = None,
                      dt: float | None = None) -> concurrent.futures.Future:
        """Swap in a new simulation of ``scene`` (built here, swapped between steps).  The Future
        holds the new ``Simulation``."""
        simulation = sim.Simulation(scene, integrator=integrator, dt=dt)

        def command(_: sim.Simulation) -> sim.Simulation:
            self.runner.let_go(everyone=True)
            self.runner.error = None
            self.runner.simulation = simulation
            return simulation

        return self.runner.post(command)

    def snapshot(self) -> concurrent.futures.Future:
        """The current state and parameters as a ``sim.Scene`` (taken between steps)."""
        return self.runner.post(sim.scenes.scene_from_simulation)
