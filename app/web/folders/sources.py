"""The page's "Sources" folder: the scene's sources (``sim.model.sources``), one at a time.

Shown for scenes with sources (two-sources, single-slit, double-slit, or any scene file with
``[[model.sources]]``).  The dropdown picks a source; its frequency, amplitude and phase sliders
change it from now on (its start and ramp stay, so the wave goes on without a new ramp).  With two
or more sources, *Phase difference* sets the second source's phase to the first one's plus that
difference: at 0 the two-sources scene draws fixed nodal lines symmetric about the bisector, and
as it changes they swing.  *Move to the selection* puts the source at the selected particle (a
plane-wave source, which drives a whole column, moves to the selected particle's column), *Add at
the selection* adds a point source there with the chosen one's settings, *Remove* removes the
chosen source.

Like the rest of the panel, the folder is a view: ``show_scene`` and ``update`` only assign widget
values (``from_user`` keeps those from posting commands), and every value a page sends is checked
(``app.web.inputs``) before ``SimulationControl.set_sources`` posts it; a refused value is named
in red and the widgets show the sources in use again.
"""

from __future__ import annotations

import math

import numpy as np
import viser

import sim
from app.web.folders.drive import highest_mode_frequency, round_up
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, choice, from_user, number, ok_html, whole_number
from app.web.widgets import say, show_number
from sim.model.forcing import Driver, ForcingError
from sim.model.sources import ALL_ROWS, SourceError
from sim.runtime.runner import Frame

MAX_AMPLITUDE_SPACINGS = 0.5
"""Largest source amplitude the page accepts, in lattice spacings (a loaded scene's larger
amplitude widens it)."""
ADDED_RAMP = 3.0
"""Seconds over which a source added on the page ramps up."""
MAX_SOURCES = 8
"""Most sources the page adds up to."""
ERRORS = (InputRefused, sim.ModelError, ForcingError, SourceError, ValueError, TimeoutError)
"""What a refused change raises; shown in the folder, never a traceback."""


def where(source: Driver) -> str:
    """Where ``source`` acts, in words."""
    if source.row == ALL_ROWS:
        return f"column {source.column}, every row (a plane wave)"
    return f"particle (column {source.column}, row {source.row})"


def wrapped(phase: float) -> float:
    """``phase`` (rad) brought into (-pi, pi]."""
    value = math.remainder(phase, 2.0 * math.pi)
    return math.pi if value == -math.pi else value


