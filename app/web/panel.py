"""The GUI panel of the web app: folders of controls, the status line and the energy plot.

Callbacks only post commands through ``SimulationControl`` (or change view settings); they never
touch the simulation's arrays.  Callbacks that depend on ordering are ``async`` so viser runs them
on its event loop in arrival order; ones that build a new lattice run in viser's thread pool.
``update(frame)`` is called by the app's frame pump for every frame drawn.
"""

from __future__ import annotations

import collections
import importlib
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import viser

import sim
from app.web.control import MASS_PATTERNS
from app.web.view import COLOR_MODES, SPRING_HARD_LIMIT
from sim.runner import Frame

if TYPE_CHECKING:
    from app.web.app import WebApp

MAX_STIFFNESS = 100.0
"""The stiffness slider's maximum (N/m); the paper's default 35 N/m is 35 % of it."""
ENERGY_HISTORY = 600
"""Points kept in the energy plot."""
PLOT_INTERVAL = 0.25
"""Seconds between energy plot updates."""
SCENE_DIRECTORY = Path("scenes")
RECORDING_DIRECTORY = Path("recordings")
STUDY_PARTICLE_LIMIT = 2_500
"""Largest lattice the page measures speed against accuracy on (bigger: use the CLI)."""


def _ok(text: str) -> str:
    return f'<div style="font-size:0.85em;color:#2b7a2b;padding:0 0.6em">{text}</div>'


def _warn(text: str) -> str:
    style = "font-size:0.85em;color:#c0392b;font-weight:600;padding:0 0.6em"
    return f'<div style="{style}">{text}</div>'


