"""The Modes folder's FPUT plot: the shares of a chain's modes 1-4 of its harmonic energy over
time, and the returns of mode 1 marked.

It subscribes to the runner's frames itself (with velocities) and samples every frame of a
one-row chain of equal masses between walls (``sim.instruments.mode_shares``); on other
lattices it shows nothing and costs nothing.  The plot has fixed options (shares 0 to 1 against
time in periods of mode 1), so a data update only sends data; a reset or a new scene removes it
and adds a new one in the same place, so no trace of the old run stays.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

import sim
from app.web.inputs import as_html
from app.web.plots import ENTERING, PADDING
from sim.instruments.mode_shares import ModeShares
from sim.runtime.runner import Frame

SHOWN_MODES = 4
"""Modes whose shares are drawn."""
COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")
RETURN_COLOUR = "#000000"
PLOT_INTERVAL = 1.0
"""Seconds between two updates of the plot's data."""


class ModeSharesView:
    """The plot and its line of text in ``folder`` (entered by the caller to place them)."""

    def __init__(self, gui: Any, folder: Any, runner: Any) -> None:
        self._gui, self._folder = gui, folder
        self._lock = threading.RLock()
        self.shares: ModeShares | None = None
        self._model: Any = None
        self._last_time = -1.0
        self._last_plot = 0.0
        self.text = gui.add_html("", visible=False)
        self.plot = gui.add_uplot(**self._options(self._empty()))
        self.plot.visible = False
        self._unsubscribe = runner.subscribe(self._sample, velocities=True)

    # --- the plot -------------------------------------------------------------------------------

    def _empty(self) -> tuple[np.ndarray, ...]:
        return (np.zeros(0),) * (SHOWN_MODES + 2)

    def _options(self, data: tuple[np.ndarray, ...], order: float | None = None) -> dict:
        series = [{"label": "t (periods of mode 1)"}]
        series += [{"label": f"mode {k + 1}", "stroke": COLOURS[k], "width": 1.5}
                   for k in range(SHOWN_MODES)]
        series.append({"label": "mode 1 back", "stroke": RETURN_COLOUR, "width": 0,
                       "points": {"show": True, "size": 9, "fill": RETURN_COLOUR}})
        return dict(data=data, series=tuple(series), order=order, aspect=1.6, padding=PADDING,
                    scales={"x": {"time": False}, "y": {"range": [0.0, 1.0]}},
                    axes=({"label": "time t (periods of mode 1)"},
                          {"label": "share of energy", "size": 50}))

    def _rebuild(self, visible: bool) -> None:
        """A new, empty plot in the old one's place (a reset or a new scene)."""
        order = self.plot.order
        self.plot.remove()
        with ENTERING, self._folder:
            self.plot = self._gui.add_uplot(**self._options(self._empty(), order))
        self.plot.visible = visible

    # --- frames ---------------------------------------------------------------------------------

    def _sample(self, frame: Frame) -> None:
        """Every frame, in the publishing thread: a sample of the chain's modes."""
        with self._lock:
            if frame.model is not self._model:
                self._model = frame.model
                try:
                    self.shares = ModeShares(frame.model, SHOWN_MODES)
                except sim.ModelError:
                    self.shares = None
                self._restart(frame)
            elif frame.time < self._last_time:  # a reset
                self.shares = ModeShares(frame.model, SHOWN_MODES) if self.shares else None
                self._restart(frame)
            self._last_time = frame.time
            if self.shares is not None and frame.velocities is not None:
                self.shares.add(frame.time, frame.positions, frame.velocities)

    def _restart(self, frame: Frame) -> None:
        visible = self.shares is not None
        self._rebuild(visible)
        self.text.visible = visible
        self.text.content = as_html("the shares of modes 1-4 appear as the chain runs")
        self._last_plot = 0.0

    def update(self, now: float) -> None:
        """Send the plot its data and say what it shows (about once a second)."""
        with self._lock:
            shares = self.shares
            if shares is None or now - self._last_plot < PLOT_INTERVAL or len(shares.times) < 2:
                return
            self._last_plot = now
            times = shares.times / shares.period
            values = shares.shares
            returns = shares.recurrences()
            marks = np.full(times.size, np.nan)
            for back in returns:
                marks[int(np.argmin(np.abs(times - back.periods)))] = back.share
            # in the lock: a reset's new plot never gets the old run's data
            absent = np.full(times.size, np.nan)  # a chain of fewer particles has fewer modes
            self.plot.data = (times, *(values[:, k] if k < values.shape[1] else absent
                                       for k in range(SHOWN_MODES)), marks)
            self.text.content = as_html(_words(shares, returns))


def _words(shares: ModeShares, returns: list) -> str:
    """What the plot shows, in a sentence or two."""
    now = shares.shares[-1, 0]
    text = (f"mode 1 (period {shares.period:.4g} s) holds {now:.1%} of the harmonic energy "
            f"at {shares.times[-1] / shares.period:.1f} periods")
    if returns:
        return text + "; back (●): " + ", ".join(
            f"{back.share:.1%} at {back.periods:.1f} periods" for back in returns)
    low_time, low_share = shares.lowest_share()
    return text + f"; lowest so far {low_share:.1%} at {low_time:.1f} periods"
