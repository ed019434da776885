"""The page's "In words" folder: the lattice described in sentences (``app.web.description``),
about once a second, in a live region of the page (``role="status"``, ``aria-live="polite"``) that
a screen reader reads out when it changes.  The followed particle is the first selected one."""

from __future__ import annotations

import html

import numpy as np

import sim
from app.web.description import describe
from app.web.host import Folder, PanelHost
from sim.runtime.runner import Frame

INTERVAL = 1.0
"""Seconds between two descriptions."""


def live_html(text: str) -> str:
    """``text`` escaped in a live region a screen reader reads when it changes."""
    return ('<div role="status" aria-live="polite" style="font-size:0.85em;padding:0 0.6em;'
            f'white-space:pre-wrap;overflow-wrap:anywhere">{html.escape(text)}</div>')


class DescriptionFolder(Folder):
    name = "description"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._shown_at = -INTERVAL
        self._text = ""
        self._followed: int | None = None
        with host.server.gui.add_folder("In words"):
            self.words = host.server.gui.add_html(live_html("The lattice, described in words."))

    def show_scene(self, simulation: sim.Simulation) -> None:
        """A new lattice: said at once (its first frame may wait for its kernels)."""
        model = simulation.model
        self._say(f"A new lattice: {simulation.scene.name}, {model.nx} × {model.ny} particles, "
                  f"t = {simulation.time:.4g} s; {simulation.integrator} at dt = "
                  f"{simulation.dt:g} s.")
        self._shown_at = -INTERVAL

    def _say(self, text: str) -> None:
        if text != self._text:  # the region is read out when it changes
            self._text = text
            self.words.content = live_html(text)

    def selection_changed(self, selection: np.ndarray, model: sim.Model) -> None:
        self._followed = int(selection[0]) if len(selection) else None

    def update(self, frame: Frame, now: float) -> None:
        if frame.model is not self.host.runner.simulation.model:
            return  # a frame of the lattice before (a new one was just put in)
        if frame.playing and now - self._shown_at < INTERVAL:
            return  # a paused lattice's frames are few (a step, a new scene): each is described
        self._shown_at = now
        if frame.preparing is not None:
            model = frame.model
            self._say(f"A lattice of {model.nx} × {model.ny} particles: its kernels are being "
                      "prepared (the first time on this machine); it starts when they are "
                      "ready.")
            return
        self._say(describe(frame, self._followed))
