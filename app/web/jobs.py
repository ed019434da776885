"""Work the page starts on the server that outlasts a click: one at a time, with progress, a
limit, a way to cancel, and an end when the server stops.

``PageJobs.start(name, work)`` runs ``work(report)`` in its own thread; ``work`` calls
``report(done, planned)`` as it goes and stops when that returns False (cancelled, or the server
is stopping).  A second start while one runs raises ``JobBusy`` with a sentence for the page.
``status()`` is a one-line summary for the page (progress in per cent, or how the last job
ended); ``cancel()`` asks the running job to stop; ``shutdown()`` (the server's SIGTERM or
Ctrl+C) cancels it and waits up to ``SHUTDOWN_WAIT`` seconds.  The page's movie download is
one such job (``app.web.folders.recording``), limited to ``MOVIE_FRAME_LIMIT`` frames.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

MOVIE_FRAME_LIMIT = 1000
"""Frames of a movie made for the page at most (its length: frames / 30 fps = 33 s)."""
SHUTDOWN_WAIT = 10.0
"""Seconds the server waits for a cancelled job to stop."""

Report = Callable[[int, int], bool]


class JobBusy(RuntimeError):
    """A job is already running (the message says which, for the page)."""


class PageJobs:
    """At most one running job; see the module docstring."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._cancel = threading.Event()
        self._closed = False
        self.name = ""
        self.done = 0
        self.planned = 0
        self.started = 0.0
        self.outcome = ""

    @property
    def running(self) -> bool:
        thread = self._thread
        return thread is not None and thread.is_alive()

    def start(self, name: str, work: Callable[[Report], Any],
              finished: Callable[[Any, BaseException | None], None]) -> None:
        """Run ``work(report)`` in a thread, then ``finished(result, error)`` (error None on
        success; a ``JobCancelled``-like exception of ``work`` when cancelled)."""
        with self._lock:
            if self._closed:
                raise JobBusy("the server is stopping")
            if self.running:
                raise JobBusy(f"{self.name} is being made ({self.percent():.0f} %); wait for it "
                              "or cancel it first")
            self._cancel.clear()
            self.name, self.done, self.planned, self.outcome = name, 0, 0, ""
            self.started = time.monotonic()

            def run() -> None:
                result: Any = None
                error: BaseException | None = None
                try:
                    result = work(self._report)
                except BaseException as raised:  # noqa: BLE001 - handed to ``finished``
                    error = raised
                self.outcome = ("cancelled" if self._cancel.is_set() else
                                f"failed: {error}" if error else "done")
                try:
                    finished(result, error)
                except Exception as raised:  # a failing page update must not go unseen
                    self.outcome = f"failed: {raised}"

            self._thread = threading.Thread(target=run, name=f"page-job-{name}", daemon=True)
            self._thread.start()

    def _report(self, done: int, planned: int) -> bool:
        self.done, self.planned = done, planned
        return not self._cancel.is_set()

    def percent(self) -> float:
        return 100.0 * self.done / self.planned if self.planned else 0.0

    def status(self) -> str:
        """One line for the page: progress of the running job, else how the last one ended."""
        if self.running:
            return (f"{self.name}: {self.done} of {self.planned or '?'} frames "
                    f"({self.percent():.0f} %), {time.monotonic() - self.started:.0f} s")
        return f"{self.name}: {self.outcome}" if self.name and self.outcome else ""

    def cancel(self) -> bool:
        """Ask the running job to stop; False if none runs."""
        if not self.running:
            return False
        self._cancel.set()
        return True

    def shutdown(self, wait: float = SHUTDOWN_WAIT) -> None:
        """Refuse new jobs, cancel the running one and wait for it (the server is stopping)."""
        with self._lock:
            self._closed = True
        self._cancel.set()
        thread = self._thread
        if thread is not None:
            thread.join(wait)
