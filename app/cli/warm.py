"""``oscillators warm``: compile the kernels of the preset scenes ahead, so no page waits for them.

numba compiles a kernel variant for each combination of a scene's flags on first use on a machine
(seconds to a minute each) and keeps it in its on-disk cache.  This command runs every preset
(or the ones named) for a few steps as the web app runs it (``sim.runtime.warming.rehearse``), with a
progress bar, and says what it compiled and what was already in the cache; the combinations are
compiled side by side on one process per core (as many as the memory holds).  ``--toggles`` adds the
Physics folder's Gravity, Damping and Linearised springs ticked or unticked; ``serve`` starts this
command in the background (``--background --served SCENE``) with its scene's toggles first.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from app.cli.commands import summary

EPILOG = """examples:
  oscillators warm                     # every preset as the web app runs it
  oscillators warm grid catenary       # only these presets
  oscillators warm --toggles           # also with Gravity / Damping / Linearised springs flipped

`make run` runs `oscillators warm` before it serves.  Kernels are kept in numba's cache beside
the sources (or in NUMBA_CACHE_DIR); a later run of this command finds them there in seconds.
"""

TOGGLED_GRAVITY = 9.81
"""g (m/s^2) the Physics folder's Gravity box turns on."""
TOGGLED_DAMPING = 0.5
"""Dashpot coefficient (N s/m) the Physics folder's Damping box turns on."""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``warm`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "warm", help=summary("warm"),
        description="Compile the numba kernels every preset scene needs in the web app, with a\n"
        "progress bar, and say what was compiled and what numba's cache already held.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("names", nargs="*", metavar="PRESET",
                        help="only these presets (default: every preset)")
    parser.add_argument("--toggles", action="store_true",
                        help="also each preset with the Physics folder's Gravity, Damping and "
                        "Linearised springs ticked or unticked")
    parser.add_argument("--served", metavar="PRESET",
                        help="the preset a server shows: its Physics toggles come first, "
                        "its own kernels are left to the server")
    parser.add_argument("--background", action="store_true",
                        help="lowest CPU priority, no progress bar, stop when the process that "
                        "started this one ends (how `serve` runs it)")
    parser.set_defaults(handler=command_warm, reads_cached_kernels=True)


@dataclass(frozen=True)
class Combination:
    """One scene to rehearse: a preset with some parameters changed, and its label."""

    preset: str
    changes: tuple[tuple[str, float], ...] = ()

    @property
    def label(self) -> str:
        changed = ", ".join(f"{name} {'on' if value else 'off'}" for name, value in self.changes)
        return f"{self.preset} ({changed})" if changed else self.preset

    def build(self) -> tuple[Any, int]:
        """The simulation as the web app runs it, and its steps per frame."""
        from app.web.app import runner_pacing
        from sim import Simulation
        from sim.scenes import building as scenes

        simulation = Simulation(scenes.build(self.preset, **dict(self.changes)))
        return simulation, runner_pacing(simulation)[0]


def toggles(preset: str) -> list[Combination]:
    """``preset`` with Gravity, Damping, and both, flipped from the preset's own, and with its
    springs linearised (or not): a kernel carries one spring law."""
    from sim.scenes import building as scenes

    model = scenes.build(preset).model
    gravity = ("gravity", 0.0 if model.has_gravity else TOGGLED_GRAVITY)
    damping = ("damping", 0.0 if model.damping > 0 else TOGGLED_DAMPING)
    linear = ("linear", not model.linear)
    return [Combination(preset, (gravity,)), Combination(preset, (damping,)),
            Combination(preset, (gravity, damping)), Combination(preset, (linear,))]


def plan(names: list[str], with_toggles: bool, served: str | None) -> list[Combination]:
    """The combinations to rehearse, most likely needed first."""
    combinations: list[Combination] = []
    if served is not None:
        combinations += toggles(served)
    for name in names:
        if name != served:
            combinations.append(Combination(name))
        if with_toggles:
            combinations += toggles(name)
    return list(dict.fromkeys(combinations))


def _unique(combinations: list[Combination], skip: set) -> Iterator[tuple[Combination, Any, int]]:
    """Each combination built, once per kernel key (``sim.runtime.warming.kernel_key``)."""
    from sim.runtime import warming

    seen = set(skip)
    for combination in combinations:
        simulation, steps = combination.build()
        key = warming.kernel_key(simulation, steps)
        if key not in seen:
            seen.add(key)
            yield combination, simulation, steps


WORKER_MEMORY = 2.5e9
"""Bytes a worker process may take while it compiles (the largest presets' peak, 2.2 GB seen)."""


def worker_count(combinations: int) -> int:
    """Processes ``warm`` compiles in side by side: one per core, as many as the memory
    available holds (``WORKER_MEMORY`` each), no more than there are combinations."""
    import psutil

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    by_memory = int(psutil.virtual_memory().available // WORKER_MEMORY)
    return max(1, min(cores or 1, by_memory, combinations))


def rehearse_combination(combination: Combination) -> tuple[str, float, bool]:
    """Compile (or read from the cache) the kernels of ``combination`` in this process:
    (its label, seconds, whether anything was compiled)."""
    from sim.runtime import warming

    simulation, steps = combination.build()
    before, clock = warming.compiles_started(), time.perf_counter()
    warming.rehearse_simulation(simulation, steps)
    return combination.label, time.perf_counter() - clock, warming.compiles_started() > before


def _rehearse_all(unique: list[Combination], workers: int, bar: Any) -> Iterator[tuple]:
    """``rehearse_combination`` of each, on ``workers`` processes (1: in this one), as each ends."""
    if workers <= 1:
        for combination in unique:
            bar.set_postfix_str(combination.label)
            yield rehearse_combination(combination)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(rehearse_combination, combination): combination
                   for combination in unique}
        for future in as_completed(futures):
            try:
                result = future.result()
            except Exception as error:  # a worker that failed or ended: the others go on
                label = futures[future].label
                print(f"  failed    {label}: {type(error).__name__}: {error}"[:300],
                      file=sys.stderr, flush=True)
                result = (label, 0.0, None)
            bar.set_postfix_str(result[0])
            yield result


def command_warm(arguments: argparse.Namespace) -> int:
    from tqdm import tqdm

    from sim.runtime import warming
    from sim.scenes import building as scenes

    names = arguments.names or list(scenes.names())
    for name in [*names, *([arguments.served] if arguments.served else [])]:
        if name not in scenes.names():
            raise ValueError(f"unknown preset {name!r}; choose from {', '.join(scenes.names())}")
    parent = os.getppid()
    if arguments.background and hasattr(os, "setpriority"):
        os.setpriority(os.PRIO_PROCESS, 0, 19)
    combinations = plan(names, arguments.toggles, arguments.served)
    skip = set()
    if arguments.served:
        served, steps = Combination(arguments.served).build()
        skip.add(warming.kernel_key(served, steps))
    started = time.perf_counter()
    compiled: list[tuple[str, float]] = []
    cached: list[tuple[str, float]] = []
    if arguments.background:  # one process at the lowest priority, stopping with its server
        for _, simulation, steps in _unique(combinations, skip):
            if os.getppid() != parent:
                return 0  # the server that started this ended
            warming.rehearse_simulation(simulation, steps)
        return 0
    unique = [combination for combination, _, _ in _unique(combinations, skip)]
    workers = worker_count(len(unique))
    bar = tqdm(total=len(unique), unit="scene", file=sys.stderr,
               desc=f"warming kernels ({workers} process{'es' if workers > 1 else ''})")
    failed: list[str] = []
    for label, seconds, did_compile in _rehearse_all(unique, workers, bar):
        if did_compile is None:
            failed.append(label)
        else:
            (compiled if did_compile else cached).append((label, seconds))
        bar.update(1)
    bar.close()
    total = time.perf_counter() - started
    print(f"{len(unique)} kernel combinations for {len(names)} preset(s) in {total:.0f} s on "
          f"{workers} process{'es' if workers > 1 else ''}: {len(compiled)} compiled "
          f"({sum(s for _, s in compiled):.0f} s), {len(cached)} already in numba's cache "
          f"({sum(s for _, s in cached):.1f} s)" + (f", {len(failed)} failed" if failed else ""))
    for label, seconds in compiled:
        print(f"  compiled  {label:<34} {seconds:6.1f} s")
    return 1 if failed else 0


NO_WARM_VARIABLE = "OSCILLATORS_NO_WARM"
"""When this environment variable is set (to anything but "" or "0"), ``serve`` warms nothing in
the background (the test suite sets it: its servers come and go in seconds)."""


def start_background(served: str | None) -> Any:
    """Start ``oscillators warm --background`` (every preset, ``served``'s toggles first) as a
    child process at the lowest CPU priority; returns its ``subprocess.Popen``, or None when
    ``OSCILLATORS_NO_WARM`` is set.  Stop it with ``stop_background``."""
    import subprocess

    if os.environ.get(NO_WARM_VARIABLE, "") not in ("", "0"):
        return None
    arguments = ["warm", "--background"] + (["--served", served] if served is not None else [])
    # the lowest priority from the start, before the imports (seconds of CPU themselves)
    command = [sys.executable, "-c", f"{_LOWEST}; from app.cli import main; "
               f"raise SystemExit(main({arguments!r}))"]
    return subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


_LOWEST = "import os; hasattr(os, 'setpriority') and os.setpriority(os.PRIO_PROCESS, 0, 19)"
"""Python that gives this process the lowest CPU priority (where the system has priorities)."""


def stop_background(process: Any) -> None:
    """End a process ``start_background`` started (if it is still warming)."""
    if process is None or process.poll() is not None:
        return
    process.terminate()
    try:
        process.wait(2.0)
    except Exception:  # still compiling after 2 s: end it
        process.kill()
