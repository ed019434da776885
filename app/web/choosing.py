"""The page's one way to choose a setting: ``app.study.choose`` (the code of `oscillators
choose`, `accuracy` and `scenes --measure`) on the scene as it is now, and applying exactly the
verified setting.

Both the Accuracy folder's *Choose for me* and the Speed-vs-accuracy folder's *Measure on this
scene* call ``choose_on_page``; its progress (run, label, estimated time left) goes to the
folder's text.  ``apply_choice`` sets the answer's integrator and dt as ordinary commands and
reads back what the simulation then runs: the page says what is in use, never what was asked.
"""

from __future__ import annotations

import time
from typing import Any

import sim
from app.study.choose import Choice, Measured, choose
from app.web.host import PanelHost
from app.web.inputs import as_html


class PageProgress:
    """``app.study.choose.Progress`` shown as one line of a folder's HTML widget: what runs now
    and the time left, from the planned seconds (measured cost per step x steps)."""

    def __init__(self, text: Any) -> None:
        self.text = text
        self.total = 0.0
        self.done = 0.0
        self.started = time.monotonic()

    def planned(self, seconds: float) -> None:
        self.total = max(0.0, self.total + seconds)

    def finished(self, seconds: float, label: str) -> None:
        self.done += seconds
        elapsed = time.monotonic() - self.started
        left = ""
        if self.done > 0 and self.total > self.done:
            left = f", about {elapsed * (self.total - self.done) / self.done:.0f} s left"
        self.text.content = as_html(f"measuring… {label} ({elapsed:.0f} s{left})")


def choose_on_page(host: PanelHost, tolerance: float, text: Any) -> Choice:
    """``choose`` on the running scene's current model and initial state (``tolerance`` a
    fraction), its progress in ``text``."""
    scene = host.runner.post(sim.scenes.scene_from_simulation).result(timeout=30)
    return choose(scene, tolerance, progress=PageProgress(text))


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
