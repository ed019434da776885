"""The intensity screen in a recording: <u^2> (m^2) along one column, averaged over the last whole
periods of the drive (``sim.instruments.screen.IntensityScreen``), logged whenever another whole period has
passed.

* ``T/screen/intensity``: the profile along the screen as a bar chart (one bar per row, row 0
  first), the latest one at each time;
* ``T/screen/rows/<j>``: a time series of the intensity at each row where the fringe theory
  (``sim.scenes.ripple_tank``, lambda from the lattice's dispersion) puts a fringe, so the build-up of
  the bright and dark fringes is seen against time;
* ``T/screen/theory``: the theory lines as text (order, kind, y in m, row), logged once.

Scenes without a slit barrier get the profile alone (the rows series follow the middle row).
"""

from __future__ import annotations

from app.recording.layout import TreePaths
from app.recording.rerun_lazy import rr
from sim.instruments.screen import IntensityScreen
from sim.model.lattice import Model
from sim.runtime.runner import Frame

PERIODS = 4
"""Whole periods the screen averages over."""


def check_screen(column: int | None, model: Model) -> int | None:
    """The screen column inside the lattice (None: no screen); raises ValueError."""
    if column is None:
        return None
    if isinstance(column, bool) or not 0 <= int(column) < model.nx:
        raise ValueError(f"the screen column must be in 0..{model.nx - 1}, got {column!r}")
    if not model.driven:
        raise ValueError("an intensity screen needs a source or a driver (its period)")
    return int(column)


class ScreenLog:
    """The screen on ``column`` of one tree."""

    def __init__(self, paths: TreePaths, model: Model, column: int) -> None:
        from sim.scenes import ripple_tank

        drivers = ((model.driver,) if model.driver is not None else ()) + tuple(model.sources)
        driver = drivers[0]
        component = "xyz"[max(range(model.dim), key=lambda c: abs(driver.direction[c]))]
        self.paths = paths
        self.screen = IntensityScreen(model, column, component, 1.0 / driver.frequency, PERIODS)
        self.lines: list[str] = []
        rows: list[int] = []
        try:
            setup = ripple_tank.SlitSetup.of(model)
            _, y0 = model.origin
            for fringe in setup.theory(model, column):
                row = int(round((fringe.y - y0) / model.spacing))
                rows.append(row)
                self.lines.append(f"m = {fringe.order:+d} {fringe.kind}: y = {fringe.y:.3f} m "
                                  f"(row {row})")
        except (ripple_tank.SlitError, ValueError):
            rows = [model.ny // 2]
        self.rows = sorted(set(rows))
        self._periods = 0

    def log_static(self, stream: rr.RecordingStream) -> None:
        text = "\n".join(self.lines) or "no slit barrier: no theory lines"
        stream.log(self.paths.below("screen/theory"), rr.TextDocument(text), static=True)

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        return None

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        return []

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """Add a frame; log the profile and the fringe rows when a whole period has ended."""
        self.screen.observe(frame.time, frame.positions)
        if self.screen.completed == self._periods:
            return
        self._periods = self.screen.completed
        intensity = self.screen.intensity
        stream.log(self.paths.below("screen/intensity"), rr.BarChart(intensity))
        for row in self.rows:
            stream.log(self.paths.below(f"screen/rows/{row}"), rr.Scalars(float(intensity[row])))
