"""Record a running simulation into a rerun ``.rrd`` file, as a subscriber of ``sim.runner.Runner``.

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
* the file is written as ``NAME.rrd.partial`` and renamed to ``NAME.rrd`` by ``close()`` once
  rerun has flushed and closed it: a file under the final name is always complete;
* the path and the free disk space are checked in the constructor, before any step is run; an
  existing file is refused unless ``overwrite=True``;
* a write that fails during the run (disk full, I/O error) stops the recording: the runner
  detaches the recorder and calls its ``on_error``, which logs an ERROR entry if it still can,
  closes the file and gives it its final name, so what was written stays a readable ``.rrd``
  (``failure`` holds the error; ``close()`` raises ``RecordingError`` saying so).

What is logged depends on the lattice (see ``LoggingPlan`` and ``docs/recording.md``): small
lattices (at most ``DETAIL_LIMIT`` particles) get every particle and spring each frame; large
ones get a colour-mapped field image, positions only on request, no springs.
"""

from __future__ import annotations

import dataclasses
import functools
import os
import queue
import shutil
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from app.recording import field as fields
from app.recording import layout
from app.recording.layout import (
    ENERGY_TERMS,
    INTEGRATOR_COLOURS,
    SCENE_ENTITY,
    TERM_COLOURS,
    TreePaths,
)
from sim.model import Model
from sim.runner import Frame, Runner

APPLICATION_ID = "coupled_oscillators"
DETAIL_LIMIT = 2500
"""Lattices with at most this many particles (50x50) are logged particle by particle."""

QUANTITIES = ("displacement", "speed")
MIN_FREE_BYTES = 16 * 2**20
STRAIN_COLORMAP = "coolwarm"


class RecordingError(RuntimeError):
    """The recording cannot be made or went wrong (the message says why and what to do)."""


@dataclasses.dataclass(frozen=True)
class RecordingOptions:
    """What to log.  ``"auto"`` values are resolved per lattice by ``plan``.

    field: "auto" (none for small lattices; video if PyAV is installed, else jpeg, for large
        ones), "jpeg", "video", "raw" (float image, lossless) or "none".
    quantity: the field's quantity, "displacement" (|x - x_rest|, m) or "speed" (|v|, m/s).
    field_scale: value shown at the top of the colour map (m or m/s); None adapts it: the
        largest 99.9th percentile of the field seen so far (logged as ``settings/field_scale``).
    positions: "auto" (every frame for small lattices, never for large ones), "all", "none",
        or an integer N: every N-th recorded frame.
    detail_limit: the particle count up to which a lattice counts as small.
    jpeg_quality: 1-95; raw_dtype: "float32" or "float16".
    flush_every: frames between waits for the file writer (bounds memory).
    background: log in a worker thread fed by a bounded queue (default) instead of in the
        runner's thread (see the measurements in docs/recording.md).
    queue_frames: frames that may wait for the worker before the simulation is held back.
    """

    field: str = "auto"
    quantity: str = "displacement"
    field_scale: float | None = None
    positions: str | int = "auto"
    detail_limit: int = DETAIL_LIMIT
    jpeg_quality: int = 80
    raw_dtype: str = "float32"
    flush_every: int = 50
    background: bool = True
    queue_frames: int = 4

    def plan(self, model: Model) -> LoggingPlan:
        """Resolve the "auto" choices for this lattice; raises ValueError on bad options."""
        if self.field not in ("auto", "none", *fields.FIELD_MODES):
            raise ValueError(f"field must be auto, none, jpeg, video or raw, got {self.field!r}")
        if self.quantity not in QUANTITIES:
            raise ValueError(f"quantity must be displacement or speed, got {self.quantity!r}")
        if self.field_scale is not None and not self.field_scale > 0:
            raise ValueError(f"field scale must be positive, got {self.field_scale!r}")
        detailed = model.n_particles <= self.detail_limit
        if self.field == "auto":
            field_mode = None if detailed else ("video" if fields.video_available() else "jpeg")
        elif self.field == "none":
            field_mode = None
        else:
            field_mode = self.field
        positions_every = _positions_every(self.positions, detailed)
        return LoggingPlan(
            detailed=detailed,
            field=field_mode,
            quantity=self.quantity,
            positions_every=positions_every,
            springs=detailed and positions_every == 1,
        )


