"""Child processes that compile kernels: ``call_in_child`` runs a module-level function in a
fresh interpreter (``python -m sim.runtime.warming``, the same environment and numba cache),
optionally with other calls beside it in children of their own, and waits for them.
``sim.runtime.warming`` says why kernels are compiled apart and read back from the cache.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
"""The folder holding the ``sim`` package, put first on the child's import path."""


CHILD_TIMEOUT = 3600.0
"""Seconds a child compiling kernels may take before this process compiles them itself (the
slowest compile seen, double-slit on a loaded machine, took 625 s)."""


def _child(function: Callable[..., Any], arguments: tuple, keywords: dict,
           keep: tuple[int, ...] = ()) -> tuple[Any, Any, bytes]:
    """A child process (``main``) started for ``function(*arguments, **keywords)``, the file its
    error output goes to, and the call it is to read on its standard input; ``keep``: file
    descriptors it inherits (under the same numbers)."""
    environment = dict(os.environ)
    environment["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT), *filter(None, [environment.get("PYTHONPATH")])])
    environment[PARENT_VARIABLE] = str(os.getpid())
    errors = tempfile.TemporaryFile()
    child = subprocess.Popen([sys.executable, "-m", "sim.runtime.warming"],
                             stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             stderr=errors, env=environment, pass_fds=keep)
    return child, errors, pickle.dumps((function, arguments, keywords))


def wait_for_end(descriptor: int) -> None:
    """Block until every process holding the other end of the pipe ``descriptor`` reads from
    has closed it or ended, however it ended (``call_in_child``'s signals)."""
    with os.fdopen(descriptor, "rb") as pipe:
        pipe.read()


def signal_ready(descriptor: int) -> None:
    """Close this end of a ``call_in_child`` signal: those waiting on it go on."""
    os.close(descriptor)


PARENT_VARIABLE = "OSCILLATORS_CHILD_OF"
"""The environment variable that gives a child the process id of the process that started it
(``end_with_parent``)."""


def end_with_parent() -> None:
    """In a child, first thing (Linux): be ended (SIGTERM) when the thread that started it
    ends, so a server stopped while a kernel compiles leaves no compiling process behind; and
    end at once if that process is gone already.  Done here, after the child started, rather
    than between fork and exec: Python code run there (``preexec_fn``) can deadlock the child
    and with it the thread waiting for the start, when another thread of the server held a
    lock (an import, a ``dlopen``) at the fork."""
    parent = os.environ.pop(PARENT_VARIABLE, None)
    if parent is None or not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != int(parent):  # it ended before the signal was asked for
        os._exit(1)


def _finish(child: Any, errors: Any, timeout: float | None) -> str:
    """Wait for ``child`` (killed after ``timeout`` s); the end of its error output."""
    try:
        child.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        child.kill()
        child.wait()
    errors.seek(0)
    tail = errors.read().decode(errors="replace").strip()[-400:]
    errors.close()
    return tail


def call_in_child(function: Callable[..., Any], *arguments: Any,
                  timeout: float | None = CHILD_TIMEOUT,
                  beside: Sequence[tuple[Callable[..., Any], tuple]] = (),
                  beside_done: str | None = None, beside_ready: str | None = None,
                  **keywords: Any) -> None:
    """``function(*arguments, **keywords)`` in a child process (the same interpreter,
    environment and numba cache; ``function`` a module-level function, the arguments
    picklable); its result is dropped.  ``beside``: (function, arguments) run at the same time
    in children of their own (kernels compiled side by side on other cores; their failures
    only cost time).  Two signals order them, each a pipe that reaches its end when the side
    that holds it closes it or ends, however it ends: ``beside_done``, the keyword under which
    ``function`` gets a descriptor for ``wait_for_end`` that returns once every ``beside``
    child has ended (so that it reads their kernels from the cache instead of compiling them
    too); ``beside_ready``, the keyword under which each ``beside`` function gets a descriptor
    to close when a first part of its work is done (``signal_ready``) and ``function`` one to
    wait on for all of them (``wait_for_end``).  Raises RuntimeError with the end of its error
    output if ``function`` fails."""
    main_keeps: list[int] = []
    beside_keeps: list[int] = []
    beside_keywords: dict[str, int] = {}
    opened: list[int] = []
    if beside and beside_done:
        reading, writing = os.pipe()
        opened += [reading, writing]
        keywords = {**keywords, beside_done: reading}
        main_keeps.append(reading)
        beside_keeps.append(writing)
    if beside and beside_ready:
        reading, writing = os.pipe()
        opened += [reading, writing]
        keywords = {**keywords, beside_ready: reading}
        main_keeps.append(reading)
        beside_keywords[beside_ready] = writing
        beside_keeps.append(writing)
    try:
        others = [_child(other, tuple(other_arguments), beside_keywords, tuple(beside_keeps))
                  for other, other_arguments in beside]
        children = [_child(function, arguments, keywords, tuple(main_keeps)), *others]
    finally:
        for descriptor in opened:  # the children hold them: each ends with its holders
            os.close(descriptor)
    for child, _, call in children:  # each reads its call as soon as it has started
        try:
            child.stdin.write(call)
            child.stdin.close()
        except OSError:  # it ended early: its exit status says why
            pass
    tails = [_finish(child, errors, timeout) for child, errors, _ in children]
    main = children[0][0]
    if main.returncode != 0:
        raise RuntimeError(f"the child process compiling the kernels exited with "
                           f"{main.returncode}: {tails[0]}")
