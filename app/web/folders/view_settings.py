"""The page's "View" folder: what the 3-D view draws (springs, moving points, colours, sizes,
pictures per second of a large lattice).

These settings change the picture only (``app.web.view.ViewSettings``), never the simulation; a
changed setting redraws the lattice from a fresh frame.  A lattice's automatic choices (no springs
on large lattices, colours only on very large ones) are shown again for each new scene.
"""

from __future__ import annotations

from collections.abc import Callable

import viser

import sim
from app.web import projector, viser_adapter
from app.web.frames import MAX_FPS, PICTURE_RATES
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, choice, from_user, number
from app.web.view import COLOR_MODES, SPRING_HARD_LIMIT
from app.web.widgets import say


def rate_label(rate: float) -> str:
    """How the page names a picture rate (per second)."""
    return f"as the page draws (up to {rate:g})" if rate == MAX_FPS else f"at most {rate:g}"


class ViewSettingsFolder(Folder):
    name = "view"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        gui = host.server.gui
        settings = host.view.settings
        model = host.runner.simulation.model
        with gui.add_folder("View", expand_by_default=False):
            self.show_springs = gui.add_checkbox(
                "Springs", settings.springs_on(model),
                disabled=model.n_springs > SPRING_HARD_LIMIT,
                hint="coloured by strain: blue compressed, red stretched "
                f"(never drawn above {SPRING_HARD_LIMIT} springs)",
            )
            self.move_points = gui.add_checkbox(
                "Move points", settings.points_move(model),
                hint="send positions every frame (large lattices: colours only by default)",
            )
            self.color_by = gui.add_dropdown("Colour particles by", list(COLOR_MODES),
                                             initial_value=settings.coloring(model))
            self.particle_scale = gui.add_slider("Particle size", 0.2, 3.0, 0.1, 1.0)
            self.picture_rate = gui.add_dropdown(
                "Pictures per second", [rate_label(r) for r in PICTURE_RATES],
                initial_value=rate_label(settings.picture_rate),
                hint="large lattices are sent as pictures: each page gets the next one when it "
                "has drawn the last; a lower limit here holds every page to it")
            self.projector = gui.add_button(
                "Projector view (this page)", icon=viser.Icon.PRESENTATION,
                hint="large black text, a larger colour bar and stronger colours on this page "
                "alone; press again to go back")
            self.message = gui.add_html("")

        @self.projector.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            viser_adapter.run_javascript(event.client, projector.TOGGLE)

        def setting(handle: viser.GuiInputHandle, apply: Callable[[object], None]) -> None:
            """Apply ``handle``'s value from the page to the settings and redraw (or say why
            it was refused)."""
            @handle.on_update
            @from_user
            async def _(_: viser.GuiEvent) -> None:
                try:
                    apply(handle.value)
                except InputRefused as error:
                    self.show_settings(host.runner.simulation.model)  # every page: the ones in use
                    say(self.message, error)
                    return
                say(self.message, None)
                host.refresh()

        def springs(value: object) -> None:
            settings.show_springs = value is True

        def move_points(value: object) -> None:
            settings.move_points = value is True

        def color_by(value: object) -> None:
            settings.color_by = choice(value, "colour", list(COLOR_MODES))

        def particle_scale(value: object) -> None:
            settings.particle_scale = number(value, "particle size", 0.2, 3.0)

        def picture_rate(value: object) -> None:
            labels = [rate_label(r) for r in PICTURE_RATES]
            settings.picture_rate = PICTURE_RATES[labels.index(
                choice(value, "pictures per second", labels))]

        setting(self.show_springs, springs)
        setting(self.move_points, move_points)
        setting(self.color_by, color_by)
        setting(self.particle_scale, particle_scale)
        setting(self.picture_rate, picture_rate)

    def show_scene(self, simulation: sim.Simulation) -> None:
        """Back to the automatic settings for the new lattice, shown in the widgets."""
        model = simulation.model
        self.show_springs.disabled = model.n_springs > SPRING_HARD_LIMIT
        settings = self.host.view.settings
        settings.show_springs = settings.move_points = settings.color_by = None
        self.show_settings(model)

    def show_settings(self, model: sim.Model) -> None:
        """Show the settings in use (assigning values posts nothing)."""
        settings = self.host.view.settings
        self.show_springs.value = settings.springs_on(model)
        self.move_points.value = settings.points_move(model)
        self.color_by.value = settings.coloring(model)
        self.particle_scale.value = settings.particle_scale
        self.picture_rate.value = rate_label(settings.picture_rate)
