"""A pytest plugin that writes which numba kernels each test compiled and for how long, to find
what makes the default suite slow: ``OSCILLATORS_COMPILE_LOG=FILE pytest -p tests.compile_log``.

Each line of FILE is ``seconds<TAB>worker<TAB>test<TAB>kernel<TAB>signature`` for one top-level
compile (numba's ``numba:compile`` event; the functions it inlines are inside its time; the worker
is pytest-xdist's, or "main").
"""

from __future__ import annotations

import os
import threading
import time

import pytest
from numba.core import event

_current = {"test": "(collection)"}
_lock = threading.Lock()


class _Listener(event.Listener):
    def __init__(self, path: str) -> None:
        self.path = path
        self.started: dict[int, list[float]] = {}

    def on_start(self, ev):  # noqa: D102 - numba's interface
        self.started.setdefault(threading.get_ident(), []).append(time.perf_counter())

    def on_end(self, ev):  # noqa: D102 - numba's interface
        stack = self.started.get(threading.get_ident())
        if not stack:
            return
        began = stack.pop()
        if stack:  # a compile inside another: counted in the outer one
            return
        data = ev.data or {}
        dispatcher = data.get("dispatcher")
        name = getattr(getattr(dispatcher, "py_func", None), "__qualname__", "?")
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", "?")
        signature = str(data.get("args", ""))[:300].replace("\t", " ").replace("\n", " ")
        with _lock, open(self.path, "a", encoding="utf-8") as log:
            worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
            log.write(f"{time.perf_counter() - began:.2f}\t{worker}\t{_current['test']}\t"
                      f"{module}.{name}\t{signature}\n")


def pytest_configure(config):
    path = os.environ.get("OSCILLATORS_COMPILE_LOG")
    if path:
        event.register("numba:compile", _Listener(path))


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _current["test"] = item.nodeid
    yield
    _current["test"] = "(between tests)"
