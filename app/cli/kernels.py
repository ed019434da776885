"""Kernels a command runs, read from numba's cache: compiled by a child process first when the
cache lacks them, with a line saying so, so that the run steps at the speed a process gets from
the cache (``sim.runtime.warming``, "Compiled apart")."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

from sim.runtime.warming import call_reading, prepare_reading


def announcer(talk: TextIO) -> Callable[[], None]:
    """The line said when kernels are compiled before a run."""
    def announce() -> None:
        print("compiling the kernels for this run in a child process (first time on this "
              "machine; later runs read them from the cache) ...", file=talk, flush=True)
    return announce


def prepare(simulation: Any, steps: int, talk: TextIO = sys.stderr) -> None:
    """Have every kernel a run of ``simulation`` calls (``steps`` at a time) read from the
    cache, compiled in a child process first if missing."""
    started = time.perf_counter()
    if prepare_reading(simulation, steps, announcer(talk)):
        print(f"kernels ready in {time.perf_counter() - started:.0f} s", file=talk, flush=True)


def reading(function: Callable[..., Any], talk: TextIO = sys.stderr, child: dict | None = None,
            **keywords: Any) -> Any:
    """``function(**keywords)`` with its kernels read from the cache (``call_reading``; the
    child's call with the keywords ``child`` overrides)."""
    return call_reading(function, child=child, announce=announcer(talk), **keywords)[0]