def _positions_every(positions: str | int, detailed: bool) -> int:
    if isinstance(positions, str) and positions.strip().isdigit():
        positions = int(positions)
    if positions == "auto":
        return 1 if detailed else 0
    if positions == "all":
        return 1
    if positions == "none":
        return 0
    if isinstance(positions, int) and not isinstance(positions, bool) and positions >= 1:
        return positions
    raise ValueError(f"positions must be auto, all, none or a whole number >= 1, got {positions!r}")


@dataclasses.dataclass(frozen=True)
class LoggingPlan:
    """What one tree logs: detailed (per particle) or not, field mode or None, positions every
    N-th recorded frame (0: never), spring strips or not."""

    detailed: bool
    field: str | None
    quantity: str
    positions_every: int
    springs: bool

    def describe(self) -> str:
        parts = []
        if self.positions_every == 1:
            parts.append("positions every frame")
        elif self.positions_every:
            parts.append(f"positions every {self.positions_every} frames")
        if self.springs:
            parts.append("springs coloured by strain")
        if self.field:
            parts.append(f"{self.quantity} field as {self.field} image")
        return ", ".join(parts) or "energies only"

    def estimated_bytes_per_frame(self, model: Model, jpeg_quality: int = 80) -> float:
        """A generous size estimate, for the disk-space check (measured values in the docs)."""
        total = 400.0  # energies, dt, timestamps
        if self.positions_every:
            total += model.n_particles * model.dim * 4 / self.positions_every
        if self.springs:
            total += model.n_springs * (2 * model.dim * 4 + 4 + 8 + 8)
        if self.field == "jpeg":
            total += model.n_particles * 0.2 * (1 + jpeg_quality / 50)
        elif self.field == "video":
            total += model.n_particles * 0.05
        elif self.field == "raw":
            total += model.n_particles * 4
        return total


def scene_document(scene: Any, model: Model, integrator: str, dt: float, plans: str) -> str:
    """The scene parameters as a markdown document (logged once, statically)."""
    lines = [f"# {scene.name}", "", scene.description, "", f"**{model.describe()}**", ""]
    lines += ["| parameter | value |", "| --- | --- |"]
    for key, value in model.parameters().items():
        lines.append(f"| {key} | {value} |")
    masses = model.masses
    mass_text = f"{masses.flat[0]:g}" if model.uniform_mass else (
        f"{masses.min():g} to {masses.max():g} (per particle: `lattice/particles:mass`)"
    )
    lines += [
        f"| mass (kg) | {mass_text} |",
        f"| particles | {model.n_particles} |",
        f"| springs | {model.n_springs} |",
        f"| integrator{'s' if ',' in integrator else ''} at start | {integrator} |",
        f"| dt at start (s) | {dt:g} |",
        "",
        f"Logged: {plans}.",
        "",
        "Particle p = j * nx + i (column i, row j, row 0 at the bottom); springs in "
        "`sim.Model.springs` order (horizontal row by row, then vertical column by column).",
    ]
    return "\n".join(lines)


