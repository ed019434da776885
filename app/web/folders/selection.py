"""The page's "Selection" folder: choose particles by row and column, and set their mass.

A click in the 3-D view selects a particle (shift+click adds); this folder selects one particle,
a row or a column by number, shows what is selected and its mean mass, and sets the selected
particles' mass.  *Hold while dragging* pins the selection to the gizmo during a drag.
"""

from __future__ import annotations

import numpy as np
import viser

import sim
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, choice, from_user, whole_number
from app.web.widgets import Limits, say

CHOICES = ("particle", "row", "column", "none")
"""What the Select buttons select."""


class SelectionFolder(Folder):
    name = "selection"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        with gui.add_folder("Selection"):
            self.text = gui.add_html(as_html(
                "Click a particle to select it (shift+click adds); drag the gizmo to move it."
            ))
            self.row = gui.add_number("Row", 0, step=1)
            self.column = gui.add_number("Column", 0, step=1)
            self.select_buttons = gui.add_button_group("Select", CHOICES)
            self.mass = gui.add_slider("Mass (kg)", 0.1, 20.0, 0.1, 1.0, disabled=True,
                                       hint="mass of the selected particles")
            self.hold = gui.add_checkbox("Hold while dragging", True,
                                         hint="pin the selection to the gizmo during a drag")
            self.message = gui.add_html("")
        self.limits = Limits({"mass": (0.1, 20.0)}, sliders={"mass": self.mass})
        """The server's limit of the mass slider, widened to show a selection's mass."""

        @self.select_buttons.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            model = host.runner.simulation.model
            try:
                what = choice(self.select_buttons.value, "selection", list(CHOICES))
                row = whole_number(self.row.value, "row", 0, model.ny - 1)
                column = whole_number(self.column.value, "column", 0, model.nx - 1)
            except InputRefused as error:
                say(self.message, error)
                return
            say(self.message, None)
            if what == "particle":
                chosen = np.array([row * model.nx + column])
            elif what == "row":
                chosen = row * model.nx + np.arange(model.nx)
            elif what == "column":
                chosen = np.arange(model.ny) * model.nx + column
            else:
                chosen = np.zeros(0, dtype=np.int64)
            host.set_selection(chosen)

        @self.mass.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            selection = host.view.selection
            if not selection.size:
                return
            try:
                mass = self.limits.check("mass", self.mass, "mass (kg)")
            except InputRefused as error:
                self.selection_changed(selection, host.runner.simulation.model)  # the mass in use
                say(self.message, error)
                return
            say(self.message, None)
            host.control.set_particle_masses(selection, mass)

        @self.hold.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            host.hold_while_dragging = self.hold.value is True

    def selection_changed(self, selection: np.ndarray, model: sim.Model) -> None:
        self.mass.disabled = selection.size == 0
        if selection.size == 0:
            self.text.content = as_html("Nothing selected: click a particle (shift+click adds).")
            return
        first = int(selection[0])
        row, column = divmod(first, model.nx)
        masses = model.masses.reshape(-1)[selection]
        where = (f"particle {first} (row {row}, column {column})" if selection.size == 1
                 else f"{selection.size} particles")
        self.text.content = as_html(f"Selected {where}, mass {masses.mean():.3g} kg")
        self.limits.show("mass", self.mass, float(masses.mean()))
