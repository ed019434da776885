"""The page's "Energy" folder: kinetic, potential, total and dissipated energy against time.

The plot keeps the last ``ENERGY_HISTORY`` frames and is redrawn a few times a second; a scene
with a driver (or one that had one) also shows the driver's work.  When the time goes back (a
reset, a new scene) the plot starts again at once.  Its axes say their quantity and unit, the
energy in J with the SI prefix that keeps its ticks readable (``app.web.widgets.PlotAxis``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

import sim
from app.web.host import Folder, PanelHost
from app.web.widgets import History, PlotAxis
from sim.runtime.runner import Frame

ENERGY_HISTORY = 600
"""Points kept in the energy plot."""
PLOT_INTERVAL = 0.25
"""Seconds between energy plot updates."""
SERIES = (
    {"label": "t (s)"},
    {"label": "kinetic", "stroke": "#1f77b4", "width": 1.5},
    {"label": "potential", "stroke": "#ff7f0e", "width": 1.5},
    {"label": "total", "stroke": "#222222", "width": 2},
    {"label": "dissipated", "stroke": "#9467bd", "width": 1.5},
)
"""The plot's x axis and lines (uPlot series) without a driver."""
DRIVER_SERIES = {"label": "driver's work", "stroke": "#2ca02c", "width": 1.5}


class EnergyFolder(Folder):
    name = "energy"

    def __init__(self, host: PanelHost) -> None:
        self.gui = host.server.gui
        self.history = History(ENERGY_HISTORY)
        """Kinetic, potential, total, dissipated energy and the driver's work (J) against time."""
        self._last_plot = 0.0
        self.shows_driver = False
        """Whether the plot has the driver's work line."""
        self.folder = self.gui.add_folder("Energy")
        self.plot: Any = None
        self.axis = PlotAxis("energy", "J", "simulated time t (s)")
        self._make_plot(with_driver=False)

    def _make_plot(self, with_driver: bool) -> None:
        """(Re)build the plot, with the driver's work or without (a uPlot's series are fixed when
        it is made)."""
        if self.plot is not None:
            self.plot.remove()
        series = (*SERIES, DRIVER_SERIES) if with_driver else SERIES
        empty = np.zeros(1)
        with self.folder:
            self.plot = self.gui.add_uplot(
                data=(empty,) * len(series), series=series,
                scales={"x": {"time": False}}, aspect=1.6, axes=self.axis.axes(),
            )
        self.axis.shown = None
        self.shows_driver = with_driver

    def show_scene(self, simulation: sim.Simulation) -> None:
        self.history.clear()
        self._last_plot = 0.0

    def update(self, frame: Frame, now: float) -> None:
        energy = frame.energy
        restarted = self.history.add(frame.time, (energy.kinetic, energy.potential,
                                                  energy.total, energy.dissipated, energy.driven))
        if restarted or len(self.history) == 1:
            self._last_plot = 0.0  # a reset: the old lines go at once
        with_driver = frame.model.driver is not None or energy.driven != 0.0
        if with_driver != self.shows_driver:
            self._make_plot(with_driver)
        if now - self._last_plot > PLOT_INTERVAL and len(self.history) >= 1:
            self._last_plot = now
            times, columns = self.history.columns()
            shown = columns if self.shows_driver else columns[:4]
            self.axis.show(self.plot, times, shown)
