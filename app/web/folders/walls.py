"""The walls controls of the page's "Scene" folder: which boundary the running lattice has.

The dropdown offers the registered boundaries (``sim.model.boundaries``) and, for a loaded scene whose
boundary is not among them, that one too, so the widget always shows the walls in use.  *Apply
walls* changes the running lattice's walls and keeps its state; a change the model or the running
integrator cannot take is refused with the model's own explanation and the widgets show the walls
that still run.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import viser

import sim
from app.web.host import PanelHost
from app.web.inputs import choice, from_user, ok_html, whole_number
from app.web.widgets import ERRORS, say
from sim.model import boundaries


def offered(model: sim.Model) -> list[str]:
    """The boundaries the page offers for ``model``: the registered ones, and the model's own."""
    names = list(boundaries.names())
    return names if model.boundary in names else [*names, model.boundary]


def walls_hint() -> str:
    """The walls dropdown's hint: each registered boundary's description."""
    return "; ".join(f"{boundary}: {boundaries.get(boundary).description}"
                     for boundary in boundaries.names())


class WallsControls:
    """Builds the walls widgets in the current GUI folder; ``message`` is the folder's message
    area, ``changed(simulation)`` runs after the walls changed and ``max_width`` is the deepest
    sponge layer (particles) the page accepts."""

    def __init__(self, host: PanelHost, message: Callable[[], Any],
                 changed: Callable[[sim.Simulation], None], max_width: int) -> None:
        self.host = host
        gui = host.server.gui
        model = host.runner.simulation.model
        names = boundaries.names()
        self.boundary = gui.add_dropdown("Walls", offered(model), initial_value=names[0],
                                         hint=walls_hint())
        self.sponge_width = gui.add_number(
            "Sponge width (particles)", model.sponge_width, step=1,
            hint="depth of the absorbing layer; a wall gets one when the lattice is "
            "more than three layers long across it",
        )
        self.boundary_button = gui.add_button(
            "Apply walls", icon=viser.Icon.BORDER_OUTER,
            hint="change the running lattice's walls (its state is kept)",
        )

        @self.boundary_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # thread pool: waits for the command
            area = message()
            try:
                boundary = choice(self.boundary.value, "walls",
                                  offered(host.runner.simulation.model))
                width = whole_number(self.sponge_width.value, "sponge width", 1, max_width)
                host.control.set_boundary(boundary, width).result(timeout=30)
            except ERRORS as error:
                say(area, error, "could not change the walls")
                self.show(host.runner.simulation.model)  # what runs, unchanged
                return
            simulation = host.runner.simulation
            changed(simulation)
            model = simulation.model
            self.show(model)
            walls = (f"{model.boundary} ({'/'.join(model.sponge_sides)}, {model.sponge_width}-"
                     "particle sponge)" if boundaries.get(model.boundary).absorbing
                     else model.boundary)
            area.content = ok_html(f"walls now {walls}")

    def show(self, model: sim.Model) -> None:
        """Show the running walls (assigning the values posts nothing)."""
        self.boundary.options = offered(model)
        self.boundary.value = model.boundary
        self.sponge_width.value = model.sponge_width
