"""One simulation's tree in a recording: its views, fed frame by frame.

A ``Track`` owns the views of one tree (``app.recording.layout.TreePaths``): the lattice
(``lattice.LatticeView``), the energy plots (``energy.EnergyView``), the field image
(``field.FieldView``), the probes and mode energies (``instruments``), and the tree's event log.
It logs each frame's time, follows changes of integrator, dt and parameters, and finishes the
views at the end.  All its methods run in the thread that logs frames (or at the end).
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
        self.modes = (instruments.ModeLog(self.paths, model, scales.energy, basis=modal_basis)
                      if plan.modes_every else None)
        self.probe_notes: list[str] = []
        """Markdown lines about the probes' spectra, filled by ``finish``."""
        self.finished = False

    def log_static(self) -> None:
        self.lattice.log_static(self.stream)
        self.energy.log_static(self.stream)
        if self.probes is not None:
            self.probes.log_static(self.stream)
        if self.screen is not None:
            self.screen.log_static(self.stream)

    def log_frame(self, frame: Frame) -> None:
        stream, plan = self.stream, self.plan
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
        self.energy.log_frame(stream, frame.energy, frame.energy_balance_error, frame.dt)
        if self.probes is not None:
            self.probes.log_frame(stream, frame.time, frame.positions)
        if self.screen is not None:
            self.screen.log_frame(stream, frame.time, frame.positions)
        if (self.modes is not None and frame.velocities is not None
                and self.frames_logged % plan.modes_every == 0):
            self.modes.log_frame(stream, frame.positions, frame.velocities)
        if plan.positions_every and self.frames_logged % plan.positions_every == 0:
            self.lattice.log_frame(stream, frame.positions, frame.strains)
        if self.field is not None:
            self.field.log_frame(stream, self.model, frame.positions, frame.velocities,
                                 frame.time)
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
        masses_changed = not np.array_equal(model.masses, self.model.masses)
        same_lattice = (model.nx, model.ny, model.dim) == (
            self.model.nx, self.model.ny, self.model.dim) and np.array_equal(
            model.rest_positions, self.model.rest_positions)
        self.model = model
        self.lattice.model = model
        if masses_changed:
            self.lattice.log_masses(self.stream)
        if model.driven:
            self.energy.add_driver(self.stream)
        if self.probes is not None and not same_lattice:
            self.probe_notes = self.probes.finish(self.stream, model.driver)
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
        self.stream.log(self.paths.log, rr.TextLog(text, level=level))

    def finish(self) -> None:
        self.set_last_time()
        if self.field is not None and not self.finished:
            self.field.finish(self.stream)
        if self.probes is not None and not self.finished:
            self.probe_notes = self.probes.finish(self.stream, self.model.driver)
        self.finished = True
