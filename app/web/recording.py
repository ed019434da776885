"""Recording the live run from the web page: one recording at a time, never losing a file.

``WebRecordings`` starts and stops an ``app.recording.Recorder`` subscribed to the app's runner.
Only one recording runs at a time (a second start while one is starting or running is refused),
every recording gets a new file name in the recordings directory chosen when the server started
(``<scene>-<date>-<time>.rrd``, with ``-2``, ``-3``… if that name is taken; nothing the page sends
names a file), and ``stop()`` (the page's button, the server stopping, Ctrl+C) closes the file so
that it verifies.  A recorder that fails (a full disk) is detached by the runner, closes its file
with an ERROR entry, and ``status()`` says so.  ``jobs`` (``app.web.jobs.PageJobs``) runs the
page's longer work (the movie download) one at a time; ``shutdown()`` ends it too.

``download()`` gives the bytes of the recording just made (or, while one runs, closes it first:
the current run's recording) and its read-me (the ``/scene`` document), for the page to send.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import sim
from app.web.jobs import PageJobs
from sim.runtime.runner import Runner
from sim.storage.files import partial_path, safe_name

SPACE_CHECK_SECONDS = 1.0
"""How often a running recording's free disk space is looked at (``failure``)."""


class RecordingBusy(RuntimeError):
    """A recording is already starting or running."""


class WebRecordings:
    """Start/stop recordings of ``runner`` into ``directory`` (created on the first start)."""

    def __init__(self, runner: Runner, directory: str | Path) -> None:
        self.runner = runner
        self.directory = Path(directory)
        self._lock = threading.Lock()
        self._starting = threading.Lock()
        self._closed = False
        self._recorder: Any = None
        self.last_path: Path | None = None
        self.last_error: str | None = None
        self.jobs = PageJobs()
        self._space_checked = 0.0

    @property
    def active(self) -> bool:
        return self._recorder is not None

    @staticmethod
    def available() -> bool:
        try:
            import app.recording  # noqa: F401
        except ImportError:
            return False
        return True

    def _free_name(self, scene_name: str) -> Path:
        stamp = time.strftime("%Y%m%d-%H%M%S")
        safe = safe_name(scene_name, limit=40)
        for number in range(1, 1000):
            suffix = "" if number == 1 else f"-{number}"
            path = self.directory / f"{safe}-{stamp}{suffix}.rrd"
            if not path.exists() and not partial_path(path).is_symlink() \
                    and not partial_path(path).exists():
                return path
        raise RecordingBusy(f"too many recordings named {safe}-{stamp}* in {self.directory}")

    def start(self, scene: sim.Scene) -> Path:
        """Start recording ``scene`` (a snapshot of the running state) now; returns the file
        path.  Raises ``RecordingBusy`` while another recording is starting or running, or once
        ``shutdown`` has begun."""
        from app.recording import Recorder

        if not self._starting.acquire(blocking=False):
            raise RecordingBusy("a recording is starting; wait a moment")
        try:
            if self._closed:
                raise RecordingBusy("the server is stopping")
            if self._recorder is not None:
                raise RecordingBusy("a recording is already running; stop it first")
            self.directory.mkdir(exist_ok=True)  # only the folder itself, never its parents
            path = self._free_name(scene.name)
            recorder = Recorder(path, scene, integrator=scene.integrator, dt=scene.dt)
            recorder.attach(self.runner, snapshot=True)
            with self._lock:
                self._recorder = recorder
            self.last_error = None
            return path
        finally:
            self._starting.release()

    def shutdown(self) -> Path | None:
        """Refuse new recordings, wait for one that is starting, and close the running one (the
        server is stopping).  Returns the closed file's path, or None."""
        with self._starting:
            self._closed = True
        self.jobs.shutdown()
        return self.stop()

    def failure(self) -> str | None:
        """Why the running recording stopped by itself (a failed write), or must stop (its disk
        is nearly full: looked at once a second, so the page says so within a second), or None."""
        recorder = self._recorder
        if recorder is None:
            return None
        error = getattr(recorder, "failure", None) or getattr(recorder, "_failure", None)
        if error is None and time.monotonic() - self._space_checked >= SPACE_CHECK_SECONDS:
            self._space_checked = time.monotonic()
            from app.recording.destination import RecordingError, check_space

            try:
                check_space(self.directory)
            except RecordingError as full:
                return str(full)
            except OSError:
                pass
        return None if error is None else str(error)

    def stop(self) -> Path | None:
        """Close the running recording (idempotent); returns its final path, or None if none
        was running.  A recording that failed is closed as far as it got; ``last_error`` says
        why."""
        with self._lock:
            recorder, self._recorder = self._recorder, None
        if recorder is None:
            return None
        try:
            self.last_path = recorder.close()
        except Exception as error:  # the file is renamed and readable; say what went wrong
            self.last_error = str(error)
            self.last_path = recorder.path
        return self.last_path

    def download(self) -> tuple[str, bytes, str]:
        """(file name, .rrd bytes, read-me markdown) of the last recording; a running one is
        closed first.  Raises ``FileNotFoundError`` with a sentence if there is none."""
        if self.active:
            self.stop()
        path = self.last_path
        if path is None or not path.is_file():
            raise FileNotFoundError("no recording yet: press Start recording, let it run, then "
                                    "Download recording")
        content = path.read_bytes()
        try:
            from app.movie.recorded import document_and_masses, read_chunks

            readme = document_and_masses(read_chunks(path), path)[0]
        except (ImportError, ValueError):
            readme = ""
        return path.name, content, readme
