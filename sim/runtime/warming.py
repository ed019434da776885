"""Compiling a simulation's kernels before they are needed, away from the thread that waits.

numba compiles a kernel for every new combination of argument types at its first call, and a
scene's flags change those types: gravity or none, dashpots or none, a driver, an absorbing layer,
unequal masses, 3-D, float32, several threads.  A new combination costs a compile of seconds to
tens of seconds on first use on a machine (numba's on-disk cache keeps it for later runs).

* ``kernel_key(simulation, steps)`` names the combination a simulation needs to advance ``steps``
  steps at a time and to be observed (energy, strains).  It is deliberately finer than numba's
  own types (a key never stands for two combinations), so a key seen once needs no compile again.
* ``rehearse(scene, ...)`` builds a copy of a simulation from a snapshot (``sim.scenes.building.
  scene_from_simulation``) and runs what a run needs: the energy, ``steps`` steps, the energy
  balance, the strains.  That compiles (or loads from the cache) every kernel the run calls,
  exactly as it calls them; the running simulation is not touched (``sim.runtime.rehearsal``,
  where two children split the work on two cores or more, ``rehearse_reading``).
* ``KernelPreparer`` rehearses in one background thread, the most recently asked combination
  first, and tells whether a key is ready, or how long its preparation has been running and
  whether it compiles (rather than only reading numba's cache).  ``shared_preparer()`` is the
  process's preparer: compiled kernels belong to the process, so one record serves every runner.

The runner (``sim.runtime.runner``) asks the preparer before it steps or observes a simulation, and says
"preparing" in its frames while it waits; the ``warm`` command rehearses every preset ahead.

Compiled apart.  numba compiles each kernel's callees on their own, and inside one process a
kernel calls its callees' own compiled code.  The leapfrog's row pass (``sim.loops.leapfrog``)
compiled that way ran its scalar loop, not its 512-bit one; in the kernel numba's cache stores,
the pass is inlined and runs vectorised.  So a process that compiled its kernels ran them about
three times slower for as long as it lived, while a process that read the same kernels from the
cache ran them at full speed (figures in ``docs/web.md``, "Compiled apart, or optimised before
inlining").  ``import sim`` asks numba for ``NUMBA_OPT=max``, which avoids it at more compile
time (``sim.runtime.optimisation``), but the cached kernels of numba's default level run the
leapfrog about a tenth faster, so the processes that use this module go back to that level
(``app.cli``: the commands that read cached kernels).  ``call_reading`` therefore makes a call (a rehearsal,
``rehearse_reading``; a command's run) with compiles refused (``refusing_compiles``); if a
kernel is missing from the cache, a child process (``python -m sim.runtime.warming``) makes the
same call and writes the cache, and the call is made again here, reading it.  If the child
fails, this process compiles the kernels itself, and the log says why.  The preparer rehearses
this way, ``bench`` calls its measurement this way, and ``run``, ``record`` and the timed runs of
``accuracy`` and ``choose`` prepare their simulations with ``prepare_reading``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import pickle
import subprocess
import sys
import threading
import time
import weakref
from collections.abc import Callable, Hashable, Iterator, Sequence
from typing import Any

from sim.forces import registry
from sim.runtime.children import CHILD_TIMEOUT, ROOT, call_in_child, end_with_parent  # noqa: F401
from sim.runtime.rehearsal import chunk_sizes, rehearse, rehearse_loop  # noqa: F401

LOGGER = logging.getLogger("oscillators.warming")


def step_shapes(steps: int, chunk: int) -> str:
    """How ``Simulation.step(steps)`` calls the stepper: "one" step at a time, "many" at a
    time, or "both" (a chunked run whose last chunk is a single step).  Some loops (Verlet's
    leapfrog) compile a different kernel for a single step."""
    ones = {size == 1 for size in chunk_sizes(steps, chunk)}
    return "both" if len(ones) == 2 else ("one" if True in ones else "many")


def kernel_key(simulation: Any, steps: int = 1) -> tuple:
    """The combination of kernel variants ``simulation`` needs to run ``steps`` steps per call
    (see the module docstring).  Values that only change numbers (stiffness, dt, amplitudes)
    are left out; every flag that may change a type is in: the force terms' from their
    registration (``sim.forces.registry.kernel_flags``), the lattice's, the instruments' and
    the call's."""
    model = simulation.model
    driver = model.driver
    threads = int(simulation.threads)
    return (
        simulation.integrator, simulation.precision, threads,
        min(model.ny, 64) if threads > 1 else 0,
        model.dim, bool(model.linear), model.uniform_mass, registry.kernel_flags(model),
        model.boundary, bool(model.sponge_sides),
        None if driver is None else (driver.kind, str(driver.row) == "all"),
        tuple(sorted({(source.kind, str(source.row) == "all") for source in model.sources})),
        bool(model.barriers),
        step_shapes(steps, getattr(simulation, "chunk_steps", 64)),
    )


