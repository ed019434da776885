"""The page's one way to choose a setting: ``app.study.choose`` (the code of `oscillators
choose`, `accuracy` and `scenes --measure`) on the scene as it is now, and applying exactly the
verified setting.

Both the Accuracy folder's *Choose for me* and the Speed-vs-accuracy folder's *Measure on this
scene* call ``choose_on_page``; its progress (run, label, time left) goes to the folder's text
about twice a second, the time left counted down from the planned seconds of computing (measured
cost per step x steps), and said to be over the plan when a run takes longer.  One choice runs
at a time per page server (``PageChoice``); ``cancel_choice`` stops it within a second
(``app.study.choose.ChoiceCancelled``), and a choice planned to take more than
``PAGE_CHOICE_LIMIT`` seconds of computing stops at once and says how long it would take.
``apply_choice`` sets the answer's integrator and dt as ordinary commands and reads back what
the simulation then runs: the page says what is in use, never what was asked.
"""

from __future__ import annotations

import threading
import time
import weakref
from typing import Any

import sim
from app.study.choose import Choice, ChoiceCancelled, Measured, choose
from app.web.host import PanelHost
from app.web.inputs import as_html

PAGE_CHOICE_LIMIT = 3600.0
"""Most seconds of planned computing a choice started from the page may take."""
TICK = 0.5
"""Seconds between two updates of the progress text."""

__all__ = ["ChoiceCancelled", "PageChoice", "apply_choice", "cancel_choice", "choose_on_page"]


def duration_text(seconds: float) -> str:
    """A duration in words: "40 s", "12 min", "3.5 h", "2.1 days", "3e+04 years"."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= 2 * size:
            return f"{seconds / size:.2g} {unit}"
    return f"{seconds:.0f} s"


class ChoiceTooLong(ValueError):
    """A choice planned to take more than ``PAGE_CHOICE_LIMIT`` seconds of computing."""


class PageProgress:
    """``app.study.choose.Progress`` shown as one line of a folder's HTML widget (see the module
    docstring); ``show()`` writes the line, a ticker calls it every ``TICK`` seconds."""

    def __init__(self, text: Any, limit: float = PAGE_CHOICE_LIMIT) -> None:
        self.text = text
        self.limit = limit
        self.total = 0.0
        self.done = 0.0
        self.label = "planning"
        self.started = self.since = time.monotonic()
        self.lock = threading.Lock()

    def planned(self, seconds: float) -> None:
        with self.lock:
            self.total = max(0.0, self.total + seconds)
            total = self.total
        if total > self.limit:
            raise ChoiceTooLong(
                f"this choice is planned to take about {duration_text(total)} of computing, over "
                f"the page's {duration_text(self.limit)}; shorten the scene's duration or use "
                "`oscillators choose` on a cluster")

    def finished(self, seconds: float, label: str) -> None:
        with self.lock:
            self.done += seconds
            self.label = label
            self.since = time.monotonic()
        self.show()

    def line(self) -> str:
        """What runs now, the time since the start and the time left (honest: counted down from
        the plan, and said to be over it when the current run takes longer)."""
        with self.lock:
            now = time.monotonic()
            elapsed = now - self.started
            left = self.total - self.done - (now - self.since)
            label, planned = self.label, self.total > self.done
        if not planned:
            rest = ""
        elif left >= 0:
            rest = f", about {duration_text(left)} left"
        else:
            rest = f", {duration_text(-left)} over the planned time"
        return f"measuring… {label} ({duration_text(elapsed)}{rest})"

    def show(self) -> None:
        self.text.content = as_html(self.line())


class PageChoice:
    """At most one choice at a time; ``cancel()`` stops the running one within a second."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.running = False

    def run(self, scene: sim.Scene, tolerance: float, text: Any) -> Choice:
        """``choose`` on ``scene`` with its progress in ``text``; raises ``ValueError`` when one
        runs already, ``ChoiceCancelled`` when cancelled."""
        with self._lock:
            if self.running:
                raise ValueError("a choice is being measured already; wait for it or cancel it")
            self.running = True
            self._stop.clear()
        progress = PageProgress(text)
        ticking = threading.Event()

        def tick() -> None:
            while not ticking.wait(TICK):
                progress.show()

        ticker = threading.Thread(target=tick, name="page-choice-progress", daemon=True)
        ticker.start()
        try:
            return choose(scene, tolerance, progress=progress, stop=self._stop.is_set)
        finally:
            ticking.set()
            ticker.join()
            with self._lock:
                self.running = False

    def cancel(self) -> bool:
        """Ask the running choice to stop; False if none runs."""
        if not self.running:
            return False
        self._stop.set()
        return True


_CHOICES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_CHOICES_LOCK = threading.Lock()


def page_choice(host: PanelHost) -> PageChoice:
    """The page server's one ``PageChoice``."""
    with _CHOICES_LOCK:
        found = _CHOICES.get(host)
        if found is None:
            found = _CHOICES[host] = PageChoice()
        return found


def choose_on_page(host: PanelHost, tolerance: float, text: Any) -> Choice:
    """``choose`` on the running scene's current model and initial state (``tolerance`` a
    fraction), its progress in ``text``; ``cancel_choice(host)`` stops it."""
    scene = host.runner.post(sim.scenes.scene_from_simulation).result(timeout=30)
    return page_choice(host).run(scene, tolerance, text)


def cancel_choice(host: PanelHost) -> bool:
    """Stop the page's running choice within a second; False if none runs."""
    return page_choice(host).cancel()


def apply_choice(host: PanelHost, answer: Measured) -> tuple[str, float]:
    """Set exactly the verified integrator and dt; returns what the simulation runs then."""
    host.control.set_integrator(answer.integrator).result(timeout=30)
    host.control.set_dt(answer.dt).result(timeout=30)
    in_use = host.runner.post(lambda simulation: (simulation.integrator, simulation.dt))
    integrator, dt = in_use.result(timeout=30)
    if (integrator, dt) != (answer.integrator, answer.dt):
        raise ValueError(f"the page runs {integrator} at dt = {dt!r} s, not the verified "
                         f"{answer.integrator} at dt = {answer.dt!r} s")
    return integrator, dt
