"""The page's "Tape and stopwatch" folder: a tape measure between two particles and a stopwatch of
simulated time, as a student measures a wavelength and a period in a ripple tank.

Shown for scenes with sources or barriers.  *Tape: A* and *Tape: B* (column, row) are the tape's
ends, typed or taken from the selected particle; the folder says their distance in lattice
spacings and in metres (at rest positions) and draws the tape on the lattice in orange.  The
stopwatch runs on the simulated time of the frames the page draws: *Start / Stop* and *Reset*;
it shows the simulated seconds counted and the wall seconds they took (the rate, like the Run
folder's), and it restarts when the simulation's time goes back (Reset of the run).

Nothing here posts a command: the tape and the stopwatch only look at the lattice.
"""

from __future__ import annotations

import math
import time

import numpy as np
import viser

import sim
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, from_user, whole_number
from app.web.widgets import say
from sim.runtime.runner import Frame

TAPE_COLOUR = (230, 126, 34)
REFRESH_SECONDS = 0.2
"""Seconds between two updates of the stopwatch's reading."""


def tape_length(model: sim.Model, a: tuple[int, int], b: tuple[int, int]) -> tuple[float, float]:
    """(spacings, metres) between particles ``a`` and ``b`` ((column, row)) at rest."""
    rest = np.asarray(model.rest_positions)
    first, second = (rest[row * model.nx + column] for column, row in (a, b))
    metres = float(np.linalg.norm(second - first))
    return metres / float(model.spacing), metres


