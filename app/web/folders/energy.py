"""The page's "Energy" folder: kinetic, potential, total and dissipated energy against time.

The plot keeps the last ``ENERGY_HISTORY`` frames and is redrawn a few times a second.  Its
lines: the kinetic energy, the springs' potential energy, gravity's potential energy (measured
from the rest positions, in a scene with gravity), the total, the energy the dampers took out,
and the driver's work (in a scene with a driver, or one that had one).  When the time goes back
(a reset, a new scene) the plot is emptied at once.  Its axes say their quantity and unit, the
energy in J with the SI prefix that keeps its ticks readable (``app.web.plots.LivePlot``).
*Download CSV* sends the page that pressed it the plotted series as a table (``app.csv_table``:
each column's quantity and unit in the header).
"""

from __future__ import annotations

import sim
from app.colours import ENERGY_COLOURS, hex_colour
from app.csv_table import ENERGY_COLUMNS, csv_text
from app.web.downloads import add_csv_button
from app.web.host import Folder, PanelHost
from app.web.plots import LivePlot
from app.web.widgets import History, PlotAxis
from sim.runtime.runner import Frame

ENERGY_HISTORY = 600
"""Points kept in the energy plot."""
PLOT_INTERVAL = 0.25
"""Seconds between energy plot updates."""
TIME_SERIES = {"label": "t (s)"}
LINES = {
    "kinetic": {"label": "kinetic", "stroke": hex_colour(ENERGY_COLOURS["kinetic"]),
               "width": 1.5},
    "spring": {"label": "springs' potential", "stroke": hex_colour(ENERGY_COLOURS["spring"]),
              "width": 1.5},
    "gravity": {"label": "gravity's potential", "stroke": hex_colour(ENERGY_COLOURS["gravity"]),
               "width": 1.5},
    "total": {"label": "total", "stroke": hex_colour(ENERGY_COLOURS["total"]),
             "width": 2},
    "dissipated": {"label": "dissipated", "stroke": hex_colour(ENERGY_COLOURS["dissipated"]),
                  "width": 1.5},
    "driven": {"label": "driver's work", "stroke": hex_colour(ENERGY_COLOURS["driven"]),
              "width": 1.5},
}
"""Each energy term (a ``sim.theory.observables.Energy`` field) and its line (a uPlot series)."""


def terms(gravity: bool, driver: bool) -> tuple[str, ...]:
    """The energy terms plotted: gravity's only in a scene with gravity, the driver's work only
    with a driver."""
    return tuple(term for term in LINES
                 if (term != "gravity" or gravity) and (term != "driven" or driver))


class EnergyFolder(Folder):
    name = "energy"

    def __init__(self, host: PanelHost) -> None:
        gui = host.server.gui
        self.history = History(ENERGY_HISTORY)
        """Every term of ``LINES`` (J) against time."""
        self._last_plot = 0.0
        self.terms = terms(gravity=False, driver=False)
        """The terms the plot shows."""
        self.scene = host.runner.simulation.scene.name
        with gui.add_folder("Energy") as self.folder:
            self.live = LivePlot(gui, self.folder, self._series(),
                                 PlotAxis("energy", "J", "simulated time t (s)"), aspect=1.6)
            self.download = add_csv_button(gui, "Download CSV", "the plotted energies",
                                           lambda: self.scene, self.csv, "energy")

    def csv(self) -> str:
        """The plotted series as CSV: simulated time (s) and each term shown (J)."""
        headings = [("simulated time t", "s")] + [(ENERGY_COLUMNS[term], "J") for term in self.terms]
        if not len(self.history):
            return csv_text(headings, [])
        times, columns = self.history.columns()
        shown = [columns[index] for index, term in enumerate(LINES) if term in self.terms]
        return csv_text(headings, zip(times, *shown, strict=True))

    @property
    def plot(self):
        """The viser plot shown now."""
        return self.live.handle

    @property
    def shows_driver(self) -> bool:
        return "driven" in self.terms

    def _series(self) -> tuple[dict, ...]:
        return (TIME_SERIES, *(LINES[term] for term in self.terms))

    def show_scene(self, simulation: sim.Simulation) -> None:
        self.scene = simulation.scene.name
        self.history.clear()
        self.live.clear()
        self._last_plot = 0.0

    def update(self, frame: Frame, now: float) -> None:
        energy = frame.energy
        restarted = self.history.add(frame.time, tuple(energy[term] for term in LINES))
        wanted = terms(gravity=frame.model.has_gravity,
                       driver=frame.model.driver is not None or energy.driven != 0.0)
        if wanted != self.terms:
            self.terms = wanted
            self.live.set_series(self._series())
            self._last_plot = 0.0
        if restarted:  # a reset: the old lines and their time range go at once
            self.live.clear()
            self._last_plot = 0.0
        if now - self._last_plot > PLOT_INTERVAL and len(self.history) >= 2:
            self._last_plot = now
            times, columns = self.history.columns()
            shown = [columns[index] for index, term in enumerate(LINES) if term in self.terms]
            self.live.show(times, shown)
