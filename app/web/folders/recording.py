"""The page's "Recording" folder: record the live run on the server, or download a movie.

*Start recording* records the run into the server's recordings directory (``app.web.recording``
chooses the file name; nothing the page sends names a file) until *Stop recording*; a recorder
that fails (a full disk) is stopped and the folder says why.  *Download a movie* renders the
scene's run from the current state to an MP4 and sends it to the user's browser.
"""

from __future__ import annotations

from pathlib import Path

import viser

from app.web.host import Folder, PanelHost
from app.web.inputs import as_html, from_user, ok_html
from app.web.widgets import download_name, say
from sim.runner import Frame


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
                scene = host.control.snapshot().result(timeout=30)
                content = movie_bytes(scene, "mp4", progress=False)
                name = download_name(scene.name) + ".mp4"
                event.client.send_file_download(name, content, save_immediately=True)
                self.movie_text.content = ok_html(f"sent {name} ({len(content) / 1e6:.2g} MB)")
            except Exception as error:  # a failed movie must not take the page down
                say(self.movie_text, error, "could not make the movie")
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

    def update(self, frame: Frame, now: float) -> None:
        """Stop a recording whose recorder failed (a full disk) and say why."""
        recordings = self.host.recordings
        failure = recordings.failure()
        if failure and failure != self._failure_shown:
            self._failure_shown = failure
            path = recordings.stop()
            self._show_stopped(path)
            say(self.record_text, failure, f"recording stopped ({path.name if path else ''})")