class Stopwatch:
    """Simulated and wall seconds counted while running (start, stop, reset)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.simulated = 0.0
        self.wall = 0.0
        self.running = False
        self._since: tuple[float, float] | None = None
        """(simulated, wall) time of the last reading while running."""

    def start(self) -> None:
        self.running = True
        self._since = None

    def stop(self) -> None:
        self.running = False
        self._since = None

    def observe(self, simulated: float, wall: float) -> None:
        """Count the time since the last reading (a running stopwatch)."""
        if not self.running:
            return
        if self._since is not None and simulated >= self._since[0]:
            self.simulated += simulated - self._since[0]
            self.wall += wall - self._since[1]
        self._since = (simulated, wall)

    def describe(self) -> str:
        state = "running" if self.running else "stopped"
        rate = f", {self.simulated / self.wall:.2f} s simulated per s" if self.wall > 0 else ""
        return (f"stopwatch: {self.simulated:.3f} s of simulated time ({state}; "
                f"{self.wall:.1f} s of wall time{rate})")


class MeasureFolder(Folder):
    name = "measure"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self.stopwatch = Stopwatch()
        self._last = 0.0
        self._last_time = -math.inf
        self.tape_line: viser.LineSegmentsHandle | None = None
        """The tape drawn on the lattice (shown only with the folder, in ripple tanks)."""
        self._in_use: tuple[tuple[int, int], tuple[int, int]] = ((0, 0), (0, 0))
        """The tape's ends in use (column, row): what a refused value is set back to."""
        gui = host.server.gui
        self.folder = gui.add_folder("Tape and stopwatch", expand_by_default=False)
        with self.folder:
            self.end_a = gui.add_vector2("Tape: A (column, row)", (0, 0), step=1,
                                         hint="one end of the tape")
            self.end_b = gui.add_vector2("Tape: B (column, row)", (0, 0), step=1,
                                         hint="the other end of the tape")
            self.a_button = gui.add_button("A = selected particle", icon=viser.Icon.POINTER)
            self.b_button = gui.add_button("B = selected particle", icon=viser.Icon.POINTER)
            self.tape = gui.add_html("")
            self.watch_button = gui.add_button("Start stopwatch", icon=viser.Icon.CLOCK_PLAY)
            self.watch_reset = gui.add_button("Reset stopwatch", icon=viser.Icon.CLOCK_STOP)
            self.reading = gui.add_html(as_html(self.stopwatch.describe()))
            self.message = gui.add_html("")

        def typed(_: viser.GuiEvent) -> None:
            self._show_tape()

        self.end_a.on_update(from_user(typed))
        self.end_b.on_update(from_user(typed))

        def take(handle):
            def handler(_: viser.GuiEvent) -> None:
                model = self.host.runner.simulation.model
                selection = np.asarray(self.host.view.selection)
                if not selection.size:
                    say(self.message, "select a particle first (click it)", "refused")
                    return
                particle = int(selection[0]) % model.n_particles
                handle.value = (particle % model.nx, particle // model.nx)
                self._show_tape()
            return handler

        self.a_button.on_click(from_user(take(self.end_a)))
        self.b_button.on_click(from_user(take(self.end_b)))

        @self.watch_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            if self.stopwatch.running:
                self.stopwatch.stop()
            else:
                self.stopwatch.start()
                self.stopwatch.observe(self.host.runner.simulation.time, time.perf_counter())
            self._show_watch()

        @self.watch_reset.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            self.stopwatch.reset()
            self._show_watch()

    def _ends(self, model: sim.Model) -> tuple[tuple[int, int], tuple[int, int]]:
        ends = []
        for name, handle in (("A", self.end_a), ("B", self.end_b)):
            value = handle.value
            if not isinstance(value, (tuple, list)) or len(value) != 2:
                raise InputRefused(f"tape end {name} is (column, row)")
            ends.append((whole_number(value[0], f"tape {name} column", 0, model.nx - 1),
                         whole_number(value[1], f"tape {name} row", 0, model.ny - 1)))
        return ends[0], ends[1]

    def _show_tape(self) -> None:
        model = self.host.runner.simulation.model
        try:
            a, b = self._ends(model)
        except InputRefused as error:
            say(self.message, error, "refused")
            # every page shows the ends in use again, not the refused value
            for handle, end in zip((self.end_a, self.end_b), self._in_use, strict=True):
                if tuple(handle.value) != end:
                    handle.value = end
            return
        self._in_use = (a, b)
        self.message.content = ""
        spacings, metres = tape_length(model, a, b)
        self.tape.content = as_html(f"tape A {a} to B {b}: {spacings:.4g} spacings = "
                                    f"{metres:.4g} m")
        rest = np.asarray(model.rest_positions)
        points = np.zeros((1, 2, 3), np.float32)
        for k, (column, row) in enumerate((a, b)):
            points[0, k, : model.dim] = rest[row * model.nx + column, : model.dim]
        points[0, :, 2] = 0.6 * float(model.spacing)
        # only where the folder is shown (ripple tanks): elsewhere no tape lies across the lattice
        self.tape_line = self.host.server.scene.add_line_segments(
            "/tape", points=points, colors=TAPE_COLOUR,
            thickness=0.4 * float(model.spacing), visible=a != b and self.folder.visible)

    def _show_watch(self) -> None:
        label = "Stop stopwatch" if self.stopwatch.running else "Start stopwatch"
        if self.watch_button.label != label:
            self.watch_button.label = label
        reading = as_html(self.stopwatch.describe())
        if self.reading.content != reading:
            self.reading.content = reading

    def show_scene(self, simulation: sim.Simulation) -> None:
        model = simulation.model
        self.folder.visible = bool(model.sources or model.barriers
                                   or simulation.scene.model.sources)
        self.end_a.max = self.end_b.max = (model.nx - 1, model.ny - 1)
        middle = model.ny // 2
        self.end_a.value = (0, middle)
        self.end_b.value = (model.nx - 1, middle)
        self.stopwatch.reset()
        self._last_time = -math.inf
        self._show_watch()
        self._show_tape()

    def update(self, frame: Frame, now: float) -> None:
        if frame.time < self._last_time:
            self.stopwatch.reset()  # the run was reset
        self._last_time = frame.time
        self.stopwatch.observe(frame.time, now)
        if now - self._last >= REFRESH_SECONDS:
            self._last = now
            self._show_watch()
