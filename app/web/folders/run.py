"""The page's "Run" folder: Play/Pause, Single step, Reset, the speed, and the status line.

Each button and each speed step is a keyboard command too (``KEYS``: Space, N, Shift+R,
Shift+Up/Down; in viser's command palette as well), listed in the folder, for a teacher at a
projector and for people who do not use a mouse.

The status line shows the time, the step, whether the run goes on, the steps per second and the
rate (simulated seconds per second of wall time); a red line says why the run stopped (a
blow-up), and an amber one that a part of the app (a recorder, a plot) failed and was detached
while the simulation goes on.

*Speed*: small scenes play in real time by default (x1), or in slow motion (x1/4, x1/2): the
runner's frame rate follows the steps per frame and dt (at most ``MAX_FPS`` frames a second), and
the status line says when the machine cannot keep up.  Large lattices play as fast as they can
by default.

*Preparing*: while the kernels a scene needs are being compiled (``sim.runtime.warming``), the status
line says so with the seconds it has taken; the buttons and every other control answer meanwhile.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import viser

from app.web.control import MAX_STEPS_PER_FRAME
from app.web.host import Folder, PanelHost
from app.web.inputs import amber_html, as_html, from_user, warning_html
from sim.runtime.runner import Frame

STATUS_INTERVAL = 0.5
"""Seconds between two updates of the status line."""
SPEEDS = {"x1/4": 0.25, "x1/2": 0.5, "x1": 1.0, "x10": 10.0, "x50": 50.0, "x200": 200.0,
          "as fast as it can": None}
"""The page's speeds: simulated seconds per second of wall time (None: no pacing).  A speed
above what the scene's steps per frame reach at ``MAX_FPS`` runs more steps per frame."""
WATCHED_SECONDS = 90.0
"""A small scene whose duration takes longer than ``LONG_SCENE`` in real time starts at the
slowest speed that plays it within this many seconds (the fput chain: x200)."""
LONG_SCENE = 600.0
MAX_FPS = 60.0
"""Frames a second at most when a speed is asked for."""
LARGE = 50_000
"""From this many particles on, a scene plays as fast as it can by default."""
KEYS = (("Play or pause", "space", None), ("Single step", "N", None), ("Reset", "R", "shift"),
        ("Faster", "arrowup", "shift"), ("Slower", "arrowdown", "shift"))
"""The Run folder's keyboard commands: (label, key, modifier), in viser's command palette too."""
KEYS_TEXT = "Keys: Space play/pause · N single step · Shift+R reset · Shift+↑/↓ faster/slower"


def default_speed(simulation) -> str:
    """The speed a scene starts at: as fast as it can for a large lattice; for a scene whose
    duration takes longer than ``LONG_SCENE`` in real time, the slowest listed speed that plays
    it within ``WATCHED_SECONDS``; else real time."""
    if simulation.model.n_particles >= LARGE:
        return "as fast as it can"
    duration = float(simulation.scene.duration)
    if duration > LONG_SCENE:
        for name, speed in SPEEDS.items():
            if speed is not None and duration / speed <= WATCHED_SECONDS:
                return name
        return "as fast as it can"
    return "x1"


