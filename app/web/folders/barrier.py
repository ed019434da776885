"""The page's "Barrier" folder: one or two slits in the scene's barrier, their width and
separation.

Shown for scenes with a barrier along a column (single-slit, double-slit, or a scene file with
``[[model.barriers]]``).  *Slits* (one or two), *Slit width* (open particles per slit) and
*Separation* (particles between the two slits' centres) rebuild the barrier's openings around the
same centre row (``sim.model.sources.slit_openings``) from now on; the pinned particles of the new
barrier stop where they are.  The line under the sliders says the gap between the pinned
particles either side of a slit (the width the fringe theory uses) and the slits' separation in
metres.  A barrier whose openings are neither one nor two equal slits is shown as it is
("as loaded") until a slider changes it.

The folder is a view: showing a scene only assigns widget values (``from_user``), and every value
a page sends is checked (``app.web.inputs``) before ``SimulationControl.set_barriers`` posts it.
"""

from __future__ import annotations

import viser

import sim
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, choice, from_user, ok_html, whole_number
from app.web.widgets import say, show_number
from sim.model.sources import Barrier, SourceError, slit_openings
from sim.runtime.runner import Frame

SLITS = {"one": 1, "two": 2}
"""The dropdown's entries and their numbers of slits."""
AS_LOADED = "as loaded"
ERRORS = (InputRefused, sim.ModelError, SourceError, ValueError, TimeoutError)


def column_barrier(model: sim.Model) -> tuple[int, Barrier] | None:
    """(index in ``model.barriers``, barrier) of the model's first barrier along a column."""
    return next(((k, b) for k, b in enumerate(model.barriers) if b.axis == "column"), None)


def slit_geometry(barrier: Barrier) -> tuple[str, int, int, int]:
    """(slits entry, width, separation, centre row) that describe ``barrier``'s openings:
    "one" / "two" for one or two equal slits, else ``AS_LOADED`` (then width and separation
    are those of the first two openings, where there are any)."""
    openings = barrier.openings
    widths = [last - first + 1 for first, last in openings]
    centres = [0.5 * (first + last) for first, last in openings]
    width = widths[0] if widths else 1
    separation = round(centres[1] - centres[0]) if len(centres) >= 2 else 2 * width
    centre = round(0.5 * (centres[0] + centres[-1])) if centres else 0
    if len(openings) == 1:
        return "one", width, separation, centre
    if len(openings) == 2 and widths[0] == widths[1]:
        return "two", width, separation, centre
    return AS_LOADED, width, separation, centre


class BarrierFolder(Folder):
    name = "barrier"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._centre = 0
        self._shown: tuple = ()
        """The barriers the widgets show."""
        gui = host.server.gui
        self.folder = gui.add_folder("Barrier", expand_by_default=True)
        with self.folder:
            self.slits = gui.add_dropdown("Slits", list(SLITS), initial_value="two",
                                          hint="one slit or two in the barrier")
            self.width = gui.add_slider(
                "Slit width (particles)", 1, 40, 1, 3,
                hint="open particles per slit; the gap between the pinned particles either "
                "side is one spacing more")
            self.separation = gui.add_slider(
                "Separation (spacings)", 2, 100, 1, 20,
                hint="between the two slits' centres (two slits)")
            self.geometry = gui.add_html("")
            self.message = gui.add_html("")

        def rebuild(_: viser.GuiEvent) -> None:  # thread pool: waits for the command
            try:
                self.rebuild_from_page()
            except ERRORS as error:
                say(self.message, error, "refused")
                self.show_barrier(self.host.runner.simulation.model)  # what runs, unchanged

        for handle in (self.slits, self.width, self.separation):
            handle.on_update(from_user(rebuild))

    def rebuild_from_page(self) -> Barrier:
        """Check the folder's values and rebuild the barrier (waits for the command)."""
        model = self.host.runner.simulation.model
        found = column_barrier(model)
        if found is None:
            raise InputRefused("the scene has no barrier along a column")
        index, barrier = found
        slits = SLITS[choice(self.slits.value, "slits", list(SLITS))]
        width = whole_number(self.width.value, "slit width", 1, model.ny)
        separation = whole_number(self.separation.value, "separation", 2, model.ny)
        openings = slit_openings(slits, width, separation, self._centre)
        rebuilt = Barrier(axis="column", index=barrier.index, openings=openings)
        barriers = list(model.barriers)
        barriers[index] = rebuilt
        self.host.control.set_barriers(barriers).result(timeout=30)
        self.show_barrier(self.host.runner.simulation.model)
        self.message.content = ok_html(f"now {rebuilt.describe()}")
        return rebuilt

    def show_barrier(self, model: sim.Model) -> None:
        """Show the barrier in use (assigning values posts nothing)."""
        self._shown = model.barriers
        found = column_barrier(model)
        if found is None:
            self.geometry.content = as_html("No barrier along a column.")
            return
        _, barrier = found
        slits, width, separation, self._centre = slit_geometry(barrier)
        options = list(SLITS) + ([AS_LOADED] if slits == AS_LOADED else [])
        if list(self.slits.options) != options:
            self.slits.options = options
        self.slits.value = slits
        show_number(self.width, width)
        show_number(self.separation, separation)
        self.separation.visible = slits != "one"
        a = float(model.spacing)
        text = (f"{barrier.describe()}: gap {(width + 1) * a:.3g} m between the pinned "
                f"particles either side of a slit")
        if slits != "one":
            text += f", slits {separation * a:.3g} m apart"
        self.geometry.content = as_html(text)

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        self.folder.visible = column_barrier(model) is not None
        self.message.content = ""
        self.show_barrier(model)

    def update(self, frame: Frame, now: float) -> None:
        """Follow a barrier changed elsewhere (another page)."""
        if self.folder.visible and frame.model.barriers != self._shown \
                and frame.model is self.host.runner.simulation.model:
            self.show_barrier(frame.model)
