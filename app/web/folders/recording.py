"""The page's "Recording" folder: record the live run on the server, take it home, or
download a movie.

*Start recording* records the run into the server's recordings directory (``app.web.recording``
chooses the file name; nothing the page sends names a file) until *Stop recording*; a recorder
that fails (a full disk) is stopped and the folder says why.  *Download recording* hands the
browser the ``.rrd`` just made (a running one is closed first) and its read-me (``.md``).
*Download a movie* renders the scene's run from the current state in the background
(``app.web.jobs``: frames encoded as drawn, progress shown, at most ``MOVIE_FRAME_LIMIT`` frames),
as an MP4 or as one HTML page that plays the run in 3-D offline (``app.movie.html``), its frames
labelled with the run's own time; while it runs the button cancels it, and a second request is
refused with a sentence.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import viser

from app.web.host import Folder, PanelHost
from app.web.inputs import as_html, from_user, ok_html
from app.web.jobs import MOVIE_FRAME_LIMIT, JobBusy
from app.web.widgets import download_name, say
from sim.runtime.runner import Frame
from sim.scenes.building import scene_from_simulation

MOVIE_FORMATS = ("MP4 video", "HTML page (3-D, offline)")
"""What "Download a movie" makes: an MP4, or one HTML page (``app.movie.html``)."""


class RecordingFolder(Folder):
    name = "recording"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._failure_shown: str | None = None
        gui = host.server.gui
        recordings = host.recordings
        available = recordings.available()
        with gui.add_folder("Recording", expand_by_default=False):
            self.record_button = gui.add_button(
                "Start recording", icon=viser.Icon.PLAYER_RECORD, disabled=not available,
                hint=(f"record the run to {recordings.directory.name}/ on the server (rerun .rrd)"
                      if available else "the recorder (app.recording) is not installed"),
            )
            self.record_text = gui.add_html("")
            self.download_button = gui.add_button(
                "Download recording", icon=viser.Icon.DOWNLOAD, disabled=not available,
                hint="the .rrd just recorded (a running recording is stopped first) and its "
                "read-me, to your computer; open it with rerun")
            self.movie_format = gui.add_dropdown(
                "Movie as", MOVIE_FORMATS, initial_value=MOVIE_FORMATS[0],
                hint="MP4: a video for any player and slides; HTML page: one file that opens "
                "offline in any browser and plays the run in 3-D (turn, zoom, scrub), with its "
                "read-me")
            self.movie_button = gui.add_button(
                "Download a movie", icon=viser.Icon.MOVIE,
                hint="render the scene's run from the current state (its duration, at most "
                f"{MOVIE_FRAME_LIMIT} frames) to an MP4 or an HTML page on your computer: title, "
                "time, colour bar. Press again to cancel.")
            self.movie_text = gui.add_html("")

        @self.download_button.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            try:
                was_active = recordings.active
                name, content, readme = recordings.download()
                if was_active:
                    self._show_stopped(recordings.last_path)
            except Exception as error:  # nothing to send, or the file is unreadable
                say(self.record_text, error, "could not download")
                return
            event.client.send_file_download(name, content, save_immediately=True)
            if readme:
                event.client.send_file_download(Path(name).stem + "-readme.md",
                                                readme.encode(), save_immediately=True)
            self.record_text.content = ok_html(f"sent {name} ({len(content) / 1e6:.2g} MB)")

        @self.movie_button.on_click
        @from_user
        def _(event: viser.GuiEvent) -> None:
            jobs = recordings.jobs
            if jobs.running:
                if jobs.name == "movie":
                    jobs.cancel()
                    self.movie_text.content = as_html("cancelling…")
                    return
            client = event.client
            try:
                scene, start = host.control.runner.post(
                    lambda simulation: (scene_from_simulation(simulation),
                                        float(simulation.time))).result(timeout=30)
                suffix = ".html" if self.movie_format.value == MOVIE_FORMATS[1] else ".mp4"
                jobs.start("movie", lambda report: self._render(scene, report, start, suffix),
                           lambda result, error: self._movie_done(client, scene, result, error,
                                                                  suffix))
            except JobBusy as busy:
                say(self.movie_text, busy, "one at a time")
                return
            except Exception as error:  # a failed movie must not take the page down
                say(self.movie_text, error, "could not make the movie")
                return
            self.movie_button.label = "Cancel the movie"
            self.movie_button.icon = viser.Icon.PLAYER_STOP
            self.movie_text.content = as_html("rendering the movie…")

        @self.record_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:  # thread pool: starting takes a snapshot
            if self.record_button.disabled:
                return
            self.record_button.disabled = True
            try:
                if recordings.active:
                    path = recordings.stop()
                    self._show_stopped(path)
                else:
                    self.record_text.content = as_html("starting…")
                    scene = host.control.snapshot().result(timeout=30)
                    path = recordings.start(scene)
                    self._failure_shown = None
                    self.record_button.label = "Stop recording"
                    self.record_button.icon = viser.Icon.PLAYER_STOP
                    self.record_text.content = as_html(f"recording to {path.name}…")
            except Exception as error:  # a failed recording must not take the page down
                say(self.record_text, error, "could not record")
            finally:
                self.record_button.disabled = False

    def _show_stopped(self, path: Path | None) -> None:
        self.record_button.label = "Start recording"
        self.record_button.icon = viser.Icon.PLAYER_RECORD
        error = self.host.recordings.last_error
        if error:
            say(self.record_text, error, f"recording stopped ({path.name if path else ''})")
        else:
            self.record_text.content = ok_html(f"saved {path.name}" if path else "stopped")

    def _render(self, scene: Any, report: Any, start: float = 0.0, suffix: str = ".mp4"
                ) -> bytes:
        """The movie of ``scene`` (the run's state at ``start`` s) as MP4 or HTML bytes, made
        through a temporary file frame by frame; the progress is shown about twice a second
        (also while the run is paused)."""
        from app.movie import render_html, render_movie

        jobs = self.host.recordings.jobs
        shown = [0.0]

        def on_frame(done: int, planned: int) -> bool:
            going_on = report(done, planned)
            now = time.monotonic()
            if going_on and now - shown[0] > 0.5:
                shown[0] = now
                self.movie_text.content = as_html(jobs.status())
            return going_on

        with tempfile.TemporaryDirectory(prefix="page-movie-") as directory:
            if suffix == ".html":
                path = render_html(scene, Path(directory) / "movie.html", progress=False,
                                   max_frames=MOVIE_FRAME_LIMIT, on_frame=on_frame,
                                   start_time=start).path
            else:
                path = render_movie(scene, Path(directory) / "movie.mp4", progress=False,
                                    max_frames=MOVIE_FRAME_LIMIT, on_frame=on_frame,
                                    start_time=start)
            return path.read_bytes()

    def _movie_done(self, client: viser.ClientHandle, scene: Any, content: bytes | None,
                    error: BaseException | None, suffix: str = ".mp4") -> None:
        self.movie_button.label = "Download a movie"
        self.movie_button.icon = viser.Icon.MOVIE
        jobs = self.host.recordings.jobs
        if jobs.outcome == "cancelled":
            self.movie_text.content = as_html("movie cancelled")
        elif error is not None or content is None:
            say(self.movie_text, error or "no frames", "could not make the movie")
        else:
            name = download_name(scene.name) + suffix
            client.send_file_download(name, content, save_immediately=True)
            self.movie_text.content = ok_html(f"sent {name} ({len(content) / 1e6:.2g} MB)")

    def update(self, frame: Frame, now: float) -> None:
        """Show the movie's progress; stop a recording whose recorder failed (a full disk) and
        say why."""
        recordings = self.host.recordings
        failure = recordings.failure()
        if failure and failure != self._failure_shown:
            self._failure_shown = failure
            path = recordings.stop()
            self._show_stopped(path)
            say(self.record_text, failure, f"recording stopped ({path.name if path else ''})")