class ControlPanel:
    """Builds the GUI for ``app`` and keeps it in step with the frames."""

    def __init__(self, app: WebApp) -> None:
        self.app = app
        self.control = app.control
        self.gui = app.server.gui
        simulation = app.runner.simulation
        model = simulation.model
        self._times: collections.deque[float] = collections.deque(maxlen=ENERGY_HISTORY)
        self._energies: collections.deque[tuple[float, float, float, float]] = (
            collections.deque(maxlen=ENERGY_HISTORY)
        )
        self._last_plot = 0.0
        self._last_status = 0.0
        self._status_steps = (time.perf_counter(), 0)
        self._steps_per_second = 0.0
        self._stability_key: tuple | None = None
        self._stable_dt: float | None = None
        self._stability_text = ""
        self._error_shown: str | None = None
        self.recorder: Any = None

        self._build_run_folder()
        self._build_scene_folder(simulation)
        self._build_integrator_folder(simulation)
        self._build_physics_folder(model)
        self._build_selection_folder()
        self._build_view_folder()
        self._build_recording_folder()
        self._build_study_folder()
        self._build_energy_plot()

    # --- folders ---------------------------------------------------------------------------------

    def _build_run_folder(self) -> None:
        gui = self.gui
        with gui.add_folder("Run"):
            self.play_button = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY,
                                              hint="start or pause the simulation")
            self.step_button = gui.add_button("Single step", icon=viser.Icon.PLAYER_TRACK_NEXT)
            self.reset_button = gui.add_button("Reset", icon=viser.Icon.REFRESH,
                                               hint="back to the scene's initial state")
            self.status = gui.add_markdown("")
            self.error_html = gui.add_html("", visible=False)

        @self.play_button.on_click
        async def _(_: viser.GuiEvent) -> None:
            if self.app.runner.playing:
                self.control.pause()
            else:
                self.control.play()
            self._show_playing()

        @self.step_button.on_click
        async def _(_: viser.GuiEvent) -> None:
            self.control.single_step()
            self._show_playing()

        @self.reset_button.on_click
        async def _(_: viser.GuiEvent) -> None:
            self.control.reset()
            self._clear_history()

    def _build_scene_folder(self, simulation: sim.Simulation) -> None:
        gui = self.gui
        names = sim.scenes.names()
        current = simulation.scene.name if simulation.scene.name in names else "grid"
        with gui.add_folder("Scene", expand_by_default=False):
            self.preset = gui.add_dropdown("Preset", names, initial_value=current)
            self.nx = gui.add_number("Columns (nx)", simulation.model.nx, min=1, max=2000, step=1)
            self.ny = gui.add_number("Rows (ny)", simulation.model.ny, min=1, max=2000, step=1)
            self.build_button = gui.add_button("Build scene", icon=viser.Icon.HAMMER,
                                               hint="replace the lattice by this preset and size")
            self.scene_path = gui.add_text(
                "File", str(SCENE_DIRECTORY / f"{simulation.scene.name}.toml")
            )
            with gui.add_folder("Save / load"):
                self.save_button = gui.add_button("Save", icon=viser.Icon.DEVICE_FLOPPY,
                                                  hint="save the current state as a scene file")
                self.load_button = gui.add_button("Load", icon=viser.Icon.FOLDER_OPEN)
            self.scene_message = gui.add_markdown("")

        @self.preset.on_update
        def _(_: viser.GuiEvent) -> None:
            model = sim.scenes.build(self.preset.value).model
            self.nx.value, self.ny.value = model.nx, model.ny

        @self.build_button.on_click
        def _(_: viser.GuiEvent) -> None:
            try:
                future = self.control.build_preset(
                    self.preset.value, nx=int(self.nx.value), ny=int(self.ny.value)
                )
                future.result(timeout=30)
            except Exception as error:
                self.scene_message.content = f"**could not build:** {error}"
                return
            size = f"{int(self.nx.value)}x{int(self.ny.value)}"
            self.scene_message.content = f"built {self.preset.value} {size}"
            self._after_new_scene()

        @self.save_button.on_click
        def _(_: viser.GuiEvent) -> None:
            path = Path(self.scene_path.value)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                saved = self.control.save(path).result(timeout=30)
            except Exception as error:
                self.scene_message.content = f"**could not save:** {error}"
                return
            self.scene_message.content = f"saved `{saved}`"

        @self.load_button.on_click
        def _(_: viser.GuiEvent) -> None:
            try:
                self.control.load(self.scene_path.value).result(timeout=30)
            except Exception as error:
                self.scene_message.content = f"**could not load:** {error}"
                return
            self.scene_message.content = f"loaded `{self.scene_path.value}`"
            self._after_new_scene()

    def _build_integrator_folder(self, simulation: sim.Simulation) -> None:
        gui = self.gui
        with gui.add_folder("Integrator"):
            self.integrator = gui.add_dropdown(
                "Method", list(sim.INTEGRATORS), initial_value=simulation.integrator,
                hint="euler (1st order), heun (2nd), verlet (symplectic 2nd), rk4 (4th)",
            )
            self.dt = gui.add_number("Time step dt (s)", simulation.dt, min=1e-5, max=1.0,
                                     step=1e-4)
            self.stability_html = gui.add_html("")
            self.steps_per_frame = gui.add_slider(
                "Steps per frame", 1, 50, 1, int(self.app.runner.steps_per_frame),
                hint="simulation steps between two pictures: faster, coarser animation",
            )

        @self.integrator.on_update
        async def _(_: viser.GuiEvent) -> None:
            self.control.set_integrator(self.integrator.value)
            self._stability_key = None

        @self.dt.on_update
        async def _(_: viser.GuiEvent) -> None:
            value = float(self.dt.value)
            if value > 0 and math.isfinite(value):
                self.control.set_dt(value)
                self._stability_key = None

        @self.steps_per_frame.on_update
        async def _(_: viser.GuiEvent) -> None:
            self.control.set_steps_per_frame(int(self.steps_per_frame.value))

    def _build_physics_folder(self, model: sim.Model) -> None:
        gui = self.gui
        with gui.add_folder("Physics"):
            self.stiffness = gui.add_slider(
                "Stiffness k (N/m)", 1.0, MAX_STIFFNESS, 1.0, float(round(model.stiffness)),
                hint="35 N/m is the paper's 35 % of maximum",
            )
            self.rest_ratio = gui.add_slider(
                "Rest length L/a", 0.5, 1.2, 0.01, round(model.rest_length / model.spacing, 2),
                hint="below 1 the springs are pre-tensioned (transverse waves spread)",
            )
            self.damping_on = gui.add_checkbox("Damping", model.damping > 0)
            self.damping = gui.add_slider("Dashpot c (N s/m)", 0.0, 10.0, 0.1,
                                          float(model.damping) or 0.5)
            gravity = float(-model.gravity[1])
            self.gravity_on = gui.add_checkbox("Gravity", model.has_gravity)
            self.gravity = gui.add_slider("g (m/s²)", 0.0, 30.0, 0.01, gravity or 9.81)
            self.linear = gui.add_checkbox("Linearised springs", model.linear,
                                           hint="springs linearised about the rest lattice")
            self.mass_pattern = gui.add_dropdown(
                "Mass pattern", list(MASS_PATTERNS),
                initial_value="uniform" if model.uniform_mass else "ionic",
            )
            self.heavy_mass = gui.add_slider("Heavy mass (kg)", 0.1, 20.0, 0.1, 4.0)
            self.physics_message = gui.add_markdown("")

        def report(future: Any) -> None:
            error = future.exception()
            self.physics_message.content = f"**rejected:** {error}" if error else ""

        @self.stiffness.on_update
        async def _(_: viser.GuiEvent) -> None:
            self.control.set_stiffness(self.stiffness.value).add_done_callback(report)
            self._stability_key = None

        @self.rest_ratio.on_update
        async def _(_: viser.GuiEvent) -> None:
            self.control.set_rest_length_ratio(self.rest_ratio.value).add_done_callback(report)
            self._stability_key = None

        async def damping_changed(_: viser.GuiEvent) -> None:
            self.control.set_damping(self.damping_on.value, self.damping.value).add_done_callback(
                report
            )
            self._stability_key = None

        self.damping_on.on_update(damping_changed)
        self.damping.on_update(damping_changed)

        async def gravity_changed(_: viser.GuiEvent) -> None:
            self.control.set_gravity(self.gravity_on.value, self.gravity.value).add_done_callback(
                report
            )

        self.gravity_on.on_update(gravity_changed)
        self.gravity.on_update(gravity_changed)

        @self.linear.on_update
        async def _(_: viser.GuiEvent) -> None:
            self.control.set_linear(self.linear.value).add_done_callback(report)
            self._stability_key = None

        async def masses_changed(_: viser.GuiEvent) -> None:
            self.control.set_mass_pattern(
                self.mass_pattern.value, heavy=self.heavy_mass.value, light=1.0
            ).add_done_callback(report)
            self._stability_key = None

        self.mass_pattern.on_update(masses_changed)
        self.heavy_mass.on_update(masses_changed)

    def _build_selection_folder(self) -> None:
        gui = self.gui
        with gui.add_folder("Selection"):
            self.selection_text = gui.add_markdown(
                "Click a particle to select it (shift+click adds); drag the gizmo to move it."
            )
            self.row = gui.add_number("Row", 0, min=0, step=1)
            self.column = gui.add_number("Column", 0, min=0, step=1)
            self.select_buttons = gui.add_button_group("Select", ("particle", "row", "column",
                                                                  "none"))
            self.selection_mass = gui.add_slider("Mass (kg)", 0.1, 20.0, 0.1, 1.0,
                                                 disabled=True,
                                                 hint="mass of the selected particles")
            self.hold = gui.add_checkbox("Hold while dragging", True,
                                         hint="pin the selection to the gizmo during a drag")

        @self.select_buttons.on_click
        async def _(_: viser.GuiEvent) -> None:
            model = self.app.runner.simulation.model
            row = min(max(int(self.row.value), 0), model.ny - 1)
            column = min(max(int(self.column.value), 0), model.nx - 1)
            choice = self.select_buttons.value
            if choice == "particle":
                chosen = np.array([row * model.nx + column])
            elif choice == "row":
                chosen = row * model.nx + np.arange(model.nx)
            elif choice == "column":
                chosen = np.arange(model.ny) * model.nx + column
            else:
                chosen = np.zeros(0, dtype=np.int64)
            self.app.set_selection(chosen)

        @self.selection_mass.on_update
        async def _(_: viser.GuiEvent) -> None:
            selection = self.app.view.selection
            if selection.size:
                self.control.set_particle_masses(selection, self.selection_mass.value)

        @self.hold.on_update
        async def _(_: viser.GuiEvent) -> None:
            self.app.hold_while_dragging = bool(self.hold.value)

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

        @self.show_springs.on_update
        async def _(_: viser.GuiEvent) -> None:
            settings.show_springs = bool(self.show_springs.value)
            self.app.refresh()

        @self.move_points.on_update
        async def _(_: viser.GuiEvent) -> None:
            settings.move_points = bool(self.move_points.value)
            self.app.refresh()

        @self.color_by.on_update
        async def _(_: viser.GuiEvent) -> None:
            settings.color_by = self.color_by.value
            self.app.refresh()

        @self.particle_scale.on_update
        async def _(_: viser.GuiEvent) -> None:
            settings.particle_scale = float(self.particle_scale.value)
            self.app.refresh()

    def _build_recording_folder(self) -> None:
        gui = self.gui
        recorder_factory = _find_recorder()
        with gui.add_folder("Recording", expand_by_default=False):
            self.record_button = gui.add_button(
                "Start recording", icon=viser.Icon.PLAYER_RECORD,
                disabled=recorder_factory is None,
                hint=(f"record the run to {RECORDING_DIRECTORY}/ (rerun .rrd)"
                      if recorder_factory else "the recorder (app.recording) is not installed yet"),
            )
            self.record_text = gui.add_markdown("")

        @self.record_button.on_click
        def _(_: viser.GuiEvent) -> None:
            if recorder_factory is None:
                return
            if self.recorder is None:
                try:
                    self.recorder = recorder_factory(self.app.runner, RECORDING_DIRECTORY)
                except Exception as error:
                    self.record_text.content = f"**could not record:** {error}"
                    return
                self.record_button.label = "Stop recording"
                self.record_text.content = "recording…"
            else:
                path = self.recorder.stop()
                self.recorder = None
                self.record_button.label = "Start recording"
                self.record_text.content = f"saved `{path}`" if path else "stopped"

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
            self.study_text = gui.add_markdown("")
            self.study_image = gui.add_image(np.full((8, 8, 3), 255, np.uint8), visible=False)

        @self.study_button.on_click
        def _(_: viser.GuiEvent) -> None:  # runs in viser's thread pool: it may take a while
            if self.study_button.disabled:
                return
            self.study_button.disabled = True
            try:
                self._run_study(float(self.study_tolerance.value))
            except Exception as error:  # a failed study must not take the page down
                self.study_text.content = f"**could not measure:** {error}"
            finally:
                self.study_button.disabled = False

    def _run_study(self, tolerance: float) -> None:
        import tempfile

        import imageio.v3 as imageio

        from app.study.accuracy import accuracy_study, plot_work_precision

        scene = self.app.runner.post(sim.scenes.scene_from_simulation).result(timeout=30)
        if scene.model.n_particles > STUDY_PARTICLE_LIMIT:
            self.study_text.content = (
                f"This lattice has {scene.model.n_particles:,} particles; the page measures up to "
                f"{STUDY_PARTICLE_LIMIT:,}. Run `oscillators accuracy` with this scene's file "
                "(Scene → Save) from the command line instead."
            )
            return
        total = [0]

        def progress(label: str) -> None:
            total[0] += 1
            self.study_text.content = f"measuring… run {total[0]}: {label}"

        study = accuracy_study(scene, tolerance=tolerance, progress=progress)
        with tempfile.TemporaryDirectory() as folder:
            picture = Path(folder) / "work_precision.png"
            plot_work_precision(study, str(picture))
            image = imageio.imread(picture)
        self.study_image.image = np.ascontiguousarray(image[..., :3])
        self.study_image.visible = True
        self.study_text.content = f"**Recommendation:** {study.recommendation.reason}"

    def _build_energy_plot(self) -> None:
        gui = self.gui
        with gui.add_folder("Energy"):
            empty = np.zeros(1)
            self.plot = gui.add_uplot(
                data=(empty, empty, empty, empty, empty),
                series=(
                    {"label": "t (s)"},
                    {"label": "kinetic", "stroke": "#1f77b4", "width": 1.5},
                    {"label": "potential", "stroke": "#ff7f0e", "width": 1.5},
                    {"label": "total", "stroke": "#222222", "width": 2},
                    {"label": "dissipated", "stroke": "#9467bd", "width": 1.5},
                ),
                scales={"x": {"time": False}},
                aspect=1.6,
            )

    # --- keeping in step -------------------------------------------------------------------------

    def _show_playing(self) -> None:
        playing = self.app.runner.playing
        self.play_button.label = "Pause" if playing else "Play"
        self.play_button.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY

    def _clear_history(self) -> None:
        self._times.clear()
        self._energies.clear()

    def _after_new_scene(self) -> None:
        simulation = self.app.runner.simulation
        model = simulation.model
        self._clear_history()
        self._stability_key = None
        self.integrator.value = simulation.integrator
        self.dt.value = simulation.dt
        self.stiffness.value = float(min(max(round(model.stiffness), 1.0), MAX_STIFFNESS))
        self.rest_ratio.value = float(min(max(round(model.rest_length / model.spacing, 2), 0.5),
                                          1.2))
        self.damping_on.value = model.damping > 0
        self.gravity_on.value = model.has_gravity
        self.linear.value = model.linear
        self.mass_pattern.value = "uniform" if model.uniform_mass else "ionic"
        self.scene_path.value = str(SCENE_DIRECTORY / f"{simulation.scene.name}.toml")
        self.show_springs.disabled = model.n_springs > SPRING_HARD_LIMIT
        settings = self.app.view.settings
        settings.show_springs = settings.move_points = settings.color_by = None
        self.show_springs.value = settings.springs_on(model)
        self.move_points.value = settings.points_move(model)
        self.color_by.value = settings.coloring(model)
        from app.web.app import runner_pacing

        steps, sim_fps, render_fps = runner_pacing(model)
        self.app.runner.steps_per_frame = steps
        self.app.runner.max_fps = sim_fps
        self.app.render_fps = render_fps
        self.steps_per_frame.value = steps
        self.app.refresh()

    def selection_changed(self, selection: np.ndarray) -> None:
        model = self.app.runner.simulation.model
        self.selection_mass.disabled = selection.size == 0
        if selection.size == 0:
            self.selection_text.content = "Nothing selected: click a particle (shift+click adds)."
            return
        first = int(selection[0])
        row, column = divmod(first, model.nx)
        masses = model.masses.reshape(-1)[selection]
        where = (f"particle {first} (row {row}, column {column})" if selection.size == 1
                 else f"{selection.size} particles")
        self.selection_text.content = f"Selected {where}, mass {masses.mean():.3g} kg"
        self.selection_mass.value = float(min(max(masses.mean(), 0.1), 20.0))

    def update(self, frame: Frame) -> None:
        """Refresh the status, the stability note and (a few times a second) the energy plot."""
        now = time.perf_counter()
        if self._times and frame.time < self._times[-1]:
            self._clear_history()
        energy = frame.energy
        if not self._times or frame.time > self._times[-1]:
            self._times.append(frame.time)
            self._energies.append((energy.kinetic, energy.potential, energy.total,
                                   energy.dissipated))
        self._update_stability(frame)
        self._update_error(frame)
        if now - self._last_status > 0.5:
            started, steps = self._status_steps
            taken = self.app.runner.steps_taken
            if now > started:
                self._steps_per_second = (taken - steps) / (now - started)
            self._status_steps = (now, taken)
            self._last_status = now
            self._show_playing()
            self.status.content = (
                f"t = {frame.time:.3f} s, step {frame.step}, "
                f"{'running' if frame.playing else 'paused'}, "
                f"{self._steps_per_second:.0f} steps/s  \n"
                f"{frame.model.describe()}"
            )
        if now - self._last_plot > PLOT_INTERVAL and len(self._times) > 1:
            self._last_plot = now
            columns = np.array(self._energies).T
            self.plot.data = (np.array(self._times), *columns)

    def _update_stability(self, frame: Frame) -> None:
        key = (id(frame.model), frame.integrator)
        if key != self._stability_key:
            self._stability_key = key
            future = self.app.runner.post(lambda simulation: simulation.stability())

            def done(result: Any) -> None:
                if result.exception() is None:
                    limit = result.result()
                    self._stable_dt = limit.dt
                    self._stability_text = limit.reason

            future.add_done_callback(done)
        stable = self._stable_dt
        if stable is None:
            text = _warn(f"no stable dt for {frame.integrator} here (add damping or change "
                         "integrator)") if self._stability_text else ""
        elif math.isinf(stable):
            text = _ok("stable for any dt")
        elif frame.dt > stable:
            text = _warn(f"dt = {frame.dt:.4g} s exceeds the stability limit "
                         f"{stable:.4g} s: the run will blow up")
        else:
            text = _ok(f"stable for dt ≤ {stable:.4g} s ({frame.dt / stable:.0%} of the limit)")
        if self.stability_html.content != text:
            self.stability_html.content = text

    def _update_error(self, frame: Frame) -> None:
        error = frame.error or (self.app.runner.error if not self.app.runner.playing else None)
        if error == self._error_shown:
            return
        self._error_shown = error
        if error:
            self.error_html.content = _warn(f"Stopped: {error}")
            self.error_html.visible = True
            self._show_playing()
        else:
            self.error_html.visible = False


def _find_recorder() -> Any:
    """A factory ``(runner, directory) -> recording`` if ``app.recording`` is installed, else None.

    The recording subscribes a ``app.recording.Recorder`` to the runner; ``stop()`` closes it and
    returns the ``.rrd`` path.
    """
    try:
        recording = importlib.import_module("app.recording")
    except ImportError:
        return None
    recorder_class = getattr(recording, "Recorder", None)
    if recorder_class is None:
        return None

    class WebRecording:
        def __init__(self, runner: Any, directory: Path) -> None:
            # the snapshot is taken by the simulation thread between steps, never mid-step
            scene = runner.post(sim.scenes.scene_from_simulation).result(timeout=30)
            directory.mkdir(parents=True, exist_ok=True)
            stamp = time.strftime("%Y%m%d-%H%M%S")
            self.recorder = recorder_class(
                directory / f"{scene.name}-{stamp}.rrd", scene,
                integrator=scene.integrator, dt=scene.dt,
            )
            self.recorder.attach(runner, snapshot=True)

        def stop(self) -> Path:
            return self.recorder.close()

    return WebRecording
