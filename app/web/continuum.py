"""The "Continuum limit" page: one body (``sim.scenes.bodies``) at several particle counts, stacked one
above another, moving on one clock, with the exact continuum solution (``sim.scenes.continuum``) drawn
over each and the distance from it shown live per N.

* a **string**: each row shows the beads and the line through them (blue; the displacement
  drawn across the string, exaggerated as in recordings, ``app.recording.continuum``) and the
  continuum solution as a thin red curve over them;
* a **membrane**: each row shows the lattice's displacement as an image in the ``signed-field``
  colours of ``app.colours`` and, beside it, the reference panel: the continuum at the same
  particles in the same colours.

The waves are fast (c = 100 m/s crosses a 1 m string in 0.01 s), so the clock runs in slow
motion: "seconds per crossing" says how many wall seconds one crossing time 2 L0 / c takes;
the clock waits while no page is open.
A clock thread advances every lattice to the common time (``BodyRun.advance_to``) and draws at
up to ``FPS`` frames per second.  The panel: Play, the slow motion, Restart, the clock and a
table of distances.  Callbacks act only on events a browser sent (``app.web.inputs.from_user``)
and only set the page's own state; the server is the project's checked server
(``app.web.security``).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence

import numpy as np

from app.colours import get as colour_map
from app.recording.continuum import CURVE_POINTS, BodyRun, drawn_exaggeration
from app.web.inputs import InputRefused, as_html, from_user, number
from app.web.page_views import PageViews
from app.web.security import AccessPolicy, checked_server
from app.web.view import NARROW, PHONE_PANEL_SHARE, VIEW_FOV, box_fit
from sim.scenes.bodies import Body
from sim.scenes.continuum import ContinuumSolution

FPS = 30.0
DEFAULT_SECONDS_PER_CROSSING = 8.0
SLOW_MOTION_RANGE = (1.0, 120.0)
"""Wall seconds one crossing time may take (the slider's range)."""

LATTICE_COLOUR = (40, 90, 200)
CONTINUUM_COLOUR = (220, 60, 40)
MEMBRANE_SCALE = 0.3
"""The membrane's colour scale: this share of the shape's amplitude is full colour (the bump
spreads out in two dimensions and its height falls)."""
IMAGE_PIXELS = 256
"""A membrane image is enlarged (each particle a block of pixels) to about this many pixels."""
ROW_HEIGHT = 0.45
"""Height of one row (fractions of L0)."""
PANEL_WIDTH = 320
"""CSS pixels of the page's control panel (viser's "medium" controls) at a laptop's right."""
LABEL_HEIGHT = 0.1
"""Room (fractions of L0) above the top row for its label."""
HEADING_GAP = 0.1
"""The membrane's column headings stand this much (fractions of L0) above the top row's label."""


class ContinuumPage:
    """The page for ``body`` at each of ``particles`` per side.  ``start()``, browse ``url``,
    ``stop()``.  ``time`` is the common clock (s), ``distances`` the latest distance per N."""

    def __init__(self, body: Body, particles: Sequence[int], integrator: str = "verlet",
                 host: str = "127.0.0.1", port: int = 8080, play: bool = True,
                 allow_origins: Sequence[str] = ()) -> None:
        self.body = body
        self.particles = sorted(set(int(n) for n in particles))
        self.integrator = integrator
        self.runs = [BodyRun(body, n, integrator) for n in self.particles]
        self.curve = ContinuumSolution(body, CURVE_POINTS - 1) if body.kind == "string" else None
        self.time = 0.0
        self.distances = {n: 0.0 for n in self.particles}
        self.playing = play
        self.seconds_per_crossing = DEFAULT_SECONDS_PER_CROSSING
        self._restart = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.access = AccessPolicy(allowed_origins=tuple(allow_origins))
        self.server = checked_server(self.access, host=host, port=port)
        self.server.gui.configure_theme(control_width="medium", dark_mode=False)
        self._build_panel()
        self._build_scene()
        self.page_views = PageViews(self.server, on_size=self._fit)
        self.server.on_client_connect(self._frame_camera)

    @property
    def url(self) -> str:
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    # --- the panel ------------------------------------------------------------------------------

    def _build_panel(self) -> None:
        gui = self.server.gui
        gui.add_markdown(as_html(f"Continuum limit: {self.body.describe()}"))
        self.play_box = gui.add_checkbox("Play", initial_value=self.playing)
        self.slow_motion = gui.add_slider(
            "Seconds per crossing", min=SLOW_MOTION_RANGE[0], max=SLOW_MOTION_RANGE[1], step=1.0,
            initial_value=self.seconds_per_crossing,
            hint="wall seconds for one crossing time 2 L0 / c (slow motion)")
        restart = gui.add_button("Restart")
        self.clock = gui.add_markdown("")
        self.table = gui.add_markdown("")

        @from_user
        def on_play(event) -> None:
            self.playing = bool(self.play_box.value)

        @from_user
        def on_slow_motion(event) -> None:
            try:
                self.seconds_per_crossing = number(self.slow_motion.value, "seconds per crossing",
                                                   *SLOW_MOTION_RANGE)
            except InputRefused:  # the slider shows the value in use again
                self.slow_motion.value = self.seconds_per_crossing

        @from_user
        def on_restart(event) -> None:
            self._restart = True

        self.play_box.on_update(on_play)
        self.slow_motion.on_update(on_slow_motion)
        restart.on_click(on_restart)

    def _show_panel(self) -> None:
        crossings = self.time / self.body.crossing_time
        self.clock.content = f"t = {self.time:.5g} s = {crossings:.3f} crossing times"
        rows = "\n".join(f"| {n} | {self.body.spacing(n):.3g} | {self.distances[n]:.2e} |"
                         for n in self.particles)
        self.table.content = ("| N | a (m) | distance |\n|---:|---:|---:|\n" + rows +
                              "\n\ndistance: relative L2 distance of the lattice from the "
                              "continuum at its particles")

    # --- the scene ------------------------------------------------------------------------------

    def _row_offset(self, index: int) -> float:
        return -index * ROW_HEIGHT * self.body.length

    def _build_scene(self) -> None:
        scene = self.server.scene
        length = self.body.length
        self.labels = []
        for index, n in enumerate(self.particles):
            y = self._row_offset(index)
            self.labels.append(scene.add_label(  # over the row's left end: never cut at the left
                f"/continuum/N{n:04d}/label", f"N = {n}", position=(0.0, y + 0.2 * length, 0.0),
                anchor="bottom-left"))
            if self.body.kind == "membrane" and index == 0:
                size = 0.8 * ROW_HEIGHT * length
                for text, x in (("lattice", 0.5 * size), ("continuum (reference)", 1.6 * size)):
                    scene.add_label(f"/continuum/heading/{text}", text, anchor="bottom-center",
                                    position=(x, y + (0.2 + HEADING_GAP) * length, 0.0))
            if self.body.kind == "string":
                scene.add_line_segments(  # the fixed ends' line at rest, grey
                    f"/continuum/N{n:04d}/axis", np.array([[[0.0, y, -0.001], [length, y, -0.001]]]),
                    colors=(200, 200, 200), thickness=1.0, thickness_units="screen")
        self._draw()

    def _frame_camera(self, client) -> None:
        """Fit ``client``'s camera to every row and its label in the part of its view the panel
        leaves (left of it on a laptop, above it on a phone), and again when the page reports
        its size."""
        self._fit(client)
        sizes: dict[str, tuple] = {"seen": (0, 0)}

        @client.camera.on_update
        def _(camera) -> None:
            size = (camera.image_width, camera.image_height)
            if size != sizes["seen"] and all(size):
                sizes["seen"] = size
                self._fit(client)

    def _fit(self, client) -> None:
        length = self.body.length
        membrane = self.body.kind == "membrane"
        # a membrane's two images, each 0.8 ROW_HEIGHT wide, centred at 0.5 and 1.6 of that
        width = (2.1 * 0.8 * ROW_HEIGHT if membrane else 1.0) * length
        top = (0.2 + LABEL_HEIGHT + (HEADING_GAP if membrane else 0.0)) * length
        bottom = self._row_offset(len(self.particles) - 1) - 0.25 * length
        view_width, view_height = self.page_views.view_size(client)
        view_width, view_height = view_width or 1366, view_height or 768
        narrow = view_width < NARROW
        position, look_at = box_fit(
            -0.02 * length, width, bottom, top, VIEW_FOV, view_width / view_height,
            covered_right=0.0 if narrow else min(0.5, PANEL_WIDTH / view_width),
            covered_bottom=PHONE_PANEL_SHARE if narrow else 0.0)
        with client.atomic():
            client.camera.fov = VIEW_FOV
            client.camera.up_direction = (0.0, 1.0, 0.0)
            client.camera.position = position
            client.camera.look_at = look_at
            client.camera.far = max(1000.0, 10.0 * position[2])

    def _draw(self) -> None:
        scene = self.server.scene
        body, length = self.body, self.body.length
        exaggeration = drawn_exaggeration(body)
        with self.server.atomic():
            for index, run in enumerate(self.runs):
                n = run.particles
                y = self._row_offset(index)
                field, reference = run.fields(self.time)
                self.distances[n] = run.distance(field, reference)
                self.labels[index].text = f"N = {n}  distance {self.distances[n]:.1e}"
                if self.curve is not None:
                    s = np.concatenate([[0.0], body.coordinates(n), [length]])
                    u = np.concatenate([[0.0], field[0], [0.0]]) * exaggeration + y
                    beads = np.stack([s, u, np.zeros_like(s)], axis=1)
                    scene.add_line_segments(f"/continuum/N{n:04d}/line",
                                            np.stack([beads[:-1], beads[1:]], axis=1),
                                            colors=LATTICE_COLOUR, thickness=2.0,
                                            thickness_units="screen")
                    scene.add_point_cloud(f"/continuum/N{n:04d}/beads", beads[1:-1],
                                          colors=LATTICE_COLOUR,
                                          point_size=min(0.02, 0.4 * body.spacing(n)) * length)
                    fine = np.concatenate([[0.0], self.curve.at(self.time)[0], [0.0]])
                    xs = np.linspace(0.0, length, CURVE_POINTS + 1)
                    curve = np.stack([xs, fine * exaggeration + y, np.full_like(xs, 0.001)], axis=1)
                    scene.add_line_segments(f"/continuum/N{n:04d}/continuum",
                                            np.stack([curve[:-1], curve[1:]], axis=1),
                                            colors=CONTINUUM_COLOUR, thickness=1.0,
                                            thickness_units="screen")
                    continue
                colours = colour_map("signed-field")
                scale = MEMBRANE_SCALE * abs(body.shape.amplitude)
                size = 0.8 * ROW_HEIGHT * length
                repeat = max(1, IMAGE_PIXELS // n)  # one block of pixels per particle, sharp
                for part, values, x in (("lattice", field, 0.5 * size),
                                        ("continuum", reference, 1.6 * size)):
                    image = colours.map(values[::-1], scale)  # image rows top down: y up
                    image = np.repeat(np.repeat(image, repeat, axis=0), repeat, axis=1)
                    scene.add_image(f"/continuum/N{n:04d}/{part}", image, size, size,
                                    format="png", position=(x, y, 0.0))
            self._show_panel()

    # --- the clock ------------------------------------------------------------------------------

    def _advance(self, wall_seconds: float) -> None:
        if self._restart:
            self._restart = False
            self.runs = [BodyRun(self.body, n, self.integrator) for n in self.particles]
            self.time = 0.0
        elif self.playing and self.server.get_clients():  # no page: the clock waits
            self.time += wall_seconds * self.body.crossing_time / self.seconds_per_crossing
            for run in self.runs:
                run.advance_to(self.time)
        else:
            return
        self._draw()

    def _loop(self) -> None:
        last = time.perf_counter()
        while not self._stop.wait(1.0 / FPS):
            now = time.perf_counter()
            try:
                self._advance(min(now - last, 0.2))
            except Exception as error:  # noqa: BLE001 - shown in the page, the server stays up
                self.playing = False
                self.clock.content = as_html(f"stopped: {error}")
            last = now

    def start(self) -> None:
        self._thread = threading.Thread(target=self._loop, name="continuum-clock", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self.server.stop()
