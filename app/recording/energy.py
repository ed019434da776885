"""The energy plots of one tree: the energy terms (J), the energy-balance error (%) and dt (s).

In a comparison every tree is named after its integrator: its lines are labelled with that name,
its balance error takes the integrator's colour and is also logged as log10 |error (%)| (the
integrators' errors lie orders of magnitude apart).
"""

from __future__ import annotations

import math

import rerun as rr

from app.recording.layout import DRIVEN_TERM, TreePaths, energy_terms
from app.recording.style import NEUTRAL_COLOUR, TERM_COLOURS, integrator_colour
from sim.model.lattice import Model
from sim.runtime.runner import Frame


class EnergyView:
    """Series lines of one tree (``name`` None for a single run at the root)."""

    def __init__(self, paths: TreePaths, name: str | None, driven: bool) -> None:
        self.paths = paths
        self.name = name
        self.terms = energy_terms(driven)

    def log_static(self, stream: rr.RecordingStream) -> None:
        for term in self.terms:
            self._log_term_line(stream, term)
        name = self.name
        drift_colour = integrator_colour(name)
        stream.log(
            self.paths.balance_error,
            rr.SeriesLines(names=f"{name or 'energy-balance'} error (%)", colors=drift_colour),
            static=True,
        )
        if name:
            stream.log(
                self.paths.log_balance_error,
                rr.SeriesLines(names=f"{name} log10 |error (%)|", colors=drift_colour),
                static=True,
            )
        stream.log(self.paths.dt,
                   rr.SeriesLines(names=f"{name} dt" if name else "dt",
                                  colors=drift_colour if name else NEUTRAL_COLOUR),
                   static=True)

    def add_driver(self, stream: rr.RecordingStream) -> None:
        """The scene gained a driver: its work joins the plot."""
        if DRIVEN_TERM not in self.terms:
            self.terms = energy_terms(True)
            self._log_term_line(stream, DRIVEN_TERM)

    def _log_term_line(self, stream: rr.RecordingStream, term: str) -> None:
        label = f"{self.name} {term}" if self.name else term
        stream.log(self.paths.energy_term(term),
                   rr.SeriesLines(names=label, colors=TERM_COLOURS[term]), static=True)

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        if model.driven:
            self.add_driver(stream)
        return None

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        return []

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """One frame: the energy terms (J), the relative balance error and the step dt (s)."""
        energy, balance_error, dt = frame.energy, frame.energy_balance_error, frame.dt
        stream.log(self.paths.dt, rr.Scalars(dt))
        for term in self.terms:
            stream.log(self.paths.energy_term(term), rr.Scalars(float(getattr(energy, term))))
        percent = 100.0 * float(balance_error)
        stream.log(self.paths.balance_error, rr.Scalars(percent))
        if self.name:  # comparisons: also on a log scale (orders of magnitude apart)
            stream.log(self.paths.log_balance_error,
                       rr.Scalars(math.log10(max(abs(percent), 1e-12))))
