"""One simulation's tree in a recording: its views, fed frame by frame.

A ``Track`` owns the views of one tree (``app.recording.layout.TreePaths``): the lattice
(``lattice.LatticeView``), the energy plots (``energy.EnergyView``), the field image
(``field.FieldView``), the probes and mode energies (``instruments``), the screen
(``screen.ScreenLog``), and the tree's event log.  It logs each frame's time, follows changes of
integrator, dt and parameters, and hands each frame, each change and the end to every view
through one interface (``app.recording.views.RecordingView``).  All its methods run in the
thread that logs frames (or at the end).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import rerun as rr

import app.recording.instruments as instruments
from app.recording.energy import EnergyView
from app.recording.field import FieldView
from app.recording.lattice import LatticeView
from app.recording.layout import TreePaths, tree_paths
from app.recording.options import LoggingPlan
from app.recording.scales import ColourScales
from app.recording.screen import ScreenLog
from app.recording.views import RecordingView
from sim.model.lattice import Model
from sim.runtime.runner import Frame


class Track:
    """The tree ``name`` (None: the root) of ``stream`` for a simulation of ``model``.

    scales: the recording's fixed colour scales; field_scale: the field's colour scale (m or
    m/s) to start from, on ``field_policy`` (``app.colours.SCALES``); ``on_field_scale(stream,
    colour_scale)`` after each field frame (the colour bar follows it); exaggeration: display
    scale of heights (3-D); modal_basis: the lattice's normal modes
    (mode energies only)."""

    def __init__(
        self, stream: rr.RecordingStream, name: str | None, model: Model, plan: LoggingPlan,
        scales: ColourScales, *, field_scale: float, exaggeration: float, jpeg_quality: int = 80,
        raw_dtype: str = "float32", modal_basis: Any = None, field_policy: str = "fixed",
        on_field_scale: Any = None,
    ) -> None:
        self.stream = stream
        self.name = name
        self.paths: TreePaths = tree_paths(name)
        self.model = model
        self.plan = plan
        self.frames_logged = 0
        self.last_step: int | None = None
        self.last_time = 0.0
        self._integrator: str | None = None
        self._dt: float | None = None
        self.lattice = LatticeView(self.paths, model, plan, scales, exaggeration)
        self.energy = EnergyView(self.paths, name, driven=model.driven)
        self.field = (FieldView(self.paths.field, plan.field, plan.quantity, scales.axis,
                                field_scale, policy=field_policy, floor=1e-6 * model.spacing,
                                scale_entity=self.paths.field_scale,
                                on_scale=(None if on_field_scale is None
                                          else lambda scale: on_field_scale(stream, scale)),
                                jpeg_quality=jpeg_quality, raw_dtype=raw_dtype)
                      if plan.field else None)
        self.probes = (instruments.ProbeLog(self.paths, model, plan.probes)
                       if plan.probes else None)
        self.screen = (ScreenLog(self.paths, model, plan.screen)
                       if plan.screen is not None else None)
        self.modes = (instruments.ModeLog(self.paths, model, scales.energy, basis=modal_basis,
                                          every=plan.modes_every)
                      if plan.modes_every else None)
        self.views: list[RecordingView] = [
            view for view in (self.energy, self.probes, self.screen, self.modes, self.lattice,
                              self.field) if view is not None]
        """Every view of the tree, in the order each frame is logged."""
        self.notes: list[str] = []
        """Markdown lines for the read-me from the views that ended (the probes' spectra)."""
        self.finished = False

    def log_static(self) -> None:
        for view in self.views:
            view.log_static(self.stream)

    def log_frame(self, frame: Frame) -> None:
        stream = self.stream
        stream.set_time("step", sequence=frame.step)
        stream.set_time("sim_time", duration=frame.time)
        self.last_step, self.last_time = frame.step, frame.time
        if frame.model is not self.model:
            self._model_changed(frame.model)
        if frame.integrator != self._integrator or frame.dt != self._dt:
            start = "recording starts: " if self._integrator is None else ""
            self.event(f"{start}integrator {frame.integrator}, dt = {frame.dt:g} s", "INFO")
            stream.log(self.paths.integrator, rr.TextDocument(frame.integrator))
            self._integrator, self._dt = frame.integrator, frame.dt
        for view in self.views:
            view.log_frame(stream, frame, self.frames_logged)
        if frame.error:
            self.event(frame.error, "ERROR")
        self.frames_logged += 1

    def set_last_time(self) -> None:
        """Put the stream's clock back at this tree's last frame (for events and the end)."""
        if self.last_step is not None:
            self.stream.set_time("step", sequence=self.last_step)
            self.stream.set_time("sim_time", duration=self.last_time)

    def _model_changed(self, model: Model) -> None:
        self.event(f"parameters changed: {model.describe()}", "INFO")
        self.stream.log(self.paths.model, rr.TextDocument(model.describe()))
        same_lattice = (model.nx, model.ny, model.dim) == (
            self.model.nx, self.model.ny, self.model.dim) and np.array_equal(
            model.rest_positions, self.model.rest_positions)
        self.model = model
        for view in list(self.views):
            reason = view.model_changed(self.stream, model, same_lattice)
            if reason:
                self.notes += view.finish(self.stream)
                self.views.remove(view)
                self.event(reason, "WARN")

    def event(self, text: str, level: str = "INFO") -> None:
        """A text-log entry in this tree (call in the thread that logs frames, or at the end)."""
        self.stream.log(self.paths.log, rr.TextLog(text, level=level))

    def finish(self) -> None:
        self.set_last_time()
        if not self.finished:
            for view in self.views:
                self.notes += view.finish(self.stream)
        self.finished = True