class RunFolder(Folder):
    name = "run"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._last_status = 0.0
        self._status_steps = (time.perf_counter(), 0)
        self._steps_per_second = 0.0
        self._error_shown: str | None = None
        self._subscriber_errors_seen = 0
        gui = host.server.gui
        with gui.add_folder("Run"):
            self.play_button = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY,
                                              hint="start or pause the simulation")
            self.step_button = gui.add_button("Single step", icon=viser.Icon.PLAYER_TRACK_NEXT)
            self.reset_button = gui.add_button("Reset", icon=viser.Icon.REFRESH,
                                               hint="back to the scene's initial state")
            large = host.runner.simulation.model.n_particles >= LARGE
            self.speed = gui.add_dropdown(
                "Speed", list(SPEEDS), initial_value="as fast as it can" if large else "x1",
                hint="simulated seconds per second: real time (x1) or slow motion")
            self.keys = gui.add_html(as_html(KEYS_TEXT, color="#555"))
            self.status = gui.add_html("")
            self.error_html = gui.add_html("", visible=False)
            self.end_html = gui.add_html("", visible=False)
            self.part_html = gui.add_html("", visible=False)

        actions = (self._play_or_pause, self._single_step, self._reset, self._faster,
                   self._slower)
        for button, action in zip((self.play_button, self.step_button, self.reset_button),
                                  actions, strict=False):
            button.on_click(from_user(action))
        for (label, key, modifier), action in zip(KEYS, actions, strict=True):
            command = gui.add_command(label, hotkey=key, modifier=modifier)
            command.on_trigger(from_user(action))

        self._fastest_fps = host.runner.max_fps
        self._base_steps = max(1, int(host.runner.steps_per_frame))
        self.go_on = False
        """Whether the user asked to run past the scene's duration."""
        self.keep_going: Callable[[], str | None] = lambda: None
        """Why the run should go on past the scene's duration (None: it need not), asked at
        the duration (the panel sets it: the Probes folder's ``time_still_needed``)."""
        self._reached_end = False

        @self.speed.on_update
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            if self.speed.value not in SPEEDS:
                self.speed.value = "x1"
            self._pace()

    # --- what the buttons and the keys do -----------------------------------------------------

    async def _play_or_pause(self, _: Any) -> None:
        if self.host.runner.playing:
            self.host.control.pause()
        else:
            if self._reached_end:
                self.go_on = True  # asked to go on past the scene's duration
            self.host.control.play()
        self._show_playing()

    async def _single_step(self, _: Any) -> None:
        self.host.control.single_step()
        self._show_playing()

    async def _reset(self, _: Any) -> None:
        self.go_on = False
        self.host.control.reset()

    async def _faster(self, _: Any) -> None:
        self._change_speed(+1)

    async def _slower(self, _: Any) -> None:
        self._change_speed(-1)

    def _change_speed(self, way: int) -> None:
        """The next speed of ``SPEEDS`` up (+1) or down (-1), shown and applied."""
        names = list(SPEEDS)
        at = names.index(self.speed.value) if self.speed.value in names else names.index("x1")
        self.speed.value = names[min(max(at + way, 0), len(names) - 1)]
        self._pace()

    def show_scene(self, simulation) -> None:
        """Real time for small scenes, as fast as it can for large lattices."""
        self.go_on = self._reached_end = False
        self._fastest_fps = self.host.runner.max_fps
        self._base_steps = max(1, int(self.host.runner.steps_per_frame))
        self.speed.value = default_speed(simulation)
        self._pace()

    def _pace(self) -> None:
        """Set the runner's frame rate for the chosen speed (dt and steps per frame as they are
        now)."""
        runner = self.host.runner
        speed = SPEEDS.get(self.speed.value)
        if speed is None:
            runner.steps_per_frame = self._base_steps
            runner.max_fps = self._fastest_fps
            return
        dt = runner.simulation.dt
        runner.steps_per_frame = min(MAX_STEPS_PER_FRAME, max(
            self._base_steps, math.ceil(speed / (dt * MAX_FPS) - 1e-9)))
        runner.max_fps = min(MAX_FPS, speed / (runner.steps_per_frame * dt))

    def _show_playing(self) -> None:
        playing = self.host.runner.playing
        self.play_button.label = "Pause" if playing else "Play"
        self.play_button.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY

    def _say_end(self, text: str | None) -> None:
        """Show the note that the run paused at the scene's duration, or take it away."""
        if text is not None:
            self.end_html.content = as_html(text)
        if self.end_html.visible != (text is not None):
            self.end_html.visible = text is not None

    def _stop_at_duration(self, frame: Frame) -> None:
        """Pause once at the scene's duration (unless the user asked to go on) and say so; the
        note goes when the run goes on or starts again (a reset)."""
        duration = self.host.runner.simulation.scene.duration
        if frame.time < duration - 1e-9:
            self._reached_end = False
            self._say_end(None)
            return
        if frame.playing and not self.go_on and not self._reached_end:
            reason = self.keep_going()
            if reason is not None:  # a folder needs the run to go on (the probes' sound)
                self._say_end(reason)
                return
            self._reached_end = True
            self.host.control.pause()
            self._say_end(f"Paused at the scene's duration ({duration:g} s); press Play to go on.")
        elif frame.playing and self.go_on:
            self._say_end(None)

    def update(self, frame: Frame, now: float) -> None:
        if frame.preparing is not None:
            self._show_preparing(frame, now)
            return
        self._stop_at_duration(frame)
        self._update_error(frame)
        self._update_part_failures()
        if now - self._last_status > STATUS_INTERVAL:
            started, steps = self._status_steps
            taken = self.host.runner.steps_taken
            if now > started:
                self._steps_per_second = (taken - steps) / (now - started)
            self._status_steps = (now, taken)
            self._last_status = now
            self._show_playing()
            self._pace()
            rate = self._steps_per_second * frame.dt
            asked = SPEEDS.get(self.speed.value)
            behind = (" - this machine cannot keep up" if frame.playing and asked is not None
                      and rate < 0.85 * asked else "")
            self.status.content = as_html(
                f"t = {frame.time:.3f} s, step {frame.step}, "
                f"{'running' if frame.playing else 'paused'}, "
                f"{self._steps_per_second:.0f} steps/s\n"
                f"rate {rate:.2f} s of simulated time per second ({self.speed.value}{behind})\n"
                f"{frame.model.describe()}"
            )

    def _show_preparing(self, frame: Frame, now: float) -> None:
        """Say that the kernels are being prepared, and how long that has taken."""
        self._show_playing()
        self._last_status = 0.0  # the next true frame updates the status at once
        self._status_steps = (now, self.host.runner.steps_taken)
        first = " (first time on this machine)" if frame.preparing.compiling else ""
        then = "it runs when ready" if self.host.runner.playing else "paused"
        self.status.content = amber_html(
            f"Preparing the kernel for this scene{first}: {frame.preparing.seconds:.0f} s\n"
            f"t = {frame.time:.3f} s, step {frame.step}, {then}\n{frame.model.describe()}")

    def _update_part_failures(self) -> None:
        """Say in the page when a subscriber (a recorder, a plot) failed and was detached."""
        runner = self.host.runner
        errors = runner.subscriber_errors
        if runner.frames_published and len(errors) and (
            len(errors) != self._subscriber_errors_seen
        ):
            self._subscriber_errors_seen = len(errors)
            self.part_html.content = amber_html(
                f"A part of the app stopped (the simulation goes on): {errors[-1]}")
            self.part_html.visible = True

    def _update_error(self, frame: Frame) -> None:
        runner = self.host.runner
        error = frame.error or (runner.error if not runner.playing else None)
        if error == self._error_shown:
            return
        self._error_shown = error
        if error:
            self.error_html.content = warning_html(f"Stopped: {error}")
            self.error_html.visible = True
            self._show_playing()
        else:
            self.error_html.visible = False
