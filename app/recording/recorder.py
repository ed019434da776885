"""Record a running simulation into a rerun ``.rrd`` file, as a subscriber of ``sim.runtime.runner.Runner``.

``sim`` knows nothing of rerun: the ``Recorder`` subscribes to a runner's frames and logs them.

    with Recorder("out.rrd", scene, expected_frames=1000) as recorder:
        recorder.attach(runner)                  # or attach(runner, tree="rk4") for comparisons
        runner.advance(1000, every=1, publish_first=True)

How it stays fast and safe:

* by default a worker thread does the colour mapping, encoding and rerun calls (a few ms to
  ~10 ms a frame for 682x383), overlapping the next steps on another core; the runner's callback
  only puts the frame on a small bounded queue, which slows the simulation down rather than
  letting memory grow when logging falls behind.  ``RecordingOptions(background=False)`` logs in
  the publishing thread instead (deterministic, and better when the simulation itself holds
  the cores);
* every ``flush_every`` frames the recorder waits for rerun to write what was logged to disk
  (``RecordingStream.flush``), so memory stays flat on long runs and an interrupted run has
  everything up to the last flush on disk;
* the file is written as ``NAME.rrd.partial`` (created exclusively, never through a link, see
  ``sim.storage.files.AtomicFile``) and renamed to ``NAME.rrd`` by ``close()`` once rerun has flushed
  and closed it: a file under the final name is always complete; rerun writes small messages,
  so a ``.partial`` left by a killed recorder reads back up to its last few frames
  (``destination.salvage``);
* the path and the free disk space are checked in the constructor, before any step is run; an
  existing file is refused unless ``overwrite=True``, a second recorder writing the same file
  is refused; the run stops while there is still room to end the file readably;
* a write that fails during the run (disk full, I/O error) stops the recording: the runner
  detaches the recorder and calls its ``on_error``, which logs an ERROR entry if it still can,
  closes the file and gives it its final name, so what was written stays a readable ``.rrd``
  (``failure`` holds the error; ``close()`` raises ``RecordingError`` saying so).

What is logged depends on the lattice (``app.recording.options.LoggingPlan``; the views of each
tree are written by ``app.recording.track.Track``).  Colour scales start from a look-ahead
run (``app.recording.scales``); the field's follows the field by default
(``app.recording.field``); the document at ``/scene`` (``app.recording.explain``) says what
every view shows, the colour bars are at ``/legend`` (``app.recording.legends``).
"""

from __future__ import annotations

import contextlib
import functools
import os
import queue
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import rerun as rr

import app.recording.destination as destination
import app.recording.instruments as instruments
from app.recording.destination import RecordingError
from app.recording.explain import RunInfo, scene_document
from app.recording.field import video_available
from app.recording.layout import COMPONENT_NAMES, LEGEND_ENTITY, SCENE_ENTITY, blueprint
from app.recording.legends import FieldLegend, colour_legends, field_label
from app.recording.options import DEFAULT_FRAME_INTERVAL, RecordingOptions
from app.recording.scales import ColourScales, look_ahead
from app.recording.style import nice_number
from app.recording.track import Track
from sim.model.lattice import Model
from sim.runtime.runner import Frame, Runner

APPLICATION_ID = "coupled_oscillators"

_SMALL_CHUNKS = rr.ChunkBatcherConfig(flush_num_bytes=256 * 1024, flush_tick=0.25)
"""rerun writes a message when 256 kB are batched or every 0.25 s: small messages, so a recorder
killed mid-write loses only its last few frames (the rest reads back, see ``destination``)."""

_STOP = object()


