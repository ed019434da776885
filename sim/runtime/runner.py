"""The runner owns the simulation loop; viewers and recorders subscribe to its frames.

Nothing here knows about viser or rerun.  Two ways to drive it:

* synchronously: ``runner.advance(steps, every=k)`` runs in the caller's thread and publishes a
  ``Frame`` every k steps (the ``record`` command, tests, benchmarks);
* in a background thread: ``runner.start()``; then ``play()`` / ``pause()`` / ``single_step()``;
  the loop advances ``steps_per_frame`` steps per frame at no more than ``max_fps`` frames per
  second (the web app).

Anyone may ``post(command)``: a callable taking the ``Simulation``, run by the loop between steps
(never in the middle of one).  ``post`` returns a ``concurrent.futures.Future`` with the command's
result or exception.  A blow-up pauses the loop, keeps the state before the bad step and publishes
a frame whose ``error`` says what happened.

A subscriber that raises is detached: the runner logs it, keeps the message in
``subscriber_errors``, calls the subscriber's ``on_error(exception)`` (so a recorder can close its
file cleanly) and carries on stepping.  One failing viewer or recorder never stops the others or
the simulation.

Kernels are prepared before they are used when the runner has a ``KernelPreparer``
(``sim.runtime.warming``): before the loop steps (or observes) a simulation whose combination of kernels
was not compiled in this process, it has them compiled in the preparer's thread and meanwhile
keeps applying commands (Pause, Reset, parameters answer at once) and publishes, four times a
second, frames of the unchanged state whose ``preparing`` says how long it has been preparing.
"""

from __future__ import annotations

import collections
import concurrent.futures
import dataclasses
import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from sim.model.lattice import Model
from sim.runtime import warming
from sim.runtime.simulation import BlowUpError, Simulation
from sim.theory import observables
from sim.theory.observables import Energy

LOGGER = logging.getLogger("oscillators.runner")
SUBSCRIBER_ERRORS_KEPT = 20
"""How many detached-subscriber messages ``Runner.subscriber_errors`` keeps."""
PREPARING_INTERVAL = 0.25
"""Seconds between two frames that say the kernels are being prepared."""


@dataclasses.dataclass(frozen=True)
class Frame:
    """A snapshot for subscribers.  Arrays are copies owned by the frame.

    positions: (n_particles, dim) m; velocities: (n_particles, dim) m/s or None if no subscriber
    asked; strains: (n_springs,) or None if no subscriber asked; energy: the energy account;
    error: the blow-up message if the run just stopped on one, else None;
    energy_balance_error: ``Simulation.energy_balance_error()`` of this state (relative, 0 exact);
    preparing: while the kernels this run needs are being compiled, how long that has taken
    (``sim.runtime.warming.Preparing``; the frame's energy is then computed without compiled kernels
    and its balance error left at 0), else None.
    """

    step: int
    time: float
    integrator: str
    dt: float
    model: Model
    positions: np.ndarray
    energy: Energy
    velocities: np.ndarray | None = None
    strains: np.ndarray | None = None
    error: str | None = None
    playing: bool = False
    energy_balance_error: float = 0.0
    preparing: warming.Preparing | None = None


@dataclasses.dataclass(eq=False)
class _Subscriber:
    callback: Callable[[Frame], Any]
    strains: bool
    velocities: bool
    on_error: Callable[[BaseException], Any] | None = None
    preparing: bool = False


