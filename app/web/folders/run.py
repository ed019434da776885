"""The page's "Run" folder: Play/Pause, Single step, Reset, and the status line.

The status line shows the time, the step, whether the run goes on and the steps per second; a red
line says why the run stopped (a blow-up), and an amber one that a part of the app (a recorder, a
plot) failed and was detached while the simulation goes on.
"""

from __future__ import annotations

import time

import viser

from app.web.host import Folder, PanelHost
from app.web.inputs import amber_html, as_html, from_user, warning_html
from sim.runner import Frame

STATUS_INTERVAL = 0.5
"""Seconds between two updates of the status line."""


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
            self.status = gui.add_html("")
            self.error_html = gui.add_html("", visible=False)
            self.part_html = gui.add_html("", visible=False)

        @self.play_button.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            if host.runner.playing:
                host.control.pause()
            else:
                host.control.play()
            self._show_playing()

        @self.step_button.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            host.control.single_step()
            self._show_playing()

        @self.reset_button.on_click
        @from_user
        async def _(_: viser.GuiEvent) -> None:
            host.control.reset()

    def _show_playing(self) -> None:
        playing = self.host.runner.playing
        self.play_button.label = "Pause" if playing else "Play"
        self.play_button.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY

    def update(self, frame: Frame, now: float) -> None:
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
            self.status.content = as_html(
                f"t = {frame.time:.3f} s, step {frame.step}, "
                f"{'running' if frame.playing else 'paused'}, "
                f"{self._steps_per_second:.0f} steps/s\n{frame.model.describe()}"
            )

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