REHEARSED_STEPS = 65
"""Steps a rehearsal runs to meet every way a run calls the stepper: whole chunks of 64 and a
single step (``step_shapes``)."""


def snapshot(simulation: Any, steps: int) -> tuple[Any, tuple]:
    """(scene, settings): ``rehearse``'s arguments for a copy of ``simulation`` as it is now,
    ``steps`` at a time (call it where the simulation is not stepping: the scene copies its
    state)."""
    from sim.scenes.building import scene_from_simulation

    return scene_from_simulation(simulation), (simulation.integrator, simulation.dt,
                                               simulation.precision, simulation.threads, steps)


def rehearse_simulation(simulation: Any, steps: int) -> None:
    """``rehearse`` a copy of ``simulation`` as it is now (``snapshot``)."""
    scene, settings = snapshot(simulation, steps)
    rehearse(scene, *settings)


def call_reading(function: Callable[..., Any], *arguments: Any,
                 child: dict | None = None, announce: Callable[[], None] | None = None,
                 beside: Sequence[tuple[Callable[..., Any], tuple]] = (),
                 beside_done: str | None = None, beside_ready: str | None = None,
                 **keywords: Any) -> tuple[Any, bool]:
    """``function(*arguments, **keywords)`` with every kernel it calls read from numba's cache:
    tried with compiles refused; if a kernel is missing, ``announce()`` is called, a child
    process runs the same call (with the keywords ``child`` overrides, e.g. a shorter
    measurement) and writes the cache, and the call is made again here.  If the child fails,
    the call compiles here, and the log says why.  Returns (result, whether a child compiled)."""
    try:
        with refusing_compiles():
            return function(*arguments, **keywords), False
    except WouldCompile:
        pass
    if announce is not None:
        announce()
    try:
        call_in_child(function, *arguments, beside=beside, beside_done=beside_done,
                      beside_ready=beside_ready, **{**keywords, **(child or {})})
    except (OSError, RuntimeError, subprocess.SubprocessError, pickle.PicklingError,
            AttributeError, TypeError) as error:  # not picklable: compiled here
        LOGGER.warning("compiling the kernels in a child process failed (%s); compiling here",
                       error)
    return function(*arguments, **keywords), True


def rehearse_reading(scene: Any, settings: tuple,
                     announce: Callable[[], None] | None = None) -> bool:
    """``rehearse(scene, *settings)`` reading every kernel from numba's cache (``call_reading``);
    on a machine with two cores or more a second child compiles the step loop
    (``rehearse_loop``) beside the first.  Returns whether a child compiled."""
    beside = [(rehearse_loop, (scene, *settings))] if (os.cpu_count() or 1) > 1 else []
    return call_reading(rehearse, scene, *settings, announce=announce, beside=beside,
                        beside_done="loop_done" if beside else None,
                        beside_ready="layer_ready" if beside else None)[1]


_READ: set[Hashable] = set()
_READ_LOCK = threading.Lock()


def prepare_reading(simulation: Any, steps: int = REHEARSED_STEPS,
                    announce: Callable[[], None] | None = None) -> bool:
    """Have the kernels a run of ``simulation`` calls (``steps`` at a time) read from numba's
    cache in this process, a child compiling those missing first (``rehearse_reading``): once
    per ``kernel_key`` in this process, in the caller's thread.  For runs that are timed or
    long.  Returns whether a child compiled."""
    steps = max(1, min(int(steps), REHEARSED_STEPS))  # more rehearse no other kernel
    key = kernel_key(simulation, steps)
    with _READ_LOCK:
        if key in _READ:
            return False
    scene, settings = snapshot(simulation, steps)
    compiled = rehearse_reading(scene, settings, announce)
    with _READ_LOCK:
        _READ.add(key)
    return compiled


def main() -> None:
    """The child: read (function, arguments, keywords) pickled on standard input, call it."""
    end_with_parent()
    function, arguments, keywords = pickle.load(sys.stdin.buffer)
    function(*arguments, **keywords)