class Recorder:
    """Writes one ``.rrd`` file from the frames of one or more runners.

    path: the final file name (``.rrd``); ``path + ".partial"`` is written meanwhile.
    scene: the ``sim.scenes.Scene`` being recorded (for the parameters document).
    trees: entity trees to lay out in the blueprint: ``(None,)`` for a single run at the root, or
        names such as ``("euler", "verlet", "rk4")`` for a comparison.
    expected_frames: if given, the free disk space is checked against an estimate.
    integrator, dt: what the run uses at the start (default: the scene's), for the document and
        the look-ahead run that fixes the colour scales.
    run: ``RunInfo`` (planned steps, frame interval in steps, command line) for the document.
    scales: colour scales to use instead of a look-ahead run (``app.recording.scales``).
    overwrite: replace ``path`` if it exists (otherwise ``RecordingError``).
    Usable as a context manager; ``close()`` is idempotent and safe from any thread.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        scene: Any,
        *,
        options: RecordingOptions | None = None,
        trees: Sequence[str | None] = (None,),
        expected_frames: int | None = None,
        integrator: str | None = None,
        dt: float | None = None,
        run: RunInfo | None = None,
        scales: ColourScales | None = None,
        overwrite: bool = False,
    ) -> None:
        self.options = options or RecordingOptions()
        self.scene = scene
        self.model: Model = scene.model
        self.plan = self.options.plan(self.model, expected_frames)
        if self.plan.field == "video" and not video_available():
            raise RecordingError("--field video needs PyAV: pip install av (or use --field jpeg)")
        self.modal_basis: Any = None
        """The normal modes of the scene's lattice (mode energies only)."""
        if self.plan.modes_every:
            try:
                self.modal_basis = instruments.modal_basis(self.model)
            except ValueError as error:
                raise RecordingError(str(error)) from None
        self.trees = tuple(trees)
        self.path = Path(path)
        self.partial_path = destination.partial_path(self.path)
        per_frame = self.plan.estimated_bytes_per_frame(self.model, self.options.jpeg_quality)
        self._bytes_per_flush = per_frame * self.options.flush_every * len(self.trees)
        self.estimated_bytes = (destination.STATIC_BYTES
                                + per_frame * (expected_frames or 0) * len(self.trees))
        """The size the file is expected to reach (0 without ``expected_frames``)."""
        self._output = destination.open_destination(self.path, overwrite, self.estimated_bytes)
        integrator = integrator or scene.integrator
        dt = dt or scene.dt
        self.run = run or RunInfo()
        try:
            self.scales = scales or look_ahead(
                scene, integrator=integrator, dt=dt, quantity=self.plan.quantity,
                strains=self.plan.springs, energies=self.plan.modes_every > 0,
            )
        except BaseException:
            self._output.discard()
            raise
        self.field_scale = self.options.field_scale or self.scales.field
        self.field_policy = self.plan.field_policy
        """The field's colour-scale policy (``app.colours.SCALES``)."""
        exaggeration = self.options.exaggeration
        if exaggeration is None:
            width = (max(self.model.nx, self.model.ny) + 1) * self.model.spacing
            exaggeration = nice_number(0.08 * width / self.scales.height) if (
                self.model.dim == 3 and self.scales.height > 0) else 1.0
        self.exaggeration = max(1.0, float(exaggeration))
        interval = self.options.frame_interval
        self.frame_interval = (max(DEFAULT_FRAME_INTERVAL, scene.duration / 1000)
                               if interval is None else float(interval))

        try:
            self._start_stream(scene, integrator, dt)
        except BaseException as error:  # nothing was logged yet: leave no file behind
            stream = getattr(self, "stream", None)
            if stream is not None:
                with contextlib.suppress(Exception):
                    stream.disconnect()
            self._output.discard()
            explained = destination.explain_failure(error, self.path.parent)
            if explained is error:
                raise
            raise RecordingError(f"recording failed: {explained}; nothing was recorded") from error
        self.tracks: dict[str | None, Track] = {}
        self._last_enqueued: dict[str | None, float] = {}
        self._unsubscribers: list[Callable[[], None]] = []
        self._queue: queue.Queue = queue.Queue(maxsize=max(1, self.options.queue_frames))
        self._lock = threading.Lock()
        self._closed = False
        self._failure: BaseException | None = None
        self.writer_stuck = False
        """rerun's writer did not end when the file was closed (``destination.disconnect``)."""
        self.frames_logged = 0
        self.logging_seconds = 0.0
        """Wall time spent logging frames (colour mapping, encoding, rerun calls; not flushes)."""
        self._since_flush = 0
        self._worker: threading.Thread | None = None
        if self.options.background:
            self._worker = threading.Thread(target=self._work, name="rrd-recorder", daemon=True)
            self._worker.start()

    # --- attaching --------------------------------------------------------------------------------

    def _start_stream(self, scene: Any, integrator: str, dt: float) -> None:
        """Open the rerun stream on the ``.partial`` file and log what a recording starts with:
        the blueprint, the read-me at ``/scene`` and the colour bars."""
        self.recording_id = str(uuid.uuid4())
        self.stream = rr.RecordingStream(APPLICATION_ID, recording_id=self.recording_id,
                                         batcher_config=_SMALL_CHUNKS)
        legends = colour_legends(self.plan, self.scales, self.exaggeration)
        bp = blueprint(
            self.trees, dim=self.model.dim,
            show_lattice=self.plan.positions_every > 0, show_field=self.plan.field is not None,
            legends=len(legends), probes=bool(self.plan.probes),
            modes=COMPONENT_NAMES[: self.model.dim] if self.plan.modes_every else (),
            shares=bool(self.plan.modes_every) and instruments.shares_measured(self.model),
        )
        self.stream.save(self._output.library_path, default_blueprint=bp)
        self.stream.send_blueprint(bp, make_active=True, make_default=True)
        self.stream.send_recording_name(f"{scene.name}")
        self.document = scene_document(
            scene, self.model, integrator=integrator, dt=dt, plan=self.plan,
            scales=self.scales, run=self.run, trees=self.trees,
            exaggeration=self.exaggeration, field_policy=self.field_policy,
        ) + f"\n\nLogged: {self.plan.describe()}."
        """The read-me logged at ``/scene`` (logged again at the end with the probes' spectra)."""
        self.stream.log(
            SCENE_ENTITY, rr.TextDocument(self.document, media_type=rr.MediaType.MARKDOWN),
            static=True,
        )
        offset = 0.0
        for name, (png, height) in legends.items():
            entity = f"{LEGEND_ENTITY}/{name}"
            placed = rr.Transform3D(translation=[0.0, offset, 0.0])
            if png is None:  # the field's bar is logged frame by frame (FieldLegend)
                self.stream.log(entity, placed, static=True)
            else:
                self.stream.log(entity, rr.EncodedImage(contents=png, media_type="image/png"),
                                placed, static=True)
            offset += height + 8
        self.field_legend = (FieldLegend(f"{LEGEND_ENTITY}/field",
                                         field_label(self.plan, self.scales.axis),
                                         self.plan.quantity) if self.plan.field else None)
        """The field's colour bar, redrawn when the numbers of its scale change."""

    def attach(self, runner: Runner, tree: str | None = None, snapshot: bool = False) -> Track:
        """Subscribe to ``runner``; its frames go to ``tree`` (None: the root).  With
        ``snapshot`` the current state is published at once (between steps, thread-safe)."""
        if self._closed:
            raise RecordingError("the recorder is closed")
        if tree in self.tracks:
            raise ValueError(f"tree {tree!r} is already attached")
        track = self._add_track(runner.simulation.model, tree)
        wants_velocities = (self.plan.field is not None and self.plan.quantity == "speed"
                            or self.plan.modes_every > 0)
        self._unsubscribers.append(
            runner.subscribe(
                functools.partial(self._enqueue, track),
                strains=self.plan.springs, velocities=wants_velocities,
                on_error=self._subscriber_failed,
            )
        )
        if snapshot:
            runner.post(lambda simulation: runner.publish())
        return track

    def record(self, frame: Frame, tree: str | None = None) -> None:
        """Log one frame directly (without a runner); the tree must exist (see ``add_tree``)."""
        self._enqueue(self.tracks[tree], frame)

    def add_tree(self, model: Model, tree: str | None = None) -> Track:
        """A tree fed by ``record`` rather than by a runner."""
        return self._add_track(model, tree)

    def _add_track(self, model: Model, tree: str | None) -> Track:
        track = Track(
            self.stream, tree, model, self.plan, self.scales, field_scale=self.field_scale,
            exaggeration=self.exaggeration, jpeg_quality=self.options.jpeg_quality,
            raw_dtype=self.options.raw_dtype, modal_basis=self.modal_basis,
            field_policy=self.field_policy,
            on_field_scale=(self.field_legend.update if self.field_legend is not None
                            and not self.tracks else None),
        )
        track.log_static()
        self.tracks[tree] = track
        return track

    @property
    def failure(self) -> BaseException | None:
        """The error that stopped the recording (a failed write, a full disk), or None."""
        return self._failure

    def _subscriber_failed(self, error: BaseException) -> None:
        """The runner detached us because a callback raised: end the file cleanly now."""
        if self._failure is None:
            self._failure = error
        try:
            self.close()
        except (RecordingError, OSError):
            pass  # failure keeps the cause; the owner's close() reports it

    def _enqueue(self, track: Track, frame: Frame) -> None:
        if self._failure is not None:
            raise RecordingError(f"recording failed: {self._failure}") from self._failure
        with self._lock:
            if self._closed:
                return
            last = self._last_enqueued.get(track.name)
            if (frame.playing and last is not None and frame.error is None
                    and frame.time >= last
                    and frame.time - last < self.frame_interval * (1 - 1e-9)):
                return  # sooner than the frame interval: skipped
            self._last_enqueued[track.name] = frame.time
            self._submit((track, frame))

    # --- worker -----------------------------------------------------------------------------------

    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            self._process(item)

    def _process(self, item: Any) -> None:
        """Log one queued item: a (track, frame) pair or a callable (events, finishing)."""
        if self._failure is not None:
            return  # keep draining so producers never block
        try:
            if callable(item):
                item()
                return
            track, frame = item
            started = time.perf_counter()
            track.log_frame(frame)
            self.logging_seconds += time.perf_counter() - started
            self.frames_logged += 1
            self._since_flush += 1
            if self._since_flush >= self.options.flush_every:
                self._since_flush = 0
                destination.flush(self.stream, self.path.parent, self._bytes_per_flush)
                destination.check_space(self.path.parent, self._bytes_per_flush)
        except Exception as error:  # reported to the producer; Ctrl-C passes through
            self._failure = error

    def _submit(self, item: Any) -> None:
        """Hand an item to the worker (background) or log it now; the caller holds _lock."""
        if self._worker is not None:
            self._queue.put(item)
        else:
            self._process(item)

    # --- closing ----------------------------------------------------------------------------------

    def event(self, text: str, level: str = "INFO", tree: str | None = None) -> None:
        """Queue a text-log entry in ``tree`` at that tree's last recorded step."""
        track = self.tracks.get(tree)

        def log_event() -> None:
            if track is not None:
                track.set_last_time()
                track.event(text, level)
            else:
                self.stream.log("/log", rr.TextLog(text, level=level))

        with self._lock:
            if not self._closed:
                self._submit(log_event)

    def close(self, interrupted: bool = False, reason: str | None = None) -> Path:
        """Stop listening, log what is queued, flush, close the file and give it its final name.
        ``interrupted``: a WARN entry says the recording was interrupted; ``reason`` (such as
        ``"SIGTERM"``): an ERROR entry says the recording was stopped by it.
        Returns the final path; raises ``RecordingError`` if writing failed (the file is kept,
        ending with an ERROR entry when that could still be written)."""
        with self._lock:
            if self._closed:
                if self._failure is not None:
                    raise RecordingError(
                        f"recording failed: {self._failure}; what was recorded is in {self.path}"
                    ) from self._failure
                return self.path
            if interrupted or reason:
                for name in self.tracks:
                    self._submit(functools.partial(self._interrupted_event, name, reason))
            for unsubscribe in self._unsubscribers:
                unsubscribe()
            for track in self.tracks.values():
                self._submit(track.finish)
            if self.plan.probes or self.plan.modes_every:
                self._submit(self._log_probe_notes)
            self._closed = True
        if self._worker is not None and self._worker is not threading.current_thread():
            self._queue.put(_STOP)
            self._worker.join()
        if self._failure is not None:
            self._failure = destination.explain_failure(self._failure, self.path.parent)
            self._log_failure()
        try:
            destination.flush(self.stream, self.path.parent)
        except Exception as error:  # noqa: BLE001 - a write failed: the file is ended below
            if self._failure is None:
                self._failure = error
        finally:
            self.writer_stuck = not destination.disconnect(self.stream)
            if self.writer_stuck and self._failure is None:
                self._failure = RecordingError("rerun did not finish writing the file")
        if self._failure is not None:
            self._failure = destination.explain_failure(self._failure, self.path.parent)
            self._end_readably()
        self._output.commit()
        if self._failure is not None:
            raise RecordingError(
                f"recording failed: {self._failure}; what was recorded is in {self.path}"
            ) from self._failure
        return self.path

    def _log_probe_notes(self) -> None:
        """The read-me again, now with what the instruments found at the end: the probes'
        spectral peaks, a chain's returns of mode 1 (static: it replaces the first)."""
        lines: list[str] = []
        for name, track in self.tracks.items():
            if track.notes:
                lines += ([f"### {name}", ""] if name else []) + track.notes + [""]
        if not lines:
            return
        heading = ("Probes: spectra (computed at the end)" if self.plan.probes
                   else "Modes (computed at the end)")
        text = self.document + f"\n\n## {heading}\n\n" + "\n".join(lines)
        self.stream.log(SCENE_ENTITY, rr.TextDocument(text.rstrip(),
                                                      media_type=rr.MediaType.MARKDOWN),
                        static=True)

    def _log_failure(self) -> None:
        """An ERROR entry in every tree saying why the recording stopped, if it can be written."""
        text = f"recording stopped: {self._failure}"
        try:
            for track in self.tracks.values():
                track.set_last_time()
                track.event(text, "ERROR")
            if not self.tracks:
                self.stream.log("/log", rr.TextLog(text, level="ERROR"))
        except Exception:  # noqa: BLE001 - the disk may be full: the file ends where it ends
            pass

    def _end_readably(self) -> None:
        """After a failed write (a full disk) rerun's file may end inside a message: cut it at
        its last whole message and append the ERROR entries, so that it reads back."""
        try:
            entries = [(track.paths.log, track.last_step, track.last_time)
                       for track in self.tracks.values()] or [("/log", None, None)]
            destination.end_readably(self._output, APPLICATION_ID, self.recording_id,
                                     f"recording stopped: {self._failure}", entries)
        except Exception:  # noqa: BLE001 - no room at all: the file ends where it ends
            pass

    def _interrupted_event(self, tree: str | None, reason: str | None = None) -> None:
        track = self.tracks[tree]
        track.set_last_time()
        if reason:
            track.event(f"recording stopped by {reason}", "ERROR")
        else:
            track.event("recording interrupted", "WARN")

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: Any, traceback: Any) -> None:
        self.close(interrupted=kind is not None and issubclass(kind, KeyboardInterrupt))
