"""The page's "Scene" folder: what runs, a preset built at a chosen size, its walls and files.

The folder shows the scene's name, source, size and parameters.  *Build scene* replaces the
lattice by a preset (``sim.scenes.building``) with its own parameters at the chosen nx x ny (up to
``MAX_PAGE_PARTICLES``: larger lattices are for the command line).  One build runs at a time
and the last press wins: a press made while a build runs waits, and is skipped if a later press
came meanwhile; the size typed is used only if it was shown for the chosen preset (else the
preset's own size), so quick Preset and Build presses never mix two presets.  The walls
(``app.web.folders.walls``) and the Files subfolder (``app.web.folders.files``) share the
folder's message line.
"""

from __future__ import annotations

import threading
from typing import NamedTuple

import viser

import sim
from app.web.folders.files import SceneFileControls
from app.web.folders.share_controls import ShareControls
from app.web.folders.walls import WallsControls
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, choice, from_user, ok_html, whole_number
from app.web.scene_files import MAX_PAGE_PARTICLES
from app.web.widgets import ERRORS, say


class BuildChoice(NamedTuple):
    """What the page showed when *Build scene* was pressed: the preset, the size, and the preset
    that size was shown for."""

    preset: str
    nx: float
    ny: float
    sized_for: str


MAX_SIDE = 2_000
"""Largest nx or ny the page builds (and deepest sponge layer it accepts)."""
FALLBACK_PRESET = "grid"
"""Preset shown when the running scene is not a preset."""


class SceneFolder(Folder):
    name = "scene"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._build_lock = threading.Lock()
        self._press_lock = threading.Lock()
        self._presses = 0
        """Build presses so far (a build runs only if no later press came while it waited)."""
        self._building = 0
        """The press whose build runs or ran last (``show_scene`` leaves the preset and size
        alone while a later one waits)."""
        self._sized_for = ""
        """The preset whose size the nx and ny controls show (or the running scene's size)."""
        gui = host.server.gui
        simulation = host.runner.simulation
        names = sim.scenes.names()
        current = simulation.scene.name if simulation.scene.name in names else FALLBACK_PRESET
        with gui.add_folder("Scene", expand_by_default=False):
            self.info = gui.add_html("")
            self.preset = gui.add_dropdown("Preset", names, initial_value=current)
            self.nx = gui.add_number("Columns (nx)", simulation.model.nx, step=1)
            self.ny = gui.add_number("Rows (ny)", simulation.model.ny, step=1)
            self.build_button = gui.add_button(
                "Build scene", icon=viser.Icon.HAMMER,
                hint="replace the lattice by this preset (its own parameters) at this size",
            )
            self.walls = WallsControls(host, lambda: self.message, self.show_info, MAX_SIDE)
            self.files = SceneFileControls(host, lambda: self.message)
            self.share = ShareControls(host, lambda: self.message)
            self.message = gui.add_html("")
        self._sized_for = current

        @self.preset.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                name = choice(self.preset.value, "preset", sim.scenes.names())
            except InputRefused as error:
                self.show_scene(host.runner.simulation)  # every page: the scene in use
                say(self.message, error)
                return
            parameters = sim.scenes.presets.PRESETS[name].parameters
            self.nx.value = int(parameters.get("nx", 1))
            self.ny.value = int(parameters.get("ny", 1))
            self._sized_for = name

        @self.build_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            with self._press_lock:  # what the page showed when pressed: a build finishing
                self._presses += 1  # meanwhile shows its own scene in these widgets
                press, chosen = self._presses, self._chosen()
            with self._build_lock:
                if press == self._presses:  # else a later press builds
                    self._building = press
                    self._build(chosen)

    def _chosen(self) -> BuildChoice:
        return BuildChoice(self.preset.value, self.nx.value, self.ny.value, self._sized_for)

    def _build(self, chosen: BuildChoice) -> None:
        host = self.host
        try:
            name = choice(chosen.preset, "preset", sim.scenes.names())
            parameters = sim.scenes.presets.PRESETS[name].parameters
            nx, ny = chosen.nx, chosen.ny
            if chosen.sized_for != name:  # the size shown was another preset's
                nx, ny = int(parameters.get("nx", 1)), int(parameters.get("ny", 1))
            nx = whole_number(nx, "nx", 1, MAX_SIDE)
            ny = whole_number(ny, "ny", 1, MAX_SIDE)
            if nx * ny > MAX_PAGE_PARTICLES:
                raise InputRefused(
                    f"{nx}x{ny} = {nx * ny:,} particles; the page builds up to "
                    f"{MAX_PAGE_PARTICLES:,} (use `oscillators run` for larger lattices)"
                )
            overrides = {}
            if nx != parameters.get("nx", 1):
                overrides["nx"] = nx
            if ny != parameters.get("ny", 1):
                overrides["ny"] = ny
            self.message.content = as_html(f"building {name} {nx}x{ny}…")
            scene = sim.scenes.build(name, **overrides)
            host.replace_scene(scene, source=f"preset {name}")
        except ERRORS as error:
            self.show_scene(host.runner.simulation)  # every page: the scene in use
            say(self.message, error, "could not build")
            return
        self.message.content = ok_html(f"built {name} {nx}x{ny}")

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        with self._press_lock:
            waiting = self._presses > self._building  # a later press builds what it was shown
        if not waiting:
            if simulation.scene.name in sim.scenes.names():
                self.preset.value = simulation.scene.name
            self.nx.value, self.ny.value = model.nx, model.ny
            self._sized_for = self.preset.value
        self.show_info(simulation)
        self.walls.show(model)

    def show_info(self, simulation: sim.Simulation) -> None:
        model, scene = simulation.model, simulation.scene
        self.info.content = as_html(
            f"{scene.name} ({self.host.scene_source}): {model.nx}x{model.ny}, "
            f"{model.n_particles:,} particles\n{model.describe()}\n"
            f"{scene.description}".rstrip()
        )