class SourcesFolder(Folder):
    name = "sources"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._amplitude_limit = MAX_AMPLITUDE_SPACINGS
        self._shown: tuple = ()
        """The sources the widgets show."""
        gui = host.server.gui
        self.folder = gui.add_folder("Sources", expand_by_default=True)
        with self.folder:
            self.chosen = gui.add_dropdown("Source", ["1"], initial_value="1",
                                           hint="which source the sliders below change")
            self.where = gui.add_html("")
            self.frequency = gui.add_slider(
                "Frequency f (Hz)", 0.001, 4.0, 0.001, 0.33,
                hint="the source's frequency; its wavelength follows the lattice's dispersion")
            self.amplitude = gui.add_slider(
                "Amplitude A (m)", 0.0, MAX_AMPLITUDE_SPACINGS, 0.001, 0.01,
                hint="force: A k (N, the force of a spring stretched by A); displacement: A (m)")
            self.phase = gui.add_slider(
                "Phase (rad)", -math.pi, math.pi, 0.01, 0.0,
                hint="the source drives sin(2πf(t - start) + phase)")
            self.difference = gui.add_slider(
                "Phase difference 2 - 1 (rad)", -math.pi, math.pi, 0.01, 0.0,
                hint="the second source's phase minus the first one's: 0 in phase, ±π in "
                "antiphase; the nodal lines swing as it changes")
            self.move_button = gui.add_button(
                "Move to the selection", icon=viser.Icon.ARROWS_MOVE,
                hint="put the chosen source at the selected particle (a plane wave: its column)")
            self.add_button = gui.add_button(
                "Add at the selection", icon=viser.Icon.PLUS,
                hint="a new point source at the selected particle, like the chosen one")
            self.remove_button = gui.add_button("Remove this source", icon=viser.Icon.TRASH)
            self.message = gui.add_html("")

        def changed(field: str, read) -> None:
            def handler(_: viser.GuiEvent) -> None:  # thread pool: waits for the command
                try:
                    index = self._index()
                    value = read()
                    sources = list(self._sources())
                    sources[index] = Driver.create({**sources[index].as_table(), field: value})
                    self._apply(sources, f"source {index + 1}: {field} now {value:.4g}")
                except ERRORS as error:
                    self._refused(error)
            return handler

        self.frequency.on_update(from_user(changed("frequency", lambda: number(
            self.frequency.value, "frequency (Hz)", 0.0, self._max_frequency(), low_open=True))))
        self.amplitude.on_update(from_user(changed("amplitude", lambda: number(
            self.amplitude.value, "amplitude (m)", 0.0,
            self._amplitude_limit * float(self.host.runner.simulation.model.spacing)))))
        self.phase.on_update(from_user(changed("phase", lambda: number(
            self.phase.value, "phase (rad)", -math.pi, math.pi))))

        @self.difference.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                difference = number(self.difference.value, "phase difference (rad)",
                                    -math.pi, math.pi)
                sources = list(self._sources())
                if len(sources) < 2:
                    raise InputRefused("a phase difference needs two sources")
                first, second = sources[0], sources[1]
                sources[1] = Driver.create({**second.as_table(),
                                            "phase": wrapped(first.phase + difference)})
                self._apply(sources, f"source 2 is {difference:.3g} rad ahead of source 1")
            except ERRORS as error:
                self._refused(error)

        @self.chosen.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:  # shows the chosen source; posts nothing
            self.show_sources(self.host.runner.simulation.model)

        @self.move_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                index = self._index()
                column, row = self._selected()
                sources = list(self._sources())
                source = sources[index]
                place = {"column": column} if source.row == ALL_ROWS else {"column": column,
                                                                            "row": row}
                sources[index] = Driver.create({**source.as_table(), **place})
                self._apply(sources, f"source {index + 1} moved to {where(sources[index])}")
            except ERRORS as error:
                self._refused(error)

        @self.add_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                sources = list(self._sources())
                if len(sources) >= MAX_SOURCES:
                    raise InputRefused(f"the page adds up to {MAX_SOURCES} sources")
                column, row = self._selected()
                like = sources[self._index()].as_table() if sources else {
                    "direction": "z" if self.host.runner.simulation.model.dim == 3 else "y",
                    "amplitude": 0.02, "frequency": 0.33, "kind": "force"}
                added = Driver.create({**like, "column": column, "row": row, "phase": 0.0,
                                       "start": self.host.runner.simulation.time,
                                       "ramp": ADDED_RAMP})
                self._apply([*sources, added], f"added source {len(sources) + 1} at "
                            f"{where(added)}", choose=len(sources))
            except ERRORS as error:
                self._refused(error)

        @self.remove_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                sources = list(self._sources())
                index = self._index()
                removed = sources.pop(index)
                self._apply(sources, f"removed the source at {where(removed)}", choose=0)
            except ERRORS as error:
                self._refused(error)

    # --- from the page --------------------------------------------------------------------------

    def _sources(self) -> tuple[Driver, ...]:
        return tuple(self.host.runner.simulation.model.sources)

    def _index(self) -> int:
        count = len(self._sources())
        if count == 0:
            raise InputRefused("the scene has no source now; add one at the selection")
        options = [str(k + 1) for k in range(count)]
        return int(choice(self.chosen.value, "source", options)) - 1

    def _selected(self) -> tuple[int, int]:
        model = self.host.runner.simulation.model
        selection = np.asarray(self.host.view.selection)
        if not selection.size:
            raise InputRefused("select a particle first (click it)")
        particle = whole_number(selection[0], "particle", 0, model.n_particles - 1)
        return particle % model.nx, particle // model.nx

    def _max_frequency(self) -> float:
        """Half the step rate 1 / (2 dt) (Hz): above it the steps cannot follow the source."""
        return 0.5 / float(self.host.runner.simulation.dt)

    def _apply(self, sources: list[Driver], said: str, choose: int | None = None) -> None:
        self.host.control.set_sources(sources).result(timeout=30)
        model = self.host.runner.simulation.model
        if choose is not None:
            self._show_choices(model)
            self.chosen.value = str(min(choose, max(0, len(model.sources) - 1)) + 1)
        self.show_sources(model)
        self.message.content = ok_html(said)

    def _refused(self, error: BaseException) -> None:
        say(self.message, error, "refused")
        self.show_sources(self.host.runner.simulation.model)  # what runs, unchanged

    # --- keeping in step ------------------------------------------------------------------------

    def _show_choices(self, model: sim.Model) -> None:
        options = [str(k + 1) for k in range(max(1, len(model.sources)))]
        if list(self.chosen.options) != options:
            self.chosen.options = options
        if self.chosen.value not in options:
            self.chosen.value = options[0]

    def show_sources(self, model: sim.Model) -> None:
        """Show the chosen source and the phase difference in use (posts nothing)."""
        self._show_choices(model)
        sources = model.sources
        self._shown = sources
        self.difference.visible = len(sources) >= 2
        if len(sources) >= 2:
            show_number(self.difference, wrapped(sources[1].phase - sources[0].phase))
        if not sources:
            self.where.content = as_html("No source: select a particle and add one.")
            return
        source = sources[int(self.chosen.value) - 1]
        self._amplitude_limit = max(MAX_AMPLITUDE_SPACINGS, source.amplitude / model.spacing)
        self.amplitude.max = self._amplitude_limit * float(model.spacing)
        show_number(self.frequency, source.frequency)
        show_number(self.amplitude, source.amplitude)
        show_number(self.phase, wrapped(source.phase))
        axis = "xyz"[int(np.argmax(np.abs(source.direction)))]
        self.where.content = as_html(
            f"Source {self.chosen.value} of {len(sources)}: {where(source)}, {source.kind} "
            f"along {axis}, from t = {source.start:.4g} s")

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        self.folder.visible = bool(model.sources or simulation.scene.model.sources)
        self.frequency.max = round_up(1.5 * highest_mode_frequency(model))
        self.message.content = ""
        self.show_sources(model)

    def update(self, frame: Frame, now: float) -> None:
        """Follow sources changed elsewhere (another page, a loaded scene)."""
        if self.folder.visible and frame.model.sources != self._shown \
                and frame.model is self.host.runner.simulation.model:
            self.show_sources(frame.model)