@dataclasses.dataclass(frozen=True)
class Preparing:
    """A preparation under way: ``seconds`` since it started, ``compiling`` whether numba is
    compiling (first time on this machine) rather than only reading its cache."""

    seconds: float
    compiling: bool


class WouldCompile(RuntimeError):
    """Raised in a thread that refuses compiles (``refusing_compiles``) when numba is about to
    compile a kernel there rather than read it from its cache."""


class _CompileWatch:
    """Which threads are inside a numba compile now (numba's "numba:compile" events), and which
    refuse to compile (``refusing``).  ``seen`` and ``locked`` hold the threads themselves, not
    their identities: a finished thread's identity is soon given to a new one, which must not
    inherit what the old one did."""

    def __init__(self) -> None:
        self.threads: dict[int, int] = {}
        self.refusing: set[int] = set()
        self.seen: weakref.WeakSet[threading.Thread] = weakref.WeakSet()
        """Threads that started a compile."""
        self.locked: weakref.WeakSet[threading.Thread] = weakref.WeakSet()
        """Threads that took numba's compiler lock: compiled or read a kernel from the cache."""
        self.started = 0
        self._lock = threading.Lock()
        self.installed = False

    def install(self) -> None:
        if self.installed:
            return
        try:
            from numba.core import event
        except ImportError:  # pragma: no cover - numba is a dependency
            return
        watch = self

        class Listener(event.Listener):
            def on_start(self, _: Any) -> None:
                ident = threading.get_ident()
                with watch._lock:
                    if ident in watch.refusing:  # before the compile: nothing is half made
                        watch.seen.add(threading.current_thread())  # compiling comes next
                        raise WouldCompile("a kernel is not in numba's cache")
                    watch.threads[ident] = watch.threads.get(ident, 0) + 1
                    watch.seen.add(threading.current_thread())
                    watch.started += 1

            def on_end(self, _: Any) -> None:
                ident = threading.get_ident()
                with watch._lock:
                    watch.threads[ident] = max(0, watch.threads.get(ident, 0) - 1)

        class LockListener(event.Listener):
            def on_start(self, _: Any) -> None:
                with watch._lock:
                    watch.locked.add(threading.current_thread())

            def on_end(self, _: Any) -> None:
                pass

        event.register("numba:compile", Listener())
        event.register("numba:compiler_lock", LockListener())
        self.installed = True

    def compiled_in(self, ident: int | None) -> bool:
        """Whether the running thread ``ident`` started a compile since ``forget(ident)``."""
        with self._lock:
            return _running(self.seen, ident)

    def forget(self, ident: int) -> None:
        with self._lock:
            _discard(self.seen, ident)


def _running(threads: weakref.WeakSet, ident: int | None) -> bool:
    """Whether a running thread of ``threads`` has the identity ``ident``."""
    return any(thread.ident == ident and thread.is_alive() for thread in list(threads))


def _discard(threads: weakref.WeakSet, ident: int) -> None:
    for thread in [thread for thread in list(threads) if thread.ident == ident]:
        threads.discard(thread)


_WATCH = _CompileWatch()


@contextlib.contextmanager
def refusing_compiles() -> Iterator[None]:
    """Inside, a numba compile in this thread raises ``WouldCompile`` before it starts; kernels
    in numba's cache are read as usual."""
    _WATCH.install()
    ident = threading.get_ident()
    with _WATCH._lock:
        _WATCH.refusing.add(ident)
    try:
        yield
    finally:
        with _WATCH._lock:
            _WATCH.refusing.discard(ident)


def compiled_in_thread(ident: int) -> bool:
    """Whether the thread ``ident`` (``threading.get_ident()``) started a numba compile since
    the process began watching (a thread whose kernels were prepared starts none)."""
    _WATCH.install()
    return _WATCH.compiled_in(ident)


def loaded_in_thread(ident: int) -> bool:
    """Whether the thread ``ident`` compiled a kernel or read one from numba's cache (both take
    numba's compiler lock) since the process began watching."""
    _WATCH.install()
    with _WATCH._lock:
        return _running(_WATCH.locked, ident)


def compiles_started() -> int:
    """How many numba compiles (not cache reads) started in this process since it began
    watching (the first call, or the first ``KernelPreparer``)."""
    _WATCH.install()
    return _WATCH.started


@dataclasses.dataclass
class _Job:
    key: Hashable
    work: Callable[[], None]
    asked: float
    owner: Hashable = None
    started: float | None = None


