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
planar lattices (at most ``DETAIL_LIMIT`` particles) get every particle and spring each frame;
small 3-D ones a surface mesh through the particles coloured by height (no springs); large ones a
colour-mapped field image, positions only on request, no springs.  Colour scales are fixed before
the first frame from a look-ahead run (``app.recording.scales``); the document at ``/scene``
(``app.recording.explain``) says what every view shows.  On request, probes (displacement series
of chosen particles, their spectra at the end) and mode energies (``app.recording.instruments``);
a driver's work joins the energy plot, a sponge layer is outlined.
"""

from __future__ import annotations

import dataclasses
import functools
import math
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
from app.recording import instruments, layout, style
from app.recording.explain import RunInfo, scene_document
from app.recording.layout import (
    COMPONENT_NAMES,
    DRIVEN_TERM,
    LEGEND_ENTITY,
    SCENE_ENTITY,
    TreePaths,
    energy_terms,
)
from app.recording.scales import AXIS_NAMES, QUANTITIES, UNITS, ColourScales, look_ahead
from sim.model import Model
from sim.runner import Frame, Runner

APPLICATION_ID = "coupled_oscillators"
DETAIL_LIMIT = 2500
"""Lattices with at most this many particles (50x50) are logged particle by particle."""

MIN_FREE_BYTES = 16 * 2**20
DEFAULT_FRAME_INTERVAL = 0.04
"""Simulated seconds between frames recorded from a live runner by default (25 per second)."""


class RecordingError(RuntimeError):
    """The recording cannot be made or went wrong (the message says why and what to do)."""


@dataclasses.dataclass(frozen=True)
class RecordingOptions:
    """What to log.  ``"auto"`` values are resolved per lattice by ``plan``.

    field: "auto" (none for small lattices; video if PyAV is installed, else jpeg, for large
        ones), "jpeg", "video", "raw" (float image, lossless) or "none".
    quantity: the field's quantity, "displacement" (the signed component u_axis, m; diverging
        colours), "magnitude" (|x - x_rest|, m) or "speed" (|v|, m/s).
    field_scale: value at the end of the field's colour map (m or m/s); None: fixed from the
        look-ahead run (``app.recording.scales``).
    exaggeration: 3-D lattices: display scale of heights (z); None picks one so the typical
        height shows as 8 % of the lattice width.
    frame_interval: simulated seconds between recorded frames at least, for frames published
        while the runner plays (its own loop, e.g. the web app, which publishes a frame every
        step); sooner ones are skipped, never a blow-up frame.  None: ``DEFAULT_FRAME_INTERVAL``
        or the scene's duration / 1000, whichever is longer; 0: every frame.  Frames published
        by ``Runner.advance(steps, every=K)`` or ``publish()`` are all recorded (the caller
        chose them).
    positions: "auto" (every frame for small lattices, never for large ones), "all", "none",
        or an integer N: every N-th recorded frame.
    detail_limit: the particle count up to which a lattice counts as small.
    jpeg_quality: 1-95; raw_dtype: "float32" or "float16".
    flush_every: frames between waits for the file writer (bounds memory).
    background: log in a worker thread fed by a bounded queue (default) instead of in the
        runner's thread (see the measurements in docs/recording.md).
    queue_frames: frames that may wait for the worker before the simulation is held back.
    probes: (column, row) of particles whose displacement is recorded every frame, with their
        spectra at the end (``app.recording.instruments``).
    modes: record the energy per normal mode (``sim.modes.mode_energies``).
    modes_every: recorded frames between two mode-energy frames; None: as often as
        ``instruments.MODES_BUDGET_BYTES`` allows for the expected number of frames.
    """

    field: str = "auto"
    quantity: str = "displacement"
    field_scale: float | None = None
    exaggeration: float | None = None
    frame_interval: float | None = None
    positions: str | int = "auto"
    detail_limit: int = DETAIL_LIMIT
    jpeg_quality: int = 80
    raw_dtype: str = "float32"
    flush_every: int = 50
    background: bool = True
    queue_frames: int = 4
    probes: tuple[tuple[int, int], ...] = ()
    modes: bool = False
    modes_every: int | None = None

    def plan(self, model: Model, expected_frames: int | None = None) -> LoggingPlan:
        """Resolve the "auto" choices for this lattice (and, for mode energies, the expected
        number of frames); raises ValueError on bad options."""
        if self.field not in ("auto", "none", *fields.FIELD_MODES):
            raise ValueError(f"field must be auto, none, jpeg, video or raw, got {self.field!r}")
        if self.quantity not in QUANTITIES:
            raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, got "
                             f"{self.quantity!r}")
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
        surface = detailed and model.dim == 3 and positions_every > 0
        probes = instruments.check_probes(self.probes, model)
        if self.modes_every is not None and not (
                isinstance(self.modes_every, int) and self.modes_every >= 1):
            raise ValueError(f"modes_every must be a whole number >= 1, got {self.modes_every!r}")
        modes_every = 0
        if self.modes:
            modes_every = self.modes_every or instruments.modes_every(model, expected_frames)
        return LoggingPlan(
            detailed=detailed,
            field=field_mode,
            quantity=self.quantity,
            positions_every=positions_every,
            springs=detailed and positions_every == 1 and not surface,
            surface=surface,
            probes=probes,
            modes_every=modes_every,
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
    N-th recorded frame (0: never), spring strips or not (planar lattices), a surface mesh through
    the particles coloured by height instead of points and springs (3-D lattices); probes as
    (column, row); mode energies every N-th recorded frame (0: never)."""

    detailed: bool
    field: str | None
    quantity: str
    positions_every: int
    springs: bool
    surface: bool = False
    probes: tuple[tuple[int, int], ...] = ()
    modes_every: int = 0

    def describe(self) -> str:
        parts = []
        if self.surface:
            parts.append("a surface through the particles coloured by height (the positions "
                         "are its vertices)"
                         + ("" if self.positions_every == 1 else f", every {self.positions_every} "
                            "frames"))
        elif self.positions_every == 1:
            parts.append("positions every frame")
        elif self.positions_every:
            parts.append(f"positions every {self.positions_every} frames")
        if self.springs:
            parts.append("springs coloured by strain")
        if self.field:
            parts.append(f"{self.quantity} field as {self.field} image")
        if self.probes:
            parts.append("probes at " + ", ".join(f"({i}, {j})" for i, j in self.probes))
        if self.modes_every == 1:
            parts.append("mode energies every frame")
        elif self.modes_every:
            parts.append(f"mode energies every {self.modes_every} frames")
        return ", ".join(parts) or "energies only"

    def estimated_bytes_per_frame(self, model: Model, jpeg_quality: int = 80,
                                  modes: bool = True) -> float:
        """A size estimate a frame on disk (the measured sizes are in docs/recording.md); used for
        the disk-space check and to choose the default frame interval of ``record``.  ``modes``:
        include the mode energies (thinned to their own budget)."""
        total = 400.0  # energies, drift, dt, timestamps
        total += 150.0 * len(self.probes) * model.dim  # measured on resonance
        if modes and self.modes_every:
            total += instruments.mode_frame_bytes(model) / self.modes_every
        if self.positions_every:
            per_vertex = model.dim * 4 + (4 if self.surface else 0)
            total += model.n_particles * per_vertex / self.positions_every
        if self.springs:
            total += model.n_springs * (2 * model.dim * 4 + 4 + 4 + 4)
        if self.field == "jpeg":
            total += model.n_particles * 0.2 * (1 + jpeg_quality / 50)
        elif self.field == "video":
            total += model.n_particles * 0.04  # measured: ~9.5 kB a frame of interference
        elif self.field == "raw":
            total += model.n_particles * 4
        return total


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
        self.scales: ColourScales = recorder.scales
        self.frames_logged = 0
        self.last_step: int | None = None
        self.last_time = 0.0
        self._integrator: str | None = None
        self._dt: float | None = None
        self._encoder: fields.FieldEncoder | None = (
            fields.make_field_encoder(
                plan.field, recorder.options.jpeg_quality, recorder.options.raw_dtype,
                signed=plan.quantity == "displacement",
            )
            if plan.field
            else None
        )
        self.terms = energy_terms(model.driver is not None)
        self.probes = (instruments.ProbeLog(self.paths, model, plan.probes)
                       if plan.probes else None)
        self.modes = (instruments.ModeLog(self.paths, model, recorder.scales.energy,
                                          basis=recorder.modal_basis)
                      if plan.modes_every else None)
        self.probe_notes: list[str] = []
        """Markdown lines about the probes' spectra, filled by ``finish``."""
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
            # The sheet lies flat, z up; heights exaggerated for display only.
            stream.log(paths.root or "/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
            stream.log(
                paths.lattice,
                rr.Transform3D(scale=[1.0, 1.0, self.recorder.exaggeration]),
                rr.AnyValues(height_exaggeration=self.recorder.exaggeration),
                static=True,
            )
        rest = np.asarray(model.rest_positions, dtype=np.float32)
        stream.log(paths.rest, points(rest, radii=0.04 * a, colors=style.NEUTRAL_COLOUR),
                   static=True)
        stream.log(
            paths.anchors,
            points(np.asarray(model.anchor_positions, np.float32), radii=0.12 * a,
                   colors=style.ANCHOR_COLOUR),
            static=True,
        )
        self._log_masses()
        if self.plan.springs:
            stream.log(
                paths.springs,
                rr.AnyValues(
                    first=model.springs[:, 0].astype(np.int32),
                    second=model.springs[:, 1].astype(np.int32),
                    strain_colour_scale=self.scales.strain,
                    rest_strain=self.scales.rest_strain,
                ),
                static=True,
            )
        if self.plan.surface:
            stream.log(
                paths.surface,
                rr.Mesh3D.from_fields(triangle_indices=_grid_triangles(model.nx, model.ny)),
                rr.AnyValues(height_colour_scale=self.scales.height),
                static=True,
            )
        for term in self.terms:
            self._log_energy_line(term)
        if self.probes is not None:
            self.probes.log_static(stream)
        instruments.log_sponge(stream, paths, model, lattice=self.plan.positions_every > 0,
                               field=self.plan.field is not None)
        if self.plan.positions_every:
            instruments.log_driver(stream, paths, model)
        drift_colour = (style.INTEGRATOR_COLOURS.get(self.name, style.DRIFT_COLOUR)
                        if self.name else style.DRIFT_COLOUR)
        stream.log(
            paths.balance_error,
            rr.SeriesLines(names=f"{self.name or 'energy-balance'} error (%)", colors=drift_colour),
            static=True,
        )
        if self.name:
            stream.log(
                paths.log_balance_error,
                rr.SeriesLines(names=f"{self.name} log10 |error (%)|", colors=drift_colour),
                static=True,
            )
        stream.log(paths.dt, rr.SeriesLines(names=f"{self.name} dt" if self.name else "dt",
                                            colors=drift_colour if self.name
                                            else style.NEUTRAL_COLOUR),
                   static=True)

    def _log_energy_line(self, term: str) -> None:
        label = f"{self.name} {term}" if self.name else term
        self.recorder.stream.log(
            self.paths.energy_term(term),
            rr.SeriesLines(names=label, colors=style.TERM_COLOURS[term]), static=True,
        )

    def _log_masses(self) -> None:
        """Static radii/colours (detailed lattices) and per-particle masses (kg)."""
        model, stream = self.model, self.recorder.stream
        masses = model.masses.ravel()
        if self.plan.detailed:
            relative = (masses / masses.mean()) ** (1.0 / 3.0)
            radii = (0.18 * model.spacing * relative).astype(np.float32)
            if model.uniform_mass:
                colours = np.array([style.PARTICLE_COLOUR], dtype=np.uint8)
            else:
                weight = (masses - masses.min()) / max(masses.max() - masses.min(), 1e-300)
                colours = np.stack(
                    [40 + 160 * weight, 110 - 40 * weight, 235 - 185 * weight], axis=1
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
                archetype.from_fields(radii=0.3 * model.spacing, colors=style.PARTICLE_COLOUR),
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
        for term in self.terms:
            stream.log(paths.energy_term(term), rr.Scalars(float(getattr(energy, term))))
        if self.probes is not None:
            self.probes.log_frame(stream, frame.time, frame.positions)
        if (self.modes is not None and frame.velocities is not None
                and self.frames_logged % plan.modes_every == 0):
            self.modes.log_frame(stream, frame.positions, frame.velocities)
        percent = 100.0 * float(frame.energy_balance_error)
        stream.log(paths.balance_error, rr.Scalars(percent))
        if self.name:  # comparisons: also on a log scale (orders of magnitude apart)
            stream.log(paths.log_balance_error,
                       rr.Scalars(math.log10(max(abs(percent), 1e-12))))
        if plan.positions_every and self.frames_logged % plan.positions_every == 0:
            positions = np.asarray(frame.positions, dtype=np.float32)
            if plan.surface:
                self._log_surface(positions)
            else:
                archetype = rr.Points3D if self.model.dim == 3 else rr.Points2D
                stream.log(paths.particles, archetype(positions))
            if plan.springs and frame.strains is not None:
                self._log_springs(positions, frame.strains)
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

    def _log_surface(self, positions: np.ndarray) -> None:
        """(n_particles, 3) float32 positions (m) as the mesh's vertices, coloured by height."""
        height = positions[:, 2] - self.model.rest_positions[:, 2]
        colours = style.map_values(height, -self.scales.height, self.scales.height,
                                   style.colour_table(style.SIGNED_LINES))
        self.recorder.stream.log(
            self.paths.surface,
            rr.Mesh3D.from_fields(vertex_positions=positions, vertex_colors=colours),
        )

    def _log_springs(self, positions: np.ndarray, strains: np.ndarray) -> None:
        """Springs as segments between (n_particles, dim) float32 positions (m) and the anchors,
        coloured by strain - rest strain on the fixed symmetric scale."""
        model = self.model
        ends = np.concatenate([positions, model.anchor_positions.astype(np.float32)])
        strips = ends[model.springs]  # (n_springs, 2, dim)
        scale = self.scales.strain
        colours = style.map_values(strains - self.scales.rest_strain, -scale, scale,
                                   style.colour_table(style.SIGNED_LINES))
        archetype = rr.LineStrips3D if model.dim == 3 else rr.LineStrips2D
        self.recorder.stream.log(
            self.paths.springs,
            archetype(strips, colors=colours, radii=0.04 * model.spacing),
            rr.AnyValues(strain=np.asarray(strains, dtype=np.float32)),
        )

    def _log_field(self, frame: Frame) -> None:
        model = self.model
        if self.plan.quantity == "speed" and frame.velocities is None:
            return
        from app.recording.scales import field_values

        values = field_values(self.plan.quantity, frame.positions, model.rest_positions,
                              frame.velocities, self.scales.axis)
        image = fields.lattice_image(values, model.nx, model.ny)
        assert self._encoder is not None
        self._encoder.log(self.recorder.stream, self.paths.field, image, self.recorder.field_scale)

    def _model_changed(self, model: Model) -> None:
        self.event(f"parameters changed: {model.describe()}", "INFO")
        self.recorder.stream.log(self.paths.model, rr.TextDocument(model.describe()))
        masses_changed = not np.array_equal(model.masses, self.model.masses)
        same_lattice = (model.nx, model.ny, model.dim) == (
            self.model.nx, self.model.ny, self.model.dim) and np.array_equal(
            model.rest_positions, self.model.rest_positions)
        self.model = model
        if masses_changed:
            self._log_masses()
        if model.driver is not None and DRIVEN_TERM not in self.terms:
            self.terms = energy_terms(True)
            self._log_energy_line(DRIVEN_TERM)
        if self.probes is not None and not same_lattice:
            self.probe_notes = self.probes.finish(self.recorder.stream, model.driver)
            self.probes = None
            self.event("probes stop here: the lattice changed shape or spacing", "WARN")
        if self.modes is not None:
            warning = (self.modes.model_changed(model) if same_lattice
                       else "mode energies stop here: the lattice changed shape or spacing")
            if warning:
                self.modes = None
                self.event(warning, "WARN")

    def event(self, text: str, level: str = "INFO") -> None:
        """A text-log entry in this tree (call in the thread that logs frames, or at the end)."""
        self.recorder.stream.log(self.paths.log, rr.TextLog(text, level=level))

    def finish(self) -> None:
        self.set_last_time()
        if self._encoder is not None and not self.finished:
            self._encoder.finish(self.recorder.stream, self.paths.field)
        if self.probes is not None and not self.finished:
            self.probe_notes = self.probes.finish(self.recorder.stream, self.model.driver)
        self.finished = True


def _grid_triangles(nx: int, ny: int) -> np.ndarray:
    """(2 (nx-1) (ny-1), 3) uint32 vertex indices: two triangles per lattice cell."""
    if nx < 2 or ny < 2:
        return np.zeros((0, 3), dtype=np.uint32)
    j, i = np.mgrid[0 : ny - 1, 0 : nx - 1]
    p = (j * nx + i).ravel()
    first = np.stack([p, p + 1, p + nx + 1], axis=1)
    second = np.stack([p, p + nx + 1, p + nx], axis=1)
    return np.concatenate([first, second]).astype(np.uint32)


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
        if self.plan.field == "video" and not fields.video_available():
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
        self.partial_path = self.path.with_name(self.path.name + ".partial")
        self._check_destination(expected_frames, overwrite)
        integrator = integrator or scene.integrator
        dt = dt or scene.dt
        self.run = run or RunInfo()
        try:
            self.scales = scales or look_ahead(
                scene, integrator=integrator, dt=dt, quantity=self.plan.quantity,
                strains=self.plan.springs, energies=self.plan.modes_every > 0,
            )
        except BaseException:
            self.partial_path.unlink(missing_ok=True)
            raise
        self.field_scale = self.options.field_scale or self.scales.field
        exaggeration = self.options.exaggeration
        if exaggeration is None:
            width = (max(self.model.nx, self.model.ny) + 1) * self.model.spacing
            exaggeration = style.nice_number(0.08 * width / self.scales.height) if (
                self.model.dim == 3 and self.scales.height > 0) else 1.0
        self.exaggeration = max(1.0, float(exaggeration))
        interval = self.options.frame_interval
        self.frame_interval = (max(DEFAULT_FRAME_INTERVAL, scene.duration / 1000)
                               if interval is None else float(interval))

        self.stream = rr.RecordingStream(APPLICATION_ID, recording_id=uuid.uuid4())
        legends = self._legends()
        bp = layout.blueprint(
            self.trees, dim=self.model.dim,
            show_lattice=self.plan.positions_every > 0, show_field=self.plan.field is not None,
            legends=len(legends), probes=bool(self.plan.probes),
            modes=COMPONENT_NAMES[: self.model.dim] if self.plan.modes_every else (),
        )
        self.stream.save(self.partial_path, default_blueprint=bp)
        self.stream.send_blueprint(bp, make_active=True, make_default=True)
        self.stream.send_recording_name(f"{scene.name}")
        self.document = scene_document(
            scene, self.model, integrator=integrator, dt=dt, plan=self.plan,
            scales=self.scales, run=self.run, trees=self.trees,
            exaggeration=self.exaggeration,
        ) + f"\n\nLogged: {self.plan.describe()}."
        """The read-me logged at ``/scene`` (logged again at the end with the probes' spectra)."""
        self.stream.log(
            SCENE_ENTITY, rr.TextDocument(self.document, media_type=rr.MediaType.MARKDOWN),
            static=True,
        )
        offset = 0.0
        for name, (png, height) in legends.items():
            self.stream.log(f"{LEGEND_ENTITY}/{name}", rr.EncodedImage(contents=png,
                            media_type="image/png"),
                            rr.Transform3D(translation=[0.0, offset, 0.0]), static=True)
            offset += height + 8
        self.tracks: dict[str | None, _Track] = {}
        self._last_enqueued: dict[str | None, float] = {}
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

    def _legends(self) -> dict[str, tuple[bytes, int]]:
        """Colour-bar PNGs (and their heights in pixels) for what this recording colours."""
        legends: dict[str, tuple[bytes, int]] = {}
        scales, plan = self.scales, self.plan
        if plan.springs:
            legends["strain"] = (style.legend_png(
                style.SIGNED_LINES, -scales.strain, scales.strain,
                "springs: strain - rest strain (dimensionless)",
                note="blue compressed, grey as at rest, red stretched"), 96)
        if plan.surface:
            legends["height"] = (style.legend_png(
                style.SIGNED_LINES, -scales.height, scales.height,
                f"surface: height z (m), drawn ×{self.exaggeration:g}",
                note="blue below the plane, red above"), 96)
        if plan.field:
            signed = plan.quantity == "displacement"
            label = (f"field: displacement u_{AXIS_NAMES[scales.axis]} (m)" if signed
                     else f"field: {plan.quantity} ({UNITS[plan.quantity]})")
            legends["field"] = (style.legend_png(
                style.SIGNED_FIELD if signed else style.MAGNITUDE,
                -self.field_scale if signed else 0.0, self.field_scale, label), 96)
        if plan.modes_every:
            legends["modes"] = (instruments.mode_legend_png(scales.energy), 96)
        return legends

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
                f"{needed / 1e6:.0f} MB, {free / 1e6:.0f} MB free "
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
                f"disk nearly full in {self.path.parent} ({free / 1e6:.1f} MB free)"
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
            if self.plan.probes:
                self._submit(self._log_probe_notes)
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

    def _log_probe_notes(self) -> None:
        """The read-me again, now with the probes' spectral peaks (static: it replaces the
        first)."""
        lines: list[str] = []
        for name, track in self.tracks.items():
            if track.probe_notes:
                lines += ([f"### {name}", ""] if name else []) + track.probe_notes + [""]
        if not lines:
            return
        text = self.document + "\n\n## Probes: spectra (computed at the end)\n\n" + "\n".join(lines)
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

    def _interrupted_event(self, tree: str | None) -> None:
        track = self.tracks[tree]
        track.set_last_time()
        track.event("recording interrupted", "WARN")

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, kind: type[BaseException] | None, value: Any, traceback: Any) -> None:
        self.close(interrupted=kind is not None and issubclass(kind, KeyboardInterrupt))