class _Track:
    """One simulation's tree in the file: its static data and per-frame logging."""

    def __init__(
        self, recorder: Recorder, name: str | None, model: Model, plan: LoggingPlan
    ) -> None:
        self.recorder = recorder
        self.name = name
        self.paths: TreePaths = layout.tree_paths(name)
        self.model = model
        self.plan = plan
        self.frames_logged = 0
        self.last_step: int | None = None
        self.last_time = 0.0
        self._integrator: str | None = None
        self._dt: float | None = None
        self._scale = recorder.options.field_scale
        self._encoder: fields.FieldEncoder | None = (
            fields.make_field_encoder(
                plan.field, recorder.options.jpeg_quality, recorder.options.raw_dtype
            )
            if plan.field
            else None
        )
        self._strain_table: np.ndarray | None = None
        self._strain_scale = 0.0
        self.finished = False

    # --- static ---------------------------------------------------------------------------------

    def log_static(self) -> None:
        stream = self.recorder.stream
        model, paths = self.model, self.paths
        points = rr.Points3D if model.dim == 3 else rr.Points2D
        a = model.spacing
        if model.dim == 2:
            # Rerun's 2-D views draw y downwards; flip the lattice so row 0 is at the bottom.
            stream.log(paths.lattice, rr.Transform3D(mat3x3=np.diag([1.0, -1.0, 1.0])), static=True)
        else:
            stream.log(paths.root or "/", rr.ViewCoordinates.RIGHT_HAND_Y_UP, static=True)
        rest = np.asarray(model.rest_positions, dtype=np.float32)
        stream.log(paths.rest, points(rest, radii=0.04 * a, colors=(90, 90, 90)), static=True)
        stream.log(
            paths.anchors,
            points(np.asarray(model.anchor_positions, np.float32), radii=0.12 * a,
                   colors=(200, 200, 200)),
            static=True,
        )
        self._log_masses()
        if self.plan.springs:
            stream.log(
                paths.springs,
                rr.AnyValues(
                    first=model.springs[:, 0].astype(np.int32),
                    second=model.springs[:, 1].astype(np.int32),
                ),
                static=True,
            )
        for term in ENERGY_TERMS:
            label = f"{self.name} {term}" if self.name else term
            colour = TERM_COLOURS[term]
            if self.name and term == "total":
                colour = INTEGRATOR_COLOURS.get(self.name, colour)
            stream.log(
                paths.energy_term(term), rr.SeriesLines(names=label, colors=colour), static=True
            )
        stream.log(paths.dt, rr.SeriesLines(names=f"{self.name} dt" if self.name else "dt"),
                   static=True)

    def _log_masses(self) -> None:
        """Static radii/colours (detailed lattices) and per-particle masses (kg)."""
        model, stream = self.model, self.recorder.stream
        masses = model.masses.ravel()
        if self.plan.detailed:
            relative = (masses / masses.mean()) ** (1.0 / 3.0)
            radii = (0.18 * model.spacing * relative).astype(np.float32)
            if model.uniform_mass:
                colours = np.array([[70, 140, 230]], dtype=np.uint8)
            else:
                weight = (masses - masses.min()) / max(masses.max() - masses.min(), 1e-300)
                colours = np.stack(
                    [70 + 160 * weight, 140 - 40 * weight, 230 - 180 * weight], axis=1
                ).astype(np.uint8)
            stream.log(
                self.paths.particles,
                rr.Points2D.from_fields(radii=radii, colors=colours)
                if model.dim == 2
                else rr.Points3D.from_fields(radii=radii, colors=colours),
                rr.AnyValues(mass=masses),
                static=True,
            )
        else:
            archetype = rr.Points2D if model.dim == 2 else rr.Points3D
            stream.log(
                self.paths.particles,
                archetype.from_fields(radii=0.3 * model.spacing, colors=(70, 140, 230)),
                static=True,
            )
            if not model.uniform_mass:
                stream.log(self.paths.particles, rr.AnyValues(mass=masses), static=True)

    # --- per frame (worker thread) ---------------------------------------------------------------

    def log_frame(self, frame: Frame) -> None:
        stream = self.recorder.stream
        paths, plan = self.paths, self.plan
        stream.set_time("step", sequence=frame.step)
        stream.set_time("sim_time", duration=frame.time)
        self.last_step, self.last_time = frame.step, frame.time
        if frame.model is not self.model:
            self._model_changed(frame.model)
        if frame.integrator != self._integrator or frame.dt != self._dt:
            start = "recording starts: " if self._integrator is None else ""
            self.event(f"{start}integrator {frame.integrator}, dt = {frame.dt:g} s", "INFO")
            stream.log(paths.integrator, rr.TextDocument(frame.integrator))
            self._integrator, self._dt = frame.integrator, frame.dt
        stream.log(paths.dt, rr.Scalars(frame.dt))
        energy = frame.energy
        for term in ENERGY_TERMS:
            stream.log(paths.energy_term(term), rr.Scalars(float(getattr(energy, term))))
        if plan.positions_every and self.frames_logged % plan.positions_every == 0:
            positions = np.asarray(frame.positions, dtype=np.float32)
            archetype = rr.Points3D if self.model.dim == 3 else rr.Points2D
            stream.log(paths.particles, archetype(positions))
            if plan.springs and frame.strains is not None:
                self._log_springs(frame.positions, frame.strains)
        if self._encoder is not None:
            self._log_field(frame)
        if frame.error:
            self.event(frame.error, "ERROR")
        self.frames_logged += 1

    def set_last_time(self) -> None:
        """Put the worker's clock back at this tree's last frame (for events and the end)."""
        if self.last_step is not None:
            self.recorder.stream.set_time("step", sequence=self.last_step)
            self.recorder.stream.set_time("sim_time", duration=self.last_time)

    def _log_springs(self, positions: np.ndarray, strains: np.ndarray) -> None:
        model = self.model
        ends = np.concatenate([positions, model.anchor_positions]).astype(np.float32)
        strips = ends[model.springs]  # (n_springs, 2, dim)
        rest_strain = (model.spacing - model.rest_length) / model.rest_length
        deviation = strains - rest_strain
        if self._strain_table is None:
            self._strain_table = fields.colour_table(STRAIN_COLORMAP)
            # Fixed for the whole recording: the first frame's largest strain change.
            self._strain_scale = max(float(np.abs(deviation).max()), 1e-6)
            self.recorder.stream.log(
                self.paths.springs,
                rr.AnyValues(strain_colour_scale=self._strain_scale, rest_strain=rest_strain),
                static=True,
            )
        unit = np.clip(0.5 + 0.5 * deviation / self._strain_scale, 0.0, 1.0)
        colours = self._strain_table[(unit * 255).astype(np.uint8)]
        archetype = rr.LineStrips3D if model.dim == 3 else rr.LineStrips2D
        self.recorder.stream.log(
            self.paths.springs,
            archetype(strips, colors=colours, radii=0.04 * model.spacing),
            rr.AnyValues(strain=np.asarray(strains, dtype=np.float64)),
        )

    def _log_field(self, frame: Frame) -> None:
        model = self.model
        if self.plan.quantity == "speed":
            if frame.velocities is None:
                return
            vectors = frame.velocities
        else:
            vectors = frame.positions - model.rest_positions
        values = np.sqrt(np.einsum("ij,ij->i", vectors, vectors))
        image = fields.lattice_image(values, model.nx, model.ny)
        if self.recorder.options.field_scale is None:
            sample = values[:: max(1, values.size // 20000)]  # ~20k values suffice for a scale
            top = max(int(sample.size * 0.999) - 1, 0)
            percentile = float(np.partition(sample, top)[top]) if sample.size else 0.0
            self._scale = max(self._scale or 0.0, percentile, 1e-6 * model.spacing)
        assert self._scale is not None and self._encoder is not None
        self.recorder.stream.log(self.paths.field_scale, rr.Scalars(self._scale))
        self._encoder.log(self.recorder.stream, self.paths.field, image, self._scale)

    def _model_changed(self, model: Model) -> None:
        self.event(f"parameters changed: {model.describe()}", "INFO")
        self.recorder.stream.log(self.paths.model, rr.TextDocument(model.describe()))
        masses_changed = not np.array_equal(model.masses, self.model.masses)
        self.model = model
        if masses_changed:
            self._log_masses()

    def event(self, text: str, level: str = "INFO") -> None:
        """A text-log entry in this tree (call in the thread that logs frames, or at the end)."""
        self.recorder.stream.log(self.paths.log, rr.TextLog(text, level=level))

    def finish(self) -> None:
        self.set_last_time()
        if self._encoder is not None and not self.finished:
            self._encoder.finish(self.recorder.stream, self.paths.field)
        self.finished = True


_STOP = object()


class Recorder:
    """Writes one ``.rrd`` file from the frames of one or more runners.

    path: the final file name (``.rrd``); ``path + ".partial"`` is written meanwhile.
    scene: the ``sim.scenes.Scene`` being recorded (for the parameters document).
    trees: entity trees to lay out in the blueprint: ``(None,)`` for a single run at the root, or
        names such as ``("euler", "verlet", "rk4")`` for a comparison.
    expected_frames: if given, the free disk space is checked against an estimate.
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
        overwrite: bool = False,
    ) -> None:
        self.options = options or RecordingOptions()
        self.scene = scene
        self.model: Model = scene.model
        self.plan = self.options.plan(self.model)
        if self.plan.field == "video" and not fields.video_available():
            raise RecordingError("--field video needs PyAV: pip install av (or use --field jpeg)")
        self.trees = tuple(trees)
        self.path = Path(path)
        self.partial_path = self.path.with_name(self.path.name + ".partial")
        self._check_destination(expected_frames, overwrite)

        self.stream = rr.RecordingStream(APPLICATION_ID, recording_id=uuid.uuid4())
        bp = layout.blueprint(
            self.trees, dim=self.model.dim,
            show_lattice=self.plan.positions_every > 0, show_field=self.plan.field is not None,
        )
        self.stream.save(self.partial_path, default_blueprint=bp)
        self.stream.send_blueprint(bp, make_active=True, make_default=True)
        self.stream.send_recording_name(f"{scene.name}")
        integrator = integrator or scene.integrator
        dt = dt or scene.dt
        self.stream.log(
            SCENE_ENTITY,
            rr.TextDocument(
                scene_document(scene, self.model, integrator, dt, self.plan.describe()),
                media_type=rr.MediaType.MARKDOWN,
            ),
            static=True,
        )
        self.tracks: dict[str | None, _Track] = {}
        self._unsubscribers: list[Callable[[], None]] = []
        self._queue: queue.Queue = queue.Queue(maxsize=max(1, self.options.queue_frames))
        self._lock = threading.Lock()
        self._closed = False
        self._failure: BaseException | None = None
        self.frames_logged = 0
        self.logging_seconds = 0.0
        """Wall time spent logging frames (colour mapping, encoding, rerun calls; not flushes)."""
        self._since_flush = 0
        self._worker: threading.Thread | None = None
        if self.options.background:
            self._worker = threading.Thread(target=self._work, name="rrd-recorder", daemon=True)
            self._worker.start()

    # --- checks -----------------------------------------------------------------------------------

    def _check_destination(self, expected_frames: int | None, overwrite: bool) -> None:
        directory = self.path.parent
        if self.path.suffix != ".rrd":
            raise RecordingError(f"the recording file must end in .rrd, got {self.path}")
        if self.path.is_dir():
            raise RecordingError(f"{self.path} is a directory; give a file name ending in .rrd")
        if self.path.exists() and not overwrite:
            raise RecordingError(f"{self.path} already exists; use --force to replace it")
        try:
            directory.mkdir(parents=True, exist_ok=True)
            with open(self.partial_path, "wb"):
                pass
        except OSError as error:
            raise RecordingError(f"cannot write {self.partial_path}: {error.strerror}") from None
        needed = MIN_FREE_BYTES
        if expected_frames:
            per_frame = self.plan.estimated_bytes_per_frame(self.model, self.options.jpeg_quality)
            needed += int(1.2 * per_frame * expected_frames * len(self.trees))
        free = shutil.disk_usage(directory).free
        if free < needed:
            self.partial_path.unlink(missing_ok=True)
            raise RecordingError(
                f"not enough disk space in {directory}: the recording needs about "
                f"{needed / 2**20:.0f} MB, {free / 2**20:.0f} MB free "
                "(record fewer frames, use --every, or --field video)"
            )

    # --- attaching --------------------------------------------------------------------------------

    def attach(self, runner: Runner, tree: str | None = None, snapshot: bool = False) -> _Track:
        """Subscribe to ``runner``; its frames go to ``tree`` (None: the root).  With
        ``snapshot`` the current state is published at once (between steps, thread-safe)."""
        if self._closed:
            raise RecordingError("the recorder is closed")
        if tree in self.tracks:
            raise ValueError(f"tree {tree!r} is already attached")
        track = _Track(self, tree, runner.simulation.model, self.plan)
        track.log_static()
        self.tracks[tree] = track
        wants_velocities = self.plan.field is not None and self.plan.quantity == "speed"
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

    def add_tree(self, model: Model, tree: str | None = None) -> _Track:
        """A tree fed by ``record`` rather than by a runner."""
        track = _Track(self, tree, model, self.plan)
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

    def _enqueue(self, track: _Track, frame: Frame) -> None:
        if self._failure is not None:
            raise RecordingError(f"recording failed: {self._failure}") from self._failure
        with self._lock:
            if self._closed:
                return
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
                self.stream.flush(timeout_sec=120.0)
                self._check_space()
        except Exception as error:  # reported to the producer; Ctrl-C passes through
            self._failure = error

    def _submit(self, item: Any) -> None:
        """Hand an item to the worker (background) or log it now; the caller holds _lock."""
        if self._worker is not None:
            self._queue.put(item)
        else:
            self._process(item)

    def _check_space(self) -> None:
        free = shutil.disk_usage(self.path.parent).free
        if free < MIN_FREE_BYTES // 4:
            raise RecordingError(
                f"disk nearly full in {self.path.parent} ({free / 2**20:.1f} MB free)"
            )

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

    def close(self, interrupted: bool = False) -> Path:
        """Stop listening, log what is queued, flush, close the file and give it its final name.
        Returns the final path; raises ``RecordingError`` if writing failed (the file is kept,
        ending with an ERROR entry when that could still be written)."""
        with self._lock:
            if self._closed:
                if self._failure is not None:
                    raise RecordingError(
                        f"recording failed: {self._failure}; what was recorded is in {self.path}"
                    ) from self._failure
                return self.path
            if interrupted:
                for name in self.tracks:
                    self._submit(functools.partial(self._interrupted_event, name))
            for unsubscribe in self._unsubscribers:
                unsubscribe()
            for track in self.tracks.values():
                self._submit(track.finish)
            self._closed = True
        if self._worker is not None and self._worker is not threading.current_thread():
            self._queue.put(_STOP)
            self._worker.join()
        if self._failure is not None:
            self._log_failure()
        try:
            self.stream.flush(timeout_sec=120.0)
        except Exception:  # noqa: BLE001 - the file keeps what reached the disk
            if self._failure is None:
                raise
        finally:
            self.stream.disconnect()
        os.replace(self.partial_path, self.path)
        if self._failure is not None:
            raise RecordingError(
                f"recording failed: {self._failure}; what was recorded is in {self.path}"
            ) from self._failure
        return self.path

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

    def _interrupted_event(self, tree: str | None) -> None:
        track = self.tracks[tree]
        track.set_last_time()
        track.event("recording interrupted", "WARN")

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: Any, traceback: Any) -> None:
        self.close(interrupted=kind is not None and issubclass(kind, KeyboardInterrupt))