class KernelPreparer:
    """Rehearses kernel combinations in one background thread; see the module docstring.

    ``rehearsal(simulation, steps)`` is the work done for a key (``rehearse_simulation`` by
    default; tests give a slow stand-in).  ``ready(key)`` says whether a key was prepared;
    ``prepare(key, simulation, steps, owner)`` asks for it (the snapshot is taken at once, in
    the caller's thread) and returns None when it is ready, else the ``Preparing`` under way; a
    new request of an ``owner`` (a runner) withdraws its requests not yet started, and
    ``withdraw(owner)`` all of them (a scene left before its kernels were needed costs nothing
    more).  A preparation under way cannot be stopped (numba does not interrupt a compile).
    """

    def __init__(self, rehearsal: Callable[[Any, int], None] | None = None) -> None:
        self._rehearsal = rehearsal
        self._ready: set[Hashable] = set()
        self._waiting: dict[Hashable, _Job] = {}
        self._current: _Job | None = None
        self._lock = threading.Lock()
        self._wake = threading.Condition(self._lock)
        self._thread: threading.Thread | None = None
        self._worker_ident: int | None = None
        self.failures: dict[Hashable, str] = {}
        """Keys whose rehearsal raised, with the message (the run then compiles as it goes)."""
        _WATCH.install()

    def ready(self, key: Hashable) -> bool:
        with self._lock:
            return key in self._ready

    def mark_ready(self, key: Hashable) -> None:
        """Record ``key`` as prepared (its kernels were compiled by other means)."""
        with self._lock:
            self._ready.add(key)
            self._waiting.pop(key, None)

    def prepare(self, key: Hashable, simulation: Any, steps: int,
                owner: Hashable = None) -> Preparing | None:
        """None if ``key`` is ready; else make sure it is being prepared and say how far."""
        with self._lock:
            if key in self._ready:
                return None
            current = self._current
            if current is not None and current.key == key:
                return self._progress(current)
            job = self._waiting.get(key)
        if job is None:
            work = self._work(simulation, steps)  # the snapshot, in the caller's thread
            with self._lock:
                self._withdraw(owner, keep=key)
                job = self._waiting.setdefault(key, _Job(key, work, time.perf_counter(), owner))
                job.asked = time.perf_counter()
                self._start()
                self._wake.notify()
        with self._lock:
            return self._progress(job)

    def withdraw(self, owner: Hashable) -> None:
        """Drop the requests of ``owner`` that have not started."""
        with self._lock:
            self._withdraw(owner)

    def _withdraw(self, owner: Hashable, keep: Hashable = None) -> None:
        if owner is None:
            return
        for key in [k for k, job in self._waiting.items() if job.owner == owner and k != keep]:
            del self._waiting[key]

    def _work(self, simulation: Any, steps: int) -> Callable[[], None]:
        if self._rehearsal is not None:
            rehearsal = self._rehearsal
            return lambda: rehearsal(simulation, steps)
        scene, settings = snapshot(simulation, steps)
        return lambda: rehearse_reading(scene, settings)

    def _progress(self, job: _Job) -> Preparing:
        started = job.started if job.started is not None else job.asked
        compiling = job is self._current and _WATCH.compiled_in(self._worker_ident)
        return Preparing(max(0.0, time.perf_counter() - started), compiling)

    def _start(self) -> None:
        if self._thread is None or not self._thread.is_alive():
            self._thread = threading.Thread(target=self._serve, name="kernel-preparer",
                                            daemon=True)
            self._thread.start()

    def _serve(self) -> None:
        self._worker_ident = threading.get_ident()
        while True:
            with self._lock:
                while not self._waiting:
                    self._wake.wait()
                key = max(self._waiting, key=lambda k: self._waiting[k].asked)  # newest first
                job = self._waiting.pop(key)
                job.started = time.perf_counter()
                self._current = job
                _WATCH.forget(self._worker_ident)
            try:
                job.work()
            except Exception as error:  # the run will compile (or fail) as it goes, and say so
                LOGGER.warning("preparing the kernels of %s failed: %r", key, error)
                self.failures[key] = repr(error)
            with self._lock:
                self._ready.add(key)
                self._current = None


_SHARED: KernelPreparer | None = None
_SHARED_LOCK = threading.Lock()


def shared_preparer() -> KernelPreparer:
    """The process's preparer (one record of what is compiled, as numba's kernels are)."""
    global _SHARED
    with _SHARED_LOCK:
        if _SHARED is None:
            _SHARED = KernelPreparer()
        return _SHARED


if __name__ == "__main__":
    main()
