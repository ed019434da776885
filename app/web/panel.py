"""The GUI panel of the web app: folders of controls, the status line and the energy plot.

The panel is a view of the app.  It shows the app's state (``show_scene`` after a new lattice,
``update(frame)`` for every frame drawn) and turns what a *user* does into commands through
``SimulationControl`` or the app's own methods.  Two rules keep it honest:

* viser runs a widget's ``on_update`` callbacks also when the server assigns ``.value``.  Every
  callback here is wrapped by ``from_user``, which ignores events that no browser sent, so
  refreshing the panel never posts a command (showing a scene never changes it);
* the browser's min/max are hints: every value a page sends is checked on the server
  (``app.web.inputs``) and a bad one is refused with a red message, never clamped.

Messages are shown with ``as_html`` (escaped), so text from a page is never rendered as markup.
The panel does not import the app; it talks to it through the ``PanelHost`` protocol.
"""

from __future__ import annotations

import collections
import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import viser

import sim
from app.web.accuracy import AccuracyFolder
from app.web.control import MASS_PATTERNS, MAX_STEPS_PER_FRAME, LatticeRunner, SimulationControl
from app.web.drive import DriveFolder
from app.web.inputs import (
    InputRefused,
    amber_html,
    as_html,
    choice,
    from_user,
    number,
    ok_html,
    warning_html,
    whole_number,
)
from app.web.probes import ProbesFolder
from app.web.recording import RecordingBusy, WebRecordings
from app.web.scene_files import SceneDirectory
from app.web.spectrum import MATPLOTLIB_LOCK, SpectrumFolder
from app.web.view import COLOR_MODES, SPRING_HARD_LIMIT, LatticeView
from sim.integrators import PRECISIONS
from sim.runner import Frame

MAX_STIFFNESS = 100.0
"""The stiffness slider's maximum (N/m); the paper's default 35 N/m is 35 % of it."""
ENERGY_HISTORY = 600
"""Points kept in the energy plot."""
PLOT_INTERVAL = 0.25
"""Seconds between energy plot updates."""
STUDY_PARTICLE_LIMIT = 2_500
"""Largest lattice the page measures speed against accuracy on (bigger: use the CLI)."""
MAX_SIDE = 2_000
"""Largest nx or ny the page builds."""
MAX_PAGE_PARTICLES = 1_000_000
"""Largest lattice (nx * ny) the page builds; bigger ones: the command line."""
MAX_DT = 10.0
"""Largest time step (s) the page accepts."""
MAX_THREADS = max(1, os.cpu_count() or 1)
"""Most threads the page lets the compiled steps use: the machine's cores."""
AS_LOADED = "as loaded"
"""Mass-pattern entry shown for masses that are neither uniform nor the ionic checkerboard."""

WALLS = ("fixed", "absorbing", "periodic", "free")
"""Walls the page offers (a loaded scene's other boundary, e.g. periodic rows, is shown too)."""

ERROR_TYPES = (InputRefused, sim.ModelError, sim.SceneError, ValueError, RecordingBusy)
"""What a refused user action raises; shown in the page, never a traceback."""


class PanelHost(Protocol):
    """What the panel needs of the web app (``app.web.app.WebApp`` provides it)."""

    server: viser.ViserServer
    runner: LatticeRunner
    control: SimulationControl
    view: LatticeView
    scene_files: SceneDirectory
    recordings: WebRecordings
    scene_source: str
    hold_while_dragging: bool

    def set_selection(self, indices: np.ndarray) -> None: ...

    def refresh(self) -> None: ...

    def replace_scene(self, scene: sim.Scene, source: str,
                      timeout: float = 120.0) -> sim.Simulation: ...


def _file_name(name: str) -> str:
    """A harmless download name from a scene name."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)[:60] or "scene"


def mass_pattern_of(model: sim.Model) -> str:
    """The page's mass pattern for a model: uniform, ionic (the checkerboard), or as loaded."""
    if model.uniform_mass:
        return "uniform"
    masses = np.asarray(model.masses).reshape(model.ny, model.nx)
    rows, columns = np.indices(masses.shape)
    even = masses[(rows + columns) % 2 == 0]
    odd = masses[(rows + columns) % 2 == 1]
    if even.size and odd.size and np.all(even == even.flat[0]) and np.all(odd == 1.0):
        return "ionic"
    return AS_LOADED