class Runner:
    """Owns a ``Simulation`` and its loop; see the module docstring."""

    def __init__(
        self, simulation: Simulation, steps_per_frame: int = 1, max_fps: float = 60.0,
        preparer: warming.KernelPreparer | None = None,
    ) -> None:
        self.simulation = simulation
        self.steps_per_frame = steps_per_frame
        self.max_fps = max_fps
        self.error: str | None = None
        self._subscribers: list[_Subscriber] = []
        self._commands: queue.Queue[tuple[Callable[[Simulation], Any], concurrent.futures.Future]]
        self._commands = queue.Queue()
        self._playing = False
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._running = False
        self._lock = threading.Lock()
        self.frames_published = 0
        self.steps_taken = 0
        """Steps run by ``guarded_step`` since the runner was made (across scene changes)."""
        self.before_step: Callable[[Simulation], Any] | None = None
        """Called before every step and after the last while set (see ``guarded_step``)."""
        self.subscriber_errors: collections.deque[str] = collections.deque(
            maxlen=SUBSCRIBER_ERRORS_KEPT
        )
        """Messages about subscribers that raised and were detached, oldest first."""
        self.preparer = preparer
        """Prepares the kernels before the loop needs them (None: they compile when called)."""
        self._pending_steps: list[concurrent.futures.Future] = []
        self._plain_energy: tuple | None = None

    # --- subscribers -----------------------------------------------------------------------------

    def subscribe(
        self, callback: Callable[[Frame], Any], *, strains: bool = False, velocities: bool = False,
        on_error: Callable[[BaseException], Any] | None = None, preparing: bool = False,
    ) -> Callable[[], None]:
        """Call ``callback(frame)`` for every published frame; ask for strains / velocities only
        if you show them, and for the frames that say the kernels are being prepared
        (``Frame.preparing``; the state did not advance) only if you show that.  If ``callback``
        raises, it is detached and ``on_error(exception)`` is called once (in the publishing
        thread).  Returns a function that unsubscribes."""
        subscriber = _Subscriber(callback, strains, velocities, on_error, preparing)
        with self._lock:
            self._subscribers.append(subscriber)

        def unsubscribe() -> None:
            with self._lock:
                if subscriber in self._subscribers:
                    self._subscribers.remove(subscriber)

        return unsubscribe

    def make_frame(self, error: str | None = None,
                   preparing: warming.Preparing | None = None) -> Frame:
        """A frame of the current state, with what the current subscribers asked for; while
        ``preparing`` without calling a compiled kernel."""
        with self._lock:
            subscribers = list(self._subscribers)
        simulation = self.simulation
        if preparing is not None:
            return self._preparing_frame(simulation, subscribers, error, preparing)
        return Frame(
            step=simulation.step_count,
            time=simulation.time,
            integrator=simulation.integrator,
            dt=simulation.dt,
            model=simulation.model,
            positions=simulation.state.particle_positions().copy(),
            energy=simulation.energy(),
            velocities=(
                simulation.state.particle_velocities().copy()
                if any(s.velocities for s in subscribers)
                else None
            ),
            strains=simulation.strains() if any(s.strains for s in subscribers) else None,
            error=error,
            playing=self._playing,
            energy_balance_error=simulation.energy_balance_error(),
        )

    def _preparing_frame(self, simulation: Simulation, subscribers: list[_Subscriber],
                         error: str | None, preparing: warming.Preparing) -> Frame:
        model = simulation.model
        state = simulation.state
        positions = simulation.peek_positions()
        velocities = state.particle_velocities().copy()
        seen = (state.step, state.time, state.dissipated, state.driven, id(model))
        kept = self._plain_energy
        if (kept is None or kept[0] != seen or not np.array_equal(kept[1], positions)
                or not np.array_equal(kept[2], velocities)):
            energy = Energy(  # numpy's terms, no compiled kernel; again only when the state moved
                kinetic=observables.kinetic_energy(model, state.velocities),
                spring=observables.spring_energy(model, state.positions),
                gravity=observables.gravity_energy(model, state.positions),
                dissipated=state.dissipated, driven=state.driven,
            )
            self._plain_energy = kept = (seen, positions, velocities, energy)
        energy = kept[3]
        return Frame(
            step=simulation.step_count, time=simulation.time, integrator=simulation.integrator,
            dt=simulation.dt, model=model, positions=positions, energy=energy,
            velocities=velocities if any(s.velocities for s in subscribers) else None,
            strains=(observables.strains(model, state.positions)
                     if any(s.strains for s in subscribers) else None),
            error=error, playing=self._playing, preparing=preparing,
        )

    def publish(self, error: str | None = None,
                preparing: warming.Preparing | None = None) -> Frame:
        """Build a frame now and hand it to every subscriber; returns it."""
        frame = self.make_frame(error, preparing)
        with self._lock:
            subscribers = [s for s in self._subscribers if preparing is None or s.preparing]
        for subscriber in subscribers:
            try:
                subscriber.callback(frame)
            except Exception as error:  # contained: detach this one, keep the others running
                self._detach(subscriber, error)
        self.frames_published += 1
        return frame

    def _detach(self, subscriber: _Subscriber, error: Exception) -> None:
        with self._lock:
            if subscriber in self._subscribers:
                self._subscribers.remove(subscriber)
        target = getattr(subscriber.callback, "func", subscriber.callback)  # functools.partial
        name = getattr(target, "__qualname__", None) or type(target).__name__
        message = f"{name} stopped receiving frames: {error}"
        self.subscriber_errors.append(message)
        LOGGER.error("subscriber detached: %s", message, exc_info=error)
        if subscriber.on_error is not None:
            try:
                subscriber.on_error(error)
            except Exception as second:  # the error handler itself failed: log and go on
                LOGGER.error("the error handler of %s failed: %r", name, second)

    # --- commands --------------------------------------------------------------------------------

    def post(self, command: Callable[[Simulation], Any]) -> concurrent.futures.Future:
        """Queue ``command(simulation)`` to run between steps; returns a Future of its result."""
        future: concurrent.futures.Future = concurrent.futures.Future()
        self._commands.put((command, future))
        self._wake.set()
        if self._thread is None:
            self.apply_commands()
        return future

    def apply_commands(self) -> int:
        """Run the queued commands now (the loop does this between steps).  Returns how many."""
        count = 0
        while True:
            try:
                command, future = self._commands.get_nowait()
            except queue.Empty:
                return count
            count += 1
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(command(self.simulation))
            except Exception as error:  # a bad command must never stop the loop
                future.set_exception(error)

    # --- synchronous driving ----------------------------------------------------------------------

    def advance(self, steps: int, every: int = 1, publish_first: bool = False) -> Frame:
        """Run ``steps`` steps in this thread, publishing a frame every ``every`` steps and after
        the last.  On a blow-up: publishes a frame with ``error`` and raises the BlowUpError."""
        if every < 1:
            raise ValueError("every must be at least 1")
        frame = self.publish() if publish_first else None
        done = 0
        while done < steps:
            self.apply_commands()
            chunk = min(every, steps - done)
            try:
                self.simulation.step(chunk)
            except BlowUpError as error:
                self.error = str(error)
                self.publish(error=self.error)
                raise
            done += chunk
            frame = self.publish()
        return frame if frame is not None else self.publish()

    # --- background loop --------------------------------------------------------------------------

    @property
    def playing(self) -> bool:
        return self._playing

    def play(self) -> None:
        self.error = None
        self._playing = True
        self._wake.set()

    def pause(self) -> None:
        self._playing = False
        self._wake.set()

    def single_step(self) -> concurrent.futures.Future:
        """Advance exactly one step (while paused) and publish it.  The Future holds whether
        the step ran; with a preparer it waits for the kernels of a single step."""
        if self.preparer is None or self._thread is None:
            return self.post(lambda simulation: self.guarded_step(1))
        future: concurrent.futures.Future = concurrent.futures.Future()
        self.post(lambda simulation: self._pending_steps.append(future))
        return future

    def _kernels_for(self, steps: int) -> warming.Preparing | None:
        """None when the kernels to run ``steps`` steps per call are ready (or nothing prepares
        them); else have them prepared and say how far that is (runs in the loop's thread)."""
        if self.preparer is None:
            return None
        simulation = self.simulation
        key = warming.kernel_key(simulation, steps)
        if self.preparer.ready(key):
            return None
        return self.preparer.prepare(key, simulation, steps, owner=id(self))

    def _preparing(self) -> warming.Preparing | None:
        """What the loop waits for before it steps or observes: the kernels of the steps it
        runs per frame (or one at a time while particles are held), and of a single step
        asked for."""
        steps = 1 if self.before_step is not None else max(1, int(self.steps_per_frame))
        waiting = self._kernels_for(steps)
        if waiting is None and self._pending_steps:
            waiting = self._kernels_for(1)
        return waiting

    def _run_pending_steps(self) -> bool:
        """Run the single steps asked for (their kernels are ready); whether any ran."""
        pending, self._pending_steps = self._pending_steps, []
        for future in pending:
            if future.set_running_or_notify_cancel():
                try:
                    future.set_result(self.guarded_step(1))
                except Exception as error:  # not a blow-up: say it to the one who asked
                    future.set_exception(error)
        return bool(pending)

    def guarded_step(self, steps: int) -> bool:
        """Advance ``steps`` steps in the loop's thread; on a blow-up pause, keep the state and
        publish a frame with the error.  Returns whether the steps ran.

        While ``before_step`` is set, the steps run one at a time and ``before_step(simulation)``
        is called before each and after the last (the web app holds dragged particles this way);
        without it they run as one compiled chunk."""
        hook = self.before_step
        before = self.simulation.step_count
        try:
            if hook is None:
                self.simulation.step(steps)
            else:
                for _ in range(steps):
                    hook(self.simulation)
                    self.simulation.step(1)
                hook(self.simulation)
        except BlowUpError as error:
            self._playing = False
            self.error = str(error)
            self.publish(error=self.error)
            return False
        finally:
            with self._lock:
                self.steps_taken += max(0, self.simulation.step_count - before)
        return True

    def start(self) -> None:
        """Start the background loop (idempotent)."""
        if self._thread is not None:
            return
        self._running = True
        self._thread = threading.Thread(target=self._loop, name="simulation-runner", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the background loop and wait for it."""
        self._running = False
        self._wake.set()
        if self.preparer is not None:
            self.preparer.withdraw(id(self))
        if self._thread is not None:
            self._thread.join(timeout)
            if not self._thread.is_alive():  # still stepping: keep it, commands stay queued
                self._thread = None

    def _loop(self) -> None:
        last_frame = 0.0
        last_notice = 0.0
        was_waiting = noticed_playing = False
        while self._running:
            changed = self.apply_commands() > 0
            waiting = self._preparing()
            if was_waiting and waiting is None:
                changed = True  # ready: a true frame replaces the one that said "preparing"
            was_waiting = waiting is not None
            if waiting is not None:  # not stepping nor observing until the kernels are ready
                now = time.perf_counter()
                if (changed or now - last_notice >= PREPARING_INTERVAL
                        or self._playing != noticed_playing):
                    last_notice, noticed_playing = now, self._playing
                    try:
                        self.publish(error=self.error, preparing=waiting)
                    except Exception as error:  # building the frame failed: report, keep looping
                        LOGGER.error("could not publish a frame: %r", error)
                self._wake.wait(0.05)
                self._wake.clear()
                continue
            if self._pending_steps and self._run_pending_steps():
                changed = True
            if self._playing:
                try:
                    if self.guarded_step(max(1, int(self.steps_per_frame))):
                        changed = True
                except Exception as error:  # not a blow-up: a bug or a bad state; pause, say why
                    LOGGER.error("simulation step failed", exc_info=error)
                    self._playing = False
                    self.error = f"the step failed: {error!r}"
                    changed = True
            if changed:
                now = time.perf_counter()
                wait = 1.0 / self.max_fps - (now - last_frame)
                if wait > 0:
                    time.sleep(wait)
                last_frame = time.perf_counter()
                try:
                    self.publish(error=None if self._playing or self.error is None else self.error)
                except Exception as error:  # building the frame failed: report, keep looping
                    LOGGER.error("could not publish a frame: %r", error)
            if not self._playing:
                self._wake.wait(0.05)
                self._wake.clear()
