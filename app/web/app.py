"""``WebApp``: one viser server showing one shared, running lattice to every connected browser.

Threads:

* the runner thread (``LatticeRunner``) steps the simulation and publishes frames; the
  subscriber only keeps the latest frame (cheap), so the simulation never waits for the network;
* the frame pump thread draws the latest frame into the scene at no more than ``render_fps``
  (inside ``server.atomic()``), updates the panel and moves the drag gizmo;
* viser's event loop and thread pool run the GUI and scene callbacks, which only post commands;
* the client watch (``app.web.clients``) disconnects a page that stops reading.

Interaction: a click casts the pointer ray onto the lattice plane z = 0 and selects the nearest
particle (shift+click adds to the selection; clicks outside the lattice are ignored).  A
transform gizmo sits on the selection; dragging it moves the selection (held in place while
dragging if "hold while dragging" is on) and releasing lets go.  A client that disconnects
mid-drag is released.

The app owns the scene, the runner and its pacing: ``replace_scene`` swaps a new lattice in and
then asks the panel to show it.  The panel (``app.web.panel``) only shows the app's state and
turns what a user does into commands; it does not import this module.  Every request to the
server passes ``app.web.security``'s Host/Origin check; the page reaches scene files only by name
in one directory (``app.web.scene_files``) and records only into one directory
(``app.web.recording``).
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import viser

import sim
from app import memory
from app.web import viser_adapter
from app.web.clients import ClientWatch
from app.web.control import LatticeRunner, SimulationControl
from app.web.page_views import PageViews
from app.web.panel import ControlPanel
from app.web.recording import WebRecordings
from app.web.roles import ClassRoles
from app.web.scene_files import SceneDirectory
from app.web.security import AccessPolicy, PageGate, checked_server
from app.web.view import NARROW, PHONE_PANEL_SHARE, VIEW_FOV, LatticeView, camera_fit, laptop_fit
from sim.runtime.runner import Frame
from sim.runtime.warming import KernelPreparer

STUDENT_TYPES = viser_adapter.STUDENT_MESSAGE_NAMES
DEFAULT_SCENES_DIR = Path("scenes")
"""Where ``serve`` looks for scene files the page may open (by name)."""
DEFAULT_RECORDINGS_DIR = Path("recordings")
"""Where recordings started from the page are written."""

LARGE_LATTICE = 50_000
"""From this many particles on, the app uses the large-lattice pacing below."""


LARGE_LATTICE_FRAME_TIME = 0.25
"""Simulated seconds per frame aimed at on large lattices (the waves visibly travel)."""
LARGE_LATTICE_PANEL_INTERVAL = 0.5
"""Seconds between two panel updates while a large lattice plays: every update re-draws part of
the page (plots, status line) in the browser's only page thread, which a slow computer also
needs to answer clicks.  A frame at the scene's duration always reaches the panel (it pauses
the run there)."""


IDLE_REDRAW = 2.0
"""Seconds between two redraws of an unchanged frame (a paused run): each redraw updates the
panel's plots in every page, work a page without graphics acceleration does on its only
thread."""

RECONNECT_GRACE = 3.0
"""Seconds the run plays on after the last page left, for a page that reloads itself (a page
drawing in software, ``app.web.page_views``) or is reloaded by its reader to come back."""

REFIT_SECONDS = 20.0
"""Seconds after a page connects during which its camera is fitted again if it leaves the fit
(a loading page resets its camera to the scene's initial one when that reaches it late)."""


def far_plane(position: Sequence[float], look_at: Sequence[float]) -> float:
    """The far clipping distance of a camera fitted at ``position`` looking at ``look_at``:
    well beyond the lattice (viser's default, 1000 m, cut the flagship off on a phone, whose
    narrow view puts the camera 1070 m away), at least viser's default."""
    distance = float(np.linalg.norm(np.subtract(position, look_at)))
    return max(1000.0, 10.0 * distance)


def runner_pacing(simulation: sim.Simulation) -> tuple[int, float, float]:
    """(steps per frame, simulation frames/s cap, render frames/s cap) for a simulation.

    Small scenes: the steps per frame that let them play in real time at 60 frames a second
    (the Run folder's speed then sets the frame rate).  Large lattices: at most the cost of 5
    RK4 steps (20 force evaluations) per frame, and no more steps than
    ``LARGE_LATTICE_FRAME_TIME`` of simulated time needs (Verlet at dt = 0.02 s: 12)."""
    if simulation.model.n_particles >= LARGE_LATTICE:
        evaluations = sim.integrators.describe(simulation.integrator).force_evaluations
        by_cost = 20 // max(1, evaluations)
        by_time = max(1, round(LARGE_LATTICE_FRAME_TIME / simulation.dt))
        return max(1, min(by_cost, by_time)), 25.0, 25.0
    # small scenes: enough steps per frame that real time needs at most 60 frames a second
    return max(1, math.ceil(1.0 / (60.0 * simulation.dt) - 1e-9)), 60.0, 90.0


class WebApp:
    """The web app around one simulation.  ``start()`` then browse ``url``; ``stop()`` to end.

    scenes_dir: the directory whose ``.toml`` files the page may open by name;
    recordings_dir: where the page's recordings go;
    allow_origins: other origins (``http://name:port``, or ``*``) whose pages may drive the app;
    class_mode: one teacher page drives, the other pages watch (``app.web.roles``);
    preparer: compiles the kernels a scene needs before the runner steps it, while the page says
    so (``sim.runtime.warming``; default: the process's own).
    teacher_token: the teacher link's token (default: a new random one).
    """

    def __init__(self, simulation: sim.Simulation, host: str = "127.0.0.1", port: int = 8080,
                 verbose: bool = False, play: bool = False,
                 scenes_dir: str | Path = DEFAULT_SCENES_DIR,
                 recordings_dir: str | Path = DEFAULT_RECORDINGS_DIR,
                 allow_origins: Sequence[str] = (), class_mode: bool = False,
                 preparer: KernelPreparer | None = None,
                 teacher_token: str | None = None) -> None:
        steps_per_frame, sim_fps, self.render_fps = runner_pacing(simulation)
        self.runner = LatticeRunner(simulation, steps_per_frame=steps_per_frame, max_fps=sim_fps,
                                    preparer=preparer)
        self.control = SimulationControl(self.runner)
        self.scene_files = SceneDirectory(scenes_dir)
        self.recordings = WebRecordings(self.runner, recordings_dir)
        self.access = AccessPolicy(allowed_origins=tuple(allow_origins), join=class_mode)
        self.server = checked_server(self.access, host=host, port=port, verbose=verbose)
        self.gate = PageGate(self.server).install()
        self.server.gui.configure_theme(control_width="large", dark_mode=False)
        # nothing in the lattice's scene casts or receives a shadow, yet viser's default light
        # renders three shadow maps at every frame (a large share of a software-rendered frame)
        self.server.scene.configure_default_lights(enabled=True, cast_shadow=False)
        self.view = LatticeView(self.server)
        self.clients = ClientWatch(self.server)
        self.play_on_start = play
        self.hold_while_dragging = True
        self._latest: Frame | None = None
        self._drawn: Frame | None = None
        self._frame_ready = threading.Event()
        self.view.picture_wanted = self._frame_ready.set  # a page is ready: picture the newest
        self._pumping = False
        self._pump: threading.Thread | None = None
        self._unsubscribe: Any = None
        self._subscription: tuple[bool, bool] | None = None
        self._gizmo: viser.TransformControlsHandle | None = None
        self._gizmo_layout: tuple | None = None
        self._drag: dict[str, Any] | None = None
        self._camera_layout: tuple | None = None
        self.frames_delivered = 0
        self._panel_time = 0.0
        self.last_error: str | None = None
        self.scene_source = f"preset {simulation.scene.name}"
        """Where the current scene came from (shown in the Scene folder)."""

        self.panel = ControlPanel(self)
        self.page_views = PageViews(self.server, on_size=self.fit_client)
        self._install_interaction()
        self.roles = (ClassRoles(self.server, self.pick, token=teacher_token).install()
                      if class_mode else None)
        if self.roles is not None:  # a student's other messages: dropped unread past a few
            allowed = STUDENT_TYPES | {"ScenePointerMessage"}
            self.gate.role_messages = (
                lambda client_id: allowed if client_id in self.roles.students else None)

    # --- life cycle ------------------------------------------------------------------------------

    @property
    def url(self) -> str:
        host = self.server.get_host()
        shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
        return f"http://{shown}:{self.server.get_port()}"

    def start(self) -> WebApp:
        self._resubscribe()
        self._pumping = True
        self._pump = threading.Thread(target=self._pump_frames, name="web-frame-pump", daemon=True)
        self._pump.start()
        self.clients.start()
        self.runner.start()
        self.runner.post(lambda simulation: None)  # publish a first frame
        if self.play_on_start:
            self.runner.play()
        return self

    def stop(self) -> None:
        """Close a running recording (so its file verifies), stop the loop and the server."""
        try:
            self.recordings.shutdown()
        finally:
            self._stop_threads()

    def _stop_threads(self) -> None:
        self._pumping = False
        self._frame_ready.set()
        self.runner.stop()
        self.clients.stop()
        if self._pump is not None:
            self._pump.join(5.0)
        if self._unsubscribe is not None:
            self._unsubscribe()
        self.server.stop()

    def __enter__(self) -> WebApp:
        return self.start()

    def __exit__(self, *_: object) -> None:
        self.stop()

    # --- scenes ----------------------------------------------------------------------------------

    def replace_scene(self, scene: sim.Scene, source: str, timeout: float = 120.0) -> sim.Simulation:
        """Run ``scene`` instead of the current one (its own integrator and dt), with the pacing
        its size needs, and show it in the panel.  ``source`` says where it came from ("preset
        grid", "file my.toml", "upload x.zip").  Raises what building it raised."""
        simulation = self.control.replace_scene(scene).result(timeout=timeout)
        steps, sim_fps, render_fps = runner_pacing(simulation)
        self.runner.steps_per_frame = steps
        self.runner.max_fps = sim_fps
        self.render_fps = render_fps
        self.scene_source = source
        self.panel.show_scene(simulation)
        self.refresh()
        return simulation

    # --- frames ----------------------------------------------------------------------------------

    def _resubscribe(self) -> None:
        """Subscribe again if the view now needs strains / velocities it did not ask for."""
        wanted = (self.view.wants_strains(), self.view.wants_velocities())
        if wanted == self._subscription:
            return
        old = self._unsubscribe
        self._unsubscribe = self.runner.subscribe(
            self._receive, strains=wanted[0], velocities=wanted[1], preparing=True
        )
        self._subscription = wanted
        if old is not None:
            old()

    def _receive(self, frame: Frame) -> None:
        self._latest = frame
        self._frame_ready.set()

    def refresh(self) -> None:
        """Redraw everything from a fresh frame (after a view setting changed)."""
        self.view.invalidate()
        self._drawn = None
        self._resubscribe()
        self.runner.post(lambda simulation: None)

    def _pump_frames(self) -> None:
        last = given_back = 0.0
        shown: Frame | None = None
        while self._pumping:
            woke = self._frame_ready.wait(0.25)
            self._frame_ready.clear()
            now = time.perf_counter()
            if now - given_back >= memory.GIVE_BACK_SECONDS:
                given_back = now
                memory.give_back()  # the frames' freed arrays, back to the system
            frame = self._latest
            if not self._pumping or frame is None:
                continue
            if not woke and frame is shown and time.perf_counter() - last < IDLE_REDRAW:
                continue  # nothing new (paused): the pages' panels and plots stay as they are
            shown = frame
            wait = 1.0 / self.render_fps - (time.perf_counter() - last)
            if wait > 0:
                time.sleep(wait)
                frame = self._latest or frame
            last = time.perf_counter()
            try:
                self._show(frame)
            except Exception as error:  # never let one bad frame stop the page
                print(f"web view: could not draw a frame: {error!r}")

    def _show(self, frame: Frame) -> None:
        layout = (frame.model.nx, frame.model.ny, frame.model.spacing)
        if layout != self._camera_layout:
            self._frame_camera(frame.model)
            self._camera_layout = layout
            self.set_selection(np.zeros(0, dtype=np.int64))
            self._resubscribe()
        drawn, self._drawn = self._drawn, frame
        if not (frame.preparing is not None and drawn is not None and drawn.model is frame.model
                and np.array_equal(drawn.positions, frame.positions)):
            self.view.draw(frame)  # a frame that says "preparing" of an unmoved state: no need
        self.frames_delivered += 1
        if frame.error:
            self.last_error = frame.error
        self._follow_selection(frame)
        now = time.perf_counter()
        large = frame.model.n_particles >= LARGE_LATTICE
        if (not large or not frame.playing or frame.error
                or frame.time >= self.runner.simulation.scene.duration - 1e-9
                or now - self._panel_time >= LARGE_LATTICE_PANEL_INTERVAL):
            self._panel_time = now
            self.panel.update(frame)
        if self.roles is not None:
            self.roles.update(frame)

    def _frame_camera(self, model: sim.Model) -> None:
        camera = self.server.initial_camera
        camera.fov = VIEW_FOV
        position, look_at, up = laptop_fit(model, VIEW_FOV, 1366, 768)
        camera.position, camera.look_at, camera.up = position, look_at, up
        camera.far = far_plane(position, look_at)
        for client in self.server.get_clients().values():
            self.fit_client(client, model)

    def fit_client(self, client: viser.ClientHandle, model: sim.Model | None = None
                   ) -> np.ndarray:
        """Point ``client``'s camera so the lattice fills the part of its view the panel leaves:
        left of it and above the floating colour bar on a laptop, above the panel on a narrow
        view (a phone), where the panel floats over the lower part and the colour bar lies
        under the lattice in that page's own scene."""
        model = model or self.runner.simulation.model
        camera = client.camera
        width, height = self.page_views.view_size(client)
        width, height, fov = width or 1366, height or 768, VIEW_FOV
        camera.fov = fov
        self.view.colour_bar.set_narrow(client, width < NARROW)
        if width < NARROW:
            position, look_at, up = camera_fit(model, fov, width / height,
                                               bottom=PHONE_PANEL_SHARE)
        else:
            position, look_at, up = laptop_fit(model, fov, width, height)
        camera.far = far_plane(position, look_at)
        camera.position = position
        camera.look_at = look_at
        camera.up_direction = up
        return np.array(position, dtype=float)

    # --- selection and dragging ------------------------------------------------------------------

    def _install_interaction(self) -> None:
        scene = self.server.scene
        scene.set_up_direction("+y")

        @scene.on_click()
        def _(event: viser.SceneClickEvent) -> None:
            self.click(event.ray_origin, event.ray_direction, add=False)

        @scene.on_click(modifier="shift")
        def _(event: viser.SceneClickEvent) -> None:
            self.click(event.ray_origin, event.ray_direction, add=True)

        @self.server.on_client_connect
        def _(client: viser.ClientHandle) -> None:
            self.fit_client(client)
            self._frame_ready.set()  # draw the latest frame again: the new page's picture
            fitted: dict[str, Any] = {"size": (0, 0), "since": time.monotonic(), "again": 5}

            @client.camera.on_update
            def _(camera: viser.CameraHandle) -> None:
                # the first report of the view's size (and a resized window) refits once
                size = (camera.image_width, camera.image_height)
                if size != fitted["size"] and all(size):
                    fitted["size"] = size
                    fitted["pose"] = self.fit_client(client)
                    return
                # a loading page may reset its camera to the scene's initial one (fitted for a
                # laptop) after it applied this page's fit: fit it again while it loads
                pose = fitted.get("pose")
                if (pose is not None and fitted["again"] > 0
                        and time.monotonic() - fitted["since"] < REFIT_SECONDS
                        and np.linalg.norm(camera.position - pose) > 1e-3 * np.linalg.norm(pose)):
                    fitted["again"] -= 1
                    fitted["pose"] = self.fit_client(client)

        @self.server.on_client_disconnect
        def _(client: viser.ClientHandle) -> None:
            self.client_left(client.client_id)

    def client_left(self, client_id: int) -> None:
        """A browser went away: let go of whatever it was dragging; when it was the last one and
        none has come within ``RECONNECT_GRACE`` seconds (a page reloading itself, or its
        reader pressing F5), pause the run (unless a recording is on) instead of burning a core
        for nobody."""
        self.control.release(client_id)
        self.view.colour_bar.client_left(client_id)
        if self._drag is not None and self._drag["owner"] == client_id:
            self._drag = None
        if any(c != client_id for c in self.server.get_clients()):
            return
        timer = threading.Timer(RECONNECT_GRACE, self._pause_if_nobody)
        timer.daemon = True
        timer.start()

    def _pause_if_nobody(self) -> None:
        if not self.server.get_clients() and not self.recordings.active and self.runner.playing:
            self.control.pause()

    def pick(self, ray_origin: tuple[float, float, float],
             ray_direction: tuple[float, float, float]) -> int | None:
        """The particle under a pointer ray (cast onto z = 0), or None if it misses the lattice."""
        positions = self.view.last_positions
        model = self.view.model
        if positions is None or model is None:
            return None
        origin = np.asarray(ray_origin, dtype=float)
        direction = np.asarray(ray_direction, dtype=float)
        if abs(direction[2]) < 1e-9:
            return None
        distance = -origin[2] / direction[2]
        if distance <= 0:
            return None
        point = (origin + distance * direction)[:2]
        gaps = np.hypot(positions[:, 0] - point[0], positions[:, 1] - point[1])
        nearest = int(np.argmin(gaps))
        return nearest if gaps[nearest] <= 0.5 * model.spacing else None

    def click(self, ray_origin: tuple[float, float, float],
              ray_direction: tuple[float, float, float], add: bool = False) -> int | None:
        particle = self.pick(ray_origin, ray_direction)
        if particle is None:
            return None
        if add:
            chosen = np.union1d(self.view.selection, [particle])
        else:
            chosen = np.array([particle], dtype=np.int64)
        self.set_selection(chosen)
        return particle

    def set_selection(self, indices: np.ndarray) -> None:
        """Select particles (indices p = row * nx + column); shows them red and the gizmo."""
        self.view.set_selection(indices)
        self.panel.selection_changed(self.view.selection)
        if self.view.selection.size == 0 and self._gizmo is not None:
            self._gizmo.remove()
            self._gizmo = None
            self._gizmo_layout = None
        self._frame_ready.set()
        self.runner.post(lambda simulation: None)

    def _follow_selection(self, frame: Frame) -> None:
        selection = self.view.selection
        if selection.size == 0 or self._drag is not None:
            return
        centre = np.zeros(3)
        centre[: frame.model.dim] = frame.positions[selection].mean(axis=0)
        layout = (frame.model.nx, frame.model.ny, frame.model.dim)
        if self._gizmo is None or layout != self._gizmo_layout:
            if self._gizmo is not None:
                self._gizmo.remove()
            self._gizmo = self._make_gizmo(frame.model, centre)
            self._gizmo_layout = layout
        elif np.linalg.norm(self._gizmo.position - centre) > 1e-4 * frame.model.spacing:
            self._gizmo.position = tuple(centre)

    def _make_gizmo(self, model: sim.Model, centre: np.ndarray) -> viser.TransformControlsHandle:
        extent = max(model.nx, model.ny) * model.spacing
        gizmo = self.server.scene.add_transform_controls(
            "/selection_gizmo", scale=max(1.5 * model.spacing, 0.06 * extent),
            active_axes=(True, True, model.dim == 3), disable_rotations=True,
            depth_test=False, position=tuple(centre),
        )

        @gizmo.on_update
        async def _(event: viser.TransformControlsEvent) -> None:
            # async: runs on the event loop in order (start, updates, end); only posts commands
            self.drag(event.phase, np.asarray(event.target.position, dtype=float),
                      owner=event.client_id)

        return gizmo

    def drag(self, phase: str, gizmo_position: np.ndarray, owner: Any = None) -> None:
        """Gizmo drag lifecycle: ``start`` remembers the selection's layout, ``update`` moves it
        (held while dragging if ``hold_while_dragging``), ``end`` lets go."""
        positions = self.view.last_positions
        model = self.view.model
        selection = self.view.selection
        if positions is None or model is None or selection.size == 0:
            return
        dim = model.dim
        if phase == "start" or self._drag is None:
            offsets = positions[selection] - positions[selection].mean(axis=0)
            self._drag = {"owner": owner, "offsets": offsets, "indices": selection.copy()}
        drag = self._drag
        targets = np.asarray(gizmo_position, dtype=float)[:dim] + drag["offsets"]
        try:
            self.control.move_particles(
                drag["indices"], targets, owner=owner,
                pin=self.hold_while_dragging and phase != "end")
        except (ValueError, IndexError) as error:  # a position no drag can reach: not applied
            self.last_error = f"gizmo drag refused: {error}"
            print(f"web page: {self.last_error}", file=sys.stderr)
        if phase == "end":
            self.control.release(owner)
            self._drag = None