class ControlPanel:
    """Builds the GUI for ``app`` and keeps it in step with the frames."""

    def __init__(self, app: PanelHost) -> None:
        self.app = app
        self.control = app.control
        self.gui = app.server.gui
        simulation = app.runner.simulation
        model = simulation.model
        self._times: collections.deque[float] = collections.deque(maxlen=ENERGY_HISTORY)
        self._energies: collections.deque[tuple[float, float, float, float, float]] = (
            collections.deque(maxlen=ENERGY_HISTORY)
        )
        self._plot_shows_driver = False
        self._last_plot = 0.0
        self._last_status = 0.0
        self._status_steps = (time.perf_counter(), 0)
        self._steps_per_second = 0.0
        self._stability_key: tuple | None = None
        self._stable_dt: float | None = None
        self._stability_text = ""
        self._error_shown: str | None = None
        self._subscriber_errors_seen = 0
        self._recording_failure_shown: str | None = None

        self._build_run_folder()
        self._build_scene_folder(simulation)
        self._build_integrator_folder(simulation)
        self.accuracy = AccuracyFolder(app, self.gui)
        self._build_physics_folder(model)
        self._build_selection_folder()
        self.spectrum = SpectrumFolder(app, self.gui)
        self.probes = ProbesFolder(app, self.gui)
        self.drive = DriveFolder(app, self.gui)
        self._build_view_folder()
        self._build_recording_folder()
        self._build_study_folder()
        self._build_energy_plot()
        self.show_scene(simulation)

    @staticmethod
    def _say(area: Any, error: BaseException | str | None, verb: str = "refused") -> None:
        """Show ``error`` in a message ``area`` (red), or clear it."""
        if error is None:
            area.content = ""
        else:
            area.content = warning_html(f"{verb}: {error}")

    # --- folders ---------------------------------------------------------------------------------

    def _build_run_folder(self) -> None:
        gui = self.gui
        with gui.add_folder("Run"):
            self.play_button = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY,
                                              hint="start or pause the simulation")
            self.step_button = gui.add_button("Single step", icon=viser.Icon.PLAYER_TRACK_NEXT)
            self.reset_button = gui.add_button("Reset", icon=viser.Icon.REFRESH,
                                               hint="back to the scene's initial state")
            self.status = gui.add_html("")
            self.error_html = gui.add_html("", visible=False)
            self.part_html = gui.add_html("", visible=False)

        @self.play_button.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            if self.app.runner.playing:
                self.control.pause()
            else:
                self.control.play()
            self._show_playing()

        @self.step_button.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            self.control.single_step()
            self._show_playing()

        @self.reset_button.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            self.control.reset()
            self._clear_history()

    def _build_scene_folder(self, simulation: sim.Simulation) -> None:
        gui = self.gui
        names = sim.scenes.names()
        current = simulation.scene.name if simulation.scene.name in names else "grid"
        directory = self.app.scene_files.root.name or str(self.app.scene_files.root)
        with gui.add_folder("Scene", expand_by_default=False):
            self.scene_info = gui.add_html("")
            self.preset = gui.add_dropdown("Preset", names, initial_value=current)
            self.nx = gui.add_number("Columns (nx)", simulation.model.nx, min=1, max=MAX_SIDE,
                                     step=1)
            self.ny = gui.add_number("Rows (ny)", simulation.model.ny, min=1, max=MAX_SIDE,
                                     step=1)
            self.build_button = gui.add_button(
                "Build scene", icon=viser.Icon.HAMMER,
                hint="replace the lattice by this preset (its own parameters) at this size",
            )
            self.boundary = gui.add_dropdown(
                "Walls", list(WALLS), initial_value=WALLS[0],
                hint="fixed: waves reflect at the walls; absorbing: a sponge layer along the "
                "walls takes the waves out (an open lattice); periodic: each row is a ring "
                "(what leaves on the right comes back on the left); free: the rows' ends have no "
                "wall spring (a pulse comes back upright)",
            )
            self.sponge_width = gui.add_number(
                "Sponge width (particles)", simulation.model.sponge_width, min=1, max=MAX_SIDE,
                step=1, hint="depth of the absorbing layer; a wall gets one when the lattice is "
                "more than three layers long across it",
            )
            self.boundary_button = gui.add_button(
                "Apply walls", icon=viser.Icon.BORDER_OUTER,
                hint="change the running lattice's walls (its state is kept)",
            )
            with gui.add_folder("Files"):
                self.download_button = gui.add_button(
                    "Download this scene", icon=viser.Icon.DOWNLOAD,
                    hint="save the current state and parameters to your computer "
                    "(.toml, or .zip when it carries per-particle arrays)",
                )
                self.upload_button = gui.add_upload_button(
                    "Open a scene file…", icon=viser.Icon.UPLOAD, mime_type=".toml,.zip",
                    hint="a .toml or .zip scene file from your computer",
                )
                self.server_scenes = gui.add_dropdown(
                    f"In {directory}/", ["(none)"], initial_value="(none)",
                    hint=f"scene files in the server's {directory}/ directory "
                    "(serve --scenes-dir)",
                )
                self.open_button = gui.add_button("Open", icon=viser.Icon.FOLDER_OPEN)
                self.list_button = gui.add_button("Refresh list", icon=viser.Icon.REFRESH)
            self.scene_message = gui.add_html("")
        self._list_server_scenes()

        @self.preset.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                name = choice(self.preset.value, "preset", sim.scenes.names())
            except InputRefused as error:
                self._say(self.scene_message, error)
                return
            parameters = sim.scenes.PRESETS[name].parameters
            self.nx.value = int(parameters.get("nx", 1))
            self.ny.value = int(parameters.get("ny", 1))

        @self.build_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                name = choice(self.preset.value, "preset", sim.scenes.names())
                nx = whole_number(self.nx.value, "nx", 1, MAX_SIDE)
                ny = whole_number(self.ny.value, "ny", 1, MAX_SIDE)
                if nx * ny > MAX_PAGE_PARTICLES:
                    raise InputRefused(
                        f"{nx}x{ny} = {nx * ny:,} particles; the page builds up to "
                        f"{MAX_PAGE_PARTICLES:,} (use `oscillators run` for larger lattices)"
                    )
                parameters = sim.scenes.PRESETS[name].parameters
                overrides = {}
                if nx != parameters.get("nx", 1):
                    overrides["nx"] = nx
                if ny != parameters.get("ny", 1):
                    overrides["ny"] = ny
                self.scene_message.content = as_html(f"building {name} {nx}x{ny}…")
                scene = sim.scenes.build(name, **overrides)
                self.app.replace_scene(scene, source=f"preset {name}")
            except ERROR_TYPES as error:
                self._say(self.scene_message, error, "could not build")
                return
            self.scene_message.content = ok_html(f"built {name} {nx}x{ny}")

        @self.boundary_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # thread pool: waits for the command
            try:
                boundary = choice(self.boundary.value, "walls", self._walls(
                    self.app.runner.simulation.model))
                width = whole_number(self.sponge_width.value, "sponge width", 1, MAX_SIDE)
                self.control.set_boundary(boundary, width).result(timeout=30)
            except ERROR_TYPES as error:
                self._say(self.scene_message, error, "could not change the walls")
                self._show_boundary(self.app.runner.simulation.model)  # what runs, unchanged
                return
            simulation = self.app.runner.simulation
            self._show_scene_info(simulation)
            self._stability_key = None
            model = simulation.model
            self._show_boundary(model)
            walls = (f"absorbing ({'/'.join(model.sponge_sides)}, {model.sponge_width}-particle "
                     "sponge)" if model.boundary == "absorbing" else model.boundary)
            self.scene_message.content = ok_html(f"walls now {walls}")

        @self.download_button.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            try:
                scene = self.control.snapshot().result(timeout=30)
                suffix, content = sim.scenes.to_bytes(scene)
            except Exception as error:  # a failed save must not take the page down
                self._say(self.scene_message, error, "could not save")
                return
            name = _file_name(scene.name) + suffix
            event.client.send_file_download(name, content, save_immediately=True)
            self.scene_message.content = ok_html(f"sent {name} ({len(content):,} bytes)")

        @self.upload_button.on_upload
        @from_user
        def _(event: viser.GuiEvent) -> None:
            upload = self.upload_button.value
            name = str(upload.name)[:200]
            try:
                limit = sim.scenes.MAX_UPLOAD_BYTES
                if len(upload.content) > limit:
                    raise InputRefused(f"the file is larger than {limit / 1e6:g} MB")
                scene = sim.scenes.from_bytes(bytes(upload.content), name)
                self.app.replace_scene(scene, source=f"upload {name}")
            except ERROR_TYPES as error:
                self._say(self.scene_message, error, f"could not open {name}")
                return
            self.scene_message.content = ok_html(f"opened {name}")

        @self.open_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            chosen = self.server_scenes.value
            try:
                scene = self.app.scene_files.load(chosen)
                self.app.replace_scene(scene, source=f"file {chosen}")
            except ERROR_TYPES as error:
                self._say(self.scene_message, error, "could not open")
                return
            self.scene_message.content = ok_html(f"opened {chosen}")

        @self.list_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self._list_server_scenes()

    def _list_server_scenes(self) -> None:
        names = self.app.scene_files.names() or ["(none)"]
        self.server_scenes.options = names
        if self.server_scenes.value not in names:
            self.server_scenes.value = names[0]
        self.open_button.disabled = names == ["(none)"]

    def _build_integrator_folder(self, simulation: sim.Simulation) -> None:
        gui = self.gui
        with gui.add_folder("Integrator"):
            self.integrator = gui.add_dropdown(
                "Method", sim.integrators.names(simulation.model),
                initial_value=simulation.integrator,
                hint="euler (1st order), heun (2nd), verlet (symplectic 2nd), rk4 (4th); "
                "exact (the normal-mode solution, no time-step error) for linearised springs",
            )
            self.dt = gui.add_number("Time step dt (s)", simulation.dt, min=1e-6, max=MAX_DT,
                                     step=1e-4)
            self.stability_html = gui.add_html("")
            self.steps_per_frame = gui.add_slider(
                "Steps per frame", 1, MAX_STEPS_PER_FRAME, 1, int(self.app.runner.steps_per_frame),
                hint="simulation steps between two pictures: faster, coarser animation",
            )
            self.precision = gui.add_dropdown(
                "Precision", list(PRECISIONS), initial_value=simulation.precision,
                hint="float32 runs about twice as fast and is less accurate (error floor near "
                "1e-7 of the motion); energies are always summed in float64",
            )
            self.threads = gui.add_slider(
                "Threads", 1, MAX_THREADS, 1, simulation.threads,
                hint="cores the compiled steps use (large lattices; results equal one thread's "
                "to round-off)", disabled=MAX_THREADS == 1,
            )
            self.integrator_message = gui.add_html("")

        @self.integrator.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                name = choice(self.integrator.value, "integrator",
                              sim.integrators.names(self.app.runner.simulation.model))
            except InputRefused as error:
                self._say(self.integrator_message, error)
                self.integrator.value = self.app.runner.simulation.integrator
                return
            self._say(self.integrator_message, None)
            self.control.set_integrator(name)
            self._stability_key = None

        @self.dt.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                value = number(self.dt.value, "dt (s)", 0.0, MAX_DT, low_open=True)
            except InputRefused as error:
                self._say(self.integrator_message, error)
                self.dt.value = self.app.runner.simulation.dt
                return
            self._say(self.integrator_message, None)
            self.control.set_dt(value)
            self._stability_key = None

        @self.precision.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                value = choice(self.precision.value, "precision", list(PRECISIONS))
            except InputRefused as error:
                self._say(self.integrator_message, error)
                self.precision.value = self.app.runner.simulation.precision
                return
            self._say(self.integrator_message, None)
            self.control.set_precision(value)

        @self.threads.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                value = whole_number(self.threads.value, "threads", 1, MAX_THREADS)
            except InputRefused as error:
                self._say(self.integrator_message, error)
                self.threads.value = self.app.runner.simulation.threads
                return
            self._say(self.integrator_message, None)
            self.control.set_threads(value)

        @self.steps_per_frame.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                steps = whole_number(self.steps_per_frame.value, "steps per frame", 1,
                                     MAX_STEPS_PER_FRAME)
            except InputRefused as error:
                self._say(self.integrator_message, error)
                self.steps_per_frame.value = int(self.app.runner.steps_per_frame)
                return
            self._say(self.integrator_message, None)
            self.control.set_steps_per_frame(steps)

    def _build_physics_folder(self, model: sim.Model) -> None:
        gui = self.gui
        with gui.add_folder("Physics"):
            self.stiffness = gui.add_slider(
                "Stiffness k (N/m)", 1.0, MAX_STIFFNESS, 1.0, 35.0,
                hint="35 N/m is the paper's 35 % of maximum",
            )
            self.rest_ratio = gui.add_slider(
                "Rest length L/a", 0.5, 1.2, 0.01, 1.0,
                hint="below 1 the springs are pre-tensioned (transverse waves spread)",
            )
            self.damping_on = gui.add_checkbox("Damping", False)
            self.damping = gui.add_slider("Dashpot c (N s/m)", 0.0, 10.0, 0.1, 0.5)
            self.gravity_on = gui.add_checkbox("Gravity", False)
            self.gravity = gui.add_slider("g (m/s²)", 0.0, 30.0, 0.01, 9.81)
            self.linear = gui.add_checkbox("Linearised springs", False,
                                           hint="springs linearised about the rest lattice")
            self.mass_pattern = gui.add_dropdown(
                "Mass pattern", [*MASS_PATTERNS, AS_LOADED], initial_value="uniform",
                hint="uniform: 1 kg everywhere; ionic: heavy/light checkerboard; "
                "as loaded: the scene's own masses (shown, not chosen)",
            )
            self.heavy_mass = gui.add_slider("Heavy mass (kg)", 0.1, 20.0, 0.1, 4.0)
            self.physics_message = gui.add_html("")
        # The server's own limits; show_scene widens them to show a scene's larger values.
        self._limits: dict[str, tuple[float, float]] = {
            "stiffness": (1.0, MAX_STIFFNESS), "rest_ratio": (0.5, 1.2), "damping": (0.0, 10.0),
            "gravity": (0.0, 30.0), "heavy_mass": (0.1, 20.0), "selection_mass": (0.1, 20.0),
        }

        def report(future: Any) -> None:
            error = future.exception()
            self._say(self.physics_message, error)

        def checked(key: str, handle: Any, label: str) -> float:
            low, high = self._limits[key]
            return number(handle.value, label, low, high, low_open=key in ("stiffness",
                                                                           "heavy_mass"))

        def physics_callback(post: Callable[[], Any]) -> Callable[[viser.GuiEvent], Any]:
            @from_user
            async def callback(_: viser.GuiEvent) -> None:
                try:
                    future = post()
                except InputRefused as error:
                    self._say(self.physics_message, error)
                    return
                future.add_done_callback(report)
                self._stability_key = None

            return callback

        self.stiffness.on_update(physics_callback(lambda: self.control.set_stiffness(
            checked("stiffness", self.stiffness, "stiffness (N/m)"))))
        self.rest_ratio.on_update(physics_callback(lambda: self.control.set_rest_length_ratio(
            checked("rest_ratio", self.rest_ratio, "L/a"))))
        damping = physics_callback(lambda: self.control.set_damping(
            bool(self.damping_on.value), checked("damping", self.damping, "dashpot c (N s/m)")))
        self.damping_on.on_update(damping)
        self.damping.on_update(damping)
        gravity = physics_callback(lambda: self.control.set_gravity(
            bool(self.gravity_on.value), checked("gravity", self.gravity, "g (m/s²)")))
        self.gravity_on.on_update(gravity)
        self.gravity.on_update(gravity)
        self.linear.on_update(physics_callback(
            lambda: self.control.set_linear(bool(self.linear.value))))

        def masses() -> Any:
            pattern = choice(self.mass_pattern.value, "mass pattern", [*MASS_PATTERNS, AS_LOADED])
            heavy = checked("heavy_mass", self.heavy_mass, "heavy mass (kg)")
            if pattern == AS_LOADED:  # nothing to choose: the scene keeps its masses
                return self.app.runner.post(lambda simulation: None)
            return self.control.set_mass_pattern(pattern, heavy=heavy, light=1.0)

        self.mass_pattern.on_update(physics_callback(masses))
        self.heavy_mass.on_update(physics_callback(masses))

    def _build_selection_folder(self) -> None:
        gui = self.gui
        with gui.add_folder("Selection"):
            self.selection_text = gui.add_html(as_html(
                "Click a particle to select it (shift+click adds); drag the gizmo to move it."
            ))
            self.row = gui.add_number("Row", 0, min=0, step=1)
            self.column = gui.add_number("Column", 0, min=0, step=1)
            self.select_buttons = gui.add_button_group("Select", ("particle", "row", "column",
                                                                  "none"))
            self.selection_mass = gui.add_slider("Mass (kg)", 0.1, 20.0, 0.1, 1.0,
                                                 disabled=True,
                                                 hint="mass of the selected particles")
            self.hold = gui.add_checkbox("Hold while dragging", True,
                                         hint="pin the selection to the gizmo during a drag")
            self.selection_message = gui.add_html("")

        @self.select_buttons.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            model = self.app.runner.simulation.model
            try:
                what = choice(self.select_buttons.value, "selection",
                              ["particle", "row", "column", "none"])
                row = whole_number(self.row.value, "row", 0, model.ny - 1)
                column = whole_number(self.column.value, "column", 0, model.nx - 1)
            except InputRefused as error:
                self._say(self.selection_message, error)
                return
            self._say(self.selection_message, None)
            if what == "particle":
                chosen = np.array([row * model.nx + column])
            elif what == "row":
                chosen = row * model.nx + np.arange(model.nx)
            elif what == "column":
                chosen = np.arange(model.ny) * model.nx + column
            else:
                chosen = np.zeros(0, dtype=np.int64)
            self.app.set_selection(chosen)

        @self.selection_mass.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            selection = self.app.view.selection
            if not selection.size:
                return
            low, high = self._limits["selection_mass"]
            try:
                mass = number(self.selection_mass.value, "mass (kg)", low, high)
            except InputRefused as error:
                self._say(self.selection_message, error)
                return
            self._say(self.selection_message, None)
            self.control.set_particle_masses(selection, mass)

        @self.hold.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            self.app.hold_while_dragging = self.hold.value is True

    def _build_view_folder(self) -> None:
        gui = self.gui
        settings = self.app.view.settings
        model = self.app.runner.simulation.model
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
            self.view_message = gui.add_html("")

        @self.show_springs.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            settings.show_springs = self.show_springs.value is True
            self.app.refresh()

        @self.move_points.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            settings.move_points = self.move_points.value is True
            self.app.refresh()

        @self.color_by.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                settings.color_by = choice(self.color_by.value, "colour", list(COLOR_MODES))
            except InputRefused as error:
                self._say(self.view_message, error)
                return
            self._say(self.view_message, None)
            self.app.refresh()

        @self.particle_scale.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            try:
                settings.particle_scale = number(self.particle_scale.value, "particle size",
                                                 0.2, 3.0)
            except InputRefused as error:
                self._say(self.view_message, error)
                return
            self._say(self.view_message, None)
            self.app.refresh()

    def _build_recording_folder(self) -> None:
        gui = self.gui
        recordings = self.app.recordings
        available = recordings.available()
        with gui.add_folder("Recording", expand_by_default=False):
            self.record_button = gui.add_button(
                "Start recording", icon=viser.Icon.PLAYER_RECORD, disabled=not available,
                hint=(f"record the run to {recordings.directory.name}/ on the server (rerun .rrd)"
                      if available else "the recorder (app.recording) is not installed"),
            )
            self.record_text = gui.add_html("")
            self.movie_button = gui.add_button(
                "Download a movie", icon=viser.Icon.MOVIE,
                hint="render the scene's run from the current state (its duration) to an MP4 "
                "on your computer: title, time, colour bar; plays in browsers and slides")
            self.movie_text = gui.add_html("")

        @self.movie_button.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:  # thread pool: rendering takes seconds
            if self.movie_button.disabled:
                return
            self.movie_button.disabled = True
            try:
                from app.movie import movie_bytes

                self.movie_text.content = as_html("rendering the movie… (about a second per "
                                                  "100 frames on large lattices)")
                scene = self.control.snapshot().result(timeout=30)
                content = movie_bytes(scene, "mp4", progress=False)
                name = _file_name(scene.name) + ".mp4"
                event.client.send_file_download(name, content, save_immediately=True)
                self.movie_text.content = ok_html(f"sent {name} ({len(content) / 1e6:.2g} MB)")
            except Exception as error:  # a failed movie must not take the page down
                self._say(self.movie_text, error, "could not make the movie")
            finally:
                self.movie_button.disabled = False

        @self.record_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # thread pool: starting takes a snapshot
            if self.record_button.disabled:
                return
            self.record_button.disabled = True
            try:
                if recordings.active:
                    path = recordings.stop()
                    self._show_recording_stopped(path)
                else:
                    self.record_text.content = as_html("starting…")
                    scene = self.control.snapshot().result(timeout=30)
                    path = recordings.start(scene)
                    self._recording_failure_shown = None
                    self.record_button.label = "Stop recording"
                    self.record_button.icon = viser.Icon.PLAYER_STOP
                    self.record_text.content = as_html(f"recording to {path.name}…")
            except Exception as error:  # a failed recording must not take the page down
                self._say(self.record_text, error, "could not record")
            finally:
                self.record_button.disabled = False

    def _show_recording_stopped(self, path: Path | None) -> None:
        self.record_button.label = "Start recording"
        self.record_button.icon = viser.Icon.PLAYER_RECORD
        error = self.app.recordings.last_error
        if error:
            self._say(self.record_text, error, f"recording stopped ({path.name if path else ''})")
        else:
            self.record_text.content = ok_html(f"saved {path.name}" if path else "stopped")

    def _build_study_folder(self) -> None:
        """Speed against accuracy on the scene as it is now: the work-precision picture and the
        recommendation of ``oscillators accuracy``, measured in a background thread."""
        gui = self.gui
        with gui.add_folder("Speed vs accuracy", expand_by_default=False):
            self.study_tolerance = gui.add_number(
                "Target error", initial_value=1e-3, min=1e-10, max=0.5, step=1e-4,
                hint="relative position error at the end of the run that the recommendation must meet",
            )
            self.study_button = gui.add_button(
                "Measure on this scene", icon=viser.Icon.CHART_LINE,
                hint="time every integrator at several dt against a reference solution "
                "(the same study as `oscillators accuracy`)",
            )
            self.study_text = gui.add_html("")
            self.study_image = gui.add_image(np.full((8, 8, 3), 255, np.uint8), visible=False)
            self.study_full_size = gui.add_button(
                "Open the picture full size", icon=viser.Icon.ARROWS_MAXIMIZE, visible=False)
            self.study_apply = gui.add_button(
                "Apply the recommendation", icon=viser.Icon.CHECK, visible=False,
                hint="switch to the recommended integrator and dt")
        self._study_picture: np.ndarray | None = None
        self._recommendation: tuple[str, float] | None = None

        @self.study_full_size.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            picture = self._study_picture
            if picture is None or event.client is None:
                return
            with event.client.gui.add_modal("Speed against accuracy on this scene") as modal:
                event.client.gui.add_image(picture, label="error against wall time")
                event.client.gui.add_button("Close").on_click(lambda _: modal.close())

        @self.study_apply.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            if self._recommendation is None:
                return
            integrator, dt = self._recommendation
            try:
                self.control.set_integrator(integrator).result(timeout=30)
                self.control.set_dt(dt).result(timeout=30)
            except ERROR_TYPES as error:
                self._say(self.study_text, error, "could not apply")
                return
            self.study_text.content = ok_html(f"now running {integrator} at dt = {dt:.4g} s")

        @self.study_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # runs in viser's thread pool: it may take a while
            if self.study_button.disabled:
                return
            try:
                tolerance = number(self.study_tolerance.value, "target error", 1e-10, 0.5)
            except InputRefused as error:
                self._say(self.study_text, error)
                return
            self.study_button.disabled = True
            try:
                self._run_study(tolerance)
            except Exception as error:  # a failed study must not take the page down
                self._say(self.study_text, error, "could not measure")
            finally:
                self.study_button.disabled = False

    def _run_study(self, tolerance: float) -> None:
        import tempfile

        import imageio.v3 as imageio

        from app.study.accuracy import accuracy_study
        from app.study.accuracy_report import plot_work_precision

        scene = self.app.runner.post(sim.scenes.scene_from_simulation).result(timeout=30)
        if scene.model.n_particles > STUDY_PARTICLE_LIMIT:
            self.study_text.content = as_html(
                f"This lattice has {scene.model.n_particles:,} particles; the page measures up to "
                f"{STUDY_PARTICLE_LIMIT:,}. Run `oscillators accuracy` with this scene's file "
                "(Scene → Files → Download this scene) from the command line instead."
            )
            return
        total = [0]

        def progress(label: str) -> None:
            total[0] += 1
            self.study_text.content = as_html(f"measuring… run {total[0]}: {label}")

        study = accuracy_study(scene, tolerance=tolerance, progress=progress,
                               precisions=tuple(dict.fromkeys(("float64", scene.precision))))
        with tempfile.TemporaryDirectory() as folder:
            picture = Path(folder) / "work_precision.png"
            with MATPLOTLIB_LOCK:  # the Modes folder draws in another thread
                plot_work_precision(study, str(picture))
            image = imageio.imread(picture)
        self._study_picture = np.ascontiguousarray(image[..., :3])
        self.study_image.image = self._study_picture
        self.study_image.visible = True
        self.study_full_size.visible = True
        recommendation = study.recommendation
        if recommendation.integrator is not None and recommendation.dt is not None:
            self._recommendation = (recommendation.integrator, float(recommendation.dt))
            self.study_apply.visible = True
        else:
            self._recommendation = None
            self.study_apply.visible = False
        self.study_text.content = as_html(
            f"Recommendation: {recommendation.reason}. Wall times are of one whole run of each "
            f"configuration from the scene's state to T = {study.until:.4g} s of simulated time "
            "(compilation excluded).", bold=True)

    def _build_energy_plot(self) -> None:
        self.energy_folder = self.gui.add_folder("Energy")
        self.plot: Any = None
        self._make_energy_plot(with_driver=False)

    def _make_energy_plot(self, with_driver: bool) -> None:
        """(Re)build the energy plot: kinetic, potential, total, dissipated, and the driver's work
        when the scene has (or had) a driver (a uPlot's series are fixed when it is made)."""
        if self.plot is not None:
            self.plot.remove()
        series = [
            {"label": "t (s)"},
            {"label": "kinetic", "stroke": "#1f77b4", "width": 1.5},
            {"label": "potential", "stroke": "#ff7f0e", "width": 1.5},
            {"label": "total", "stroke": "#222222", "width": 2},
            {"label": "dissipated", "stroke": "#9467bd", "width": 1.5},
        ]
        if with_driver:
            series.append({"label": "driver's work", "stroke": "#2ca02c", "width": 1.5})
        empty = np.zeros(1)
        with self.energy_folder:
            self.plot = self.gui.add_uplot(
                data=(empty,) * len(series), series=tuple(series),
                scales={"x": {"time": False}}, aspect=1.6,
            )
        self._plot_shows_driver = with_driver

    # --- keeping in step -------------------------------------------------------------------------

    def _show_playing(self) -> None:
        playing = self.app.runner.playing
        self.play_button.label = "Pause" if playing else "Play"
        self.play_button.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY

    def _clear_history(self) -> None:
        self._times.clear()
        self._energies.clear()

    def _show_number(self, handle: Any, key: str | None, value: float) -> None:
        """Show ``value`` in a slider, widening its range (and the server's limit ``key``) if the
        scene's value lies outside it: shown as it is, never rounded or clamped."""
        if key is not None:
            low, high = self._limits[key]
            self._limits[key] = (min(low, value), max(high, value))
        if value > handle.max:
            handle.max = value
        if value < handle.min:
            handle.min = value
        handle.value = value

    def show_scene(self, simulation: sim.Simulation) -> None:
        """Show a (new) simulation's scene and parameters.  Assigning widget values here posts
        no command (``from_user``), so the scene runs exactly as it was built or loaded."""
        model = simulation.model
        scene = simulation.scene
        self._clear_history()
        self.accuracy.clear()
        self.spectrum.show_scene(simulation)
        self.probes.show_scene(simulation)
        self._stability_key = None
        self.integrator.options = sim.integrators.names(model)
        if scene.name in sim.scenes.names():
            self.preset.value = scene.name
        self.nx.value, self.ny.value = model.nx, model.ny
        self._show_scene_info(simulation)
        self._show_boundary(model)
        self.drive.show_scene(simulation)
        self.integrator.value = simulation.integrator
        self.dt.value = simulation.dt
        self.precision.value = simulation.precision
        self.threads.value = simulation.threads
        self._show_number(self.stiffness, "stiffness", float(model.stiffness))
        self._show_number(self.rest_ratio, "rest_ratio", float(model.rest_length / model.spacing))
        self.damping_on.value = model.damping > 0
        if model.damping > 0:
            self._show_number(self.damping, "damping", float(model.damping))
        self.gravity_on.value = model.has_gravity
        if model.has_gravity:
            self._show_number(self.gravity, "gravity", float(np.linalg.norm(model.gravity)))
        self.linear.value = model.linear
        pattern = mass_pattern_of(model)
        self.mass_pattern.value = pattern
        if pattern == "ionic":
            masses = np.asarray(model.masses).reshape(-1)
            self._show_number(self.heavy_mass, "heavy_mass", float(masses[0]))
        self.steps_per_frame.value = int(self.app.runner.steps_per_frame)
        self.show_springs.disabled = model.n_springs > SPRING_HARD_LIMIT
        settings = self.app.view.settings
        settings.show_springs = settings.move_points = settings.color_by = None
        self.show_springs.value = settings.springs_on(model)
        self.move_points.value = settings.points_move(model)
        self.color_by.value = settings.coloring(model)
        self._say(self.physics_message, None)

    def _show_scene_info(self, simulation: sim.Simulation) -> None:
        model, scene = simulation.model, simulation.scene
        self.scene_info.content = as_html(
            f"{scene.name} ({self.app.scene_source}): {model.nx}x{model.ny}, "
            f"{model.n_particles:,} particles\n{model.describe()}\n"
            f"{scene.description}".rstrip()
        )

    @staticmethod
    def _walls(model: sim.Model) -> list[str]:
        return [*WALLS, model.boundary] if model.boundary not in WALLS else list(WALLS)

    def _show_boundary(self, model: sim.Model) -> None:
        """Show the running walls (assigning the values posts nothing)."""
        self.boundary.options = self._walls(model)
        self.boundary.value = model.boundary
        self.sponge_width.value = model.sponge_width

    def selection_changed(self, selection: np.ndarray) -> None:
        model = self.app.runner.simulation.model
        self.drive.selection_changed(selection, model)
        self.selection_mass.disabled = selection.size == 0
        if selection.size == 0:
            self.selection_text.content = as_html(
                "Nothing selected: click a particle (shift+click adds).")
            return
        first = int(selection[0])
        row, column = divmod(first, model.nx)
        masses = model.masses.reshape(-1)[selection]
        where = (f"particle {first} (row {row}, column {column})" if selection.size == 1
                 else f"{selection.size} particles")
        self.selection_text.content = as_html(f"Selected {where}, mass {masses.mean():.3g} kg")
        self._show_number(self.selection_mass, "selection_mass", float(masses.mean()))

    def update(self, frame: Frame) -> None:
        """Refresh the status, the stability note and (a few times a second) the energy plot."""
        now = time.perf_counter()
        if self._times and frame.time < self._times[-1]:
            self._clear_history()
        energy = frame.energy
        if not self._times or frame.time > self._times[-1]:
            self._times.append(frame.time)
            self._energies.append((energy.kinetic, energy.potential, energy.total,
                                   energy.dissipated, energy.driven))
        with_driver = frame.model.driver is not None or energy.driven != 0.0
        if with_driver != self._plot_shows_driver:
            self._make_energy_plot(with_driver)
        self._update_stability(frame)
        self._update_error(frame)
        self._update_part_failures()
        self.accuracy.update(frame, now)
        self.spectrum.update(frame, now)
        self.probes.update(frame, now)
        self.drive.update(frame, now)
        if now - self._last_status > 0.5:
            started, steps = self._status_steps
            taken = self.app.runner.steps_taken
            if now > started:
                self._steps_per_second = (taken - steps) / (now - started)
            self._status_steps = (now, taken)
            self._last_status = now
            self._show_playing()
            self.status.content = as_html(
                f"t = {frame.time:.3f} s, step {frame.step}, "
                f"{'running' if frame.playing else 'paused'}, "
                f"{self._steps_per_second:.0f} steps/s\n{frame.model.describe()}"
            )
        if now - self._last_plot > PLOT_INTERVAL and len(self._times) > 1:
            self._last_plot = now
            columns = np.array(self._energies).T
            shown = columns if self._plot_shows_driver else columns[:4]
            self.plot.data = (np.array(self._times), *shown)

    def _update_part_failures(self) -> None:
        """Say in the page when a subscriber (a recorder, a plot) failed and was detached."""
        errors = self.app.runner.subscriber_errors
        failure = self.app.recordings.failure()
        if failure and failure != self._recording_failure_shown:
            self._recording_failure_shown = failure
            path = self.app.recordings.stop()
            self._show_recording_stopped(path)
            self._say(self.record_text, failure, f"recording stopped ({path.name if path else ''})")
        if self.app.runner.frames_published and len(errors) and (
            len(errors) != self._subscriber_errors_seen
        ):
            self._subscriber_errors_seen = len(errors)
            self.part_html.content = amber_html(
                f"A part of the app stopped (the simulation goes on): {errors[-1]}")
            self.part_html.visible = True

    def _update_stability(self, frame: Frame) -> None:
        key = (id(frame.model), frame.integrator)
        if key != self._stability_key:
            self._stability_key = key
            applicable = sim.integrators.names(frame.model)
            if tuple(self.integrator.options) != tuple(applicable):
                self.integrator.options = applicable  # e.g. exact once springs are linearised
            if self.integrator.value != frame.integrator:
                self.integrator.value = frame.integrator  # shows what runs (posts nothing)
            future = self.app.runner.post(lambda simulation: simulation.stability())

            def done(result: Any) -> None:
                if result.exception() is None:
                    limit = result.result()
                    self._stable_dt = limit.dt
                    self._stability_text = limit.reason

            future.add_done_callback(done)
        stable = self._stable_dt
        if stable is None:
            text = warning_html(f"no stable dt for {frame.integrator} here (add damping or change "
                                "integrator)") if self._stability_text else ""
        elif math.isinf(stable):
            text = ok_html("stable for any dt")
        elif frame.dt > stable:
            text = warning_html(f"dt = {frame.dt:.4g} s exceeds the stability limit "
                                f"{stable:.4g} s: the run will blow up")
        else:
            text = ok_html(f"stable for dt ≤ {stable:.4g} s ({frame.dt / stable:.0%} of the limit)")
        if self.stability_html.content != text:
            self.stability_html.content = text

    def _update_error(self, frame: Frame) -> None:
        error = frame.error or (self.app.runner.error if not self.app.runner.playing else None)
        if error == self._error_shown:
            return
        self._error_shown = error
        if error:
            self.error_html.content = warning_html(f"Stopped: {error}")
            self.error_html.visible = True
            self._show_playing()
        else:
            self.error_html.visible = False
