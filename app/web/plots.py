"""``LivePlot``: one line plot of the page that follows a run (energy, error, probes).

A uPlot in the page keeps its x range across data updates relative to the data it had (viser's
plot component); when the plot's options change (a new value axis: another unit or range) the
page builds the chart again, and the relative x range it carries over can leave the new chart
looking at a sliver of time before the data, drawing no line while the hover values still
change.  So a ``LivePlot`` never changes a shown plot's options: when its value axis needs
another unit or range (``app.web.widgets.PlotAxis``) or other lines, it removes the plot and adds
a new one in the same place (same folder, same order) with the data it shows; a reset empties it
the same way, so no time range of an old run stays.  Data updates in between only send data.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

import numpy as np

from app.web.widgets import PlotAxis

PADDING = (10, 24, 0, 0)
"""Space (CSS px: top, right, bottom, left) around a plot: the top tick's label is not cut."""
ENTERING = threading.Lock()
"""Held while a plot is added into its folder: a viser folder may be entered (``with folder``)
by one thread at a time, and a reset (the frame pump) and a new scene (a page's callback) may
rebuild plots at the same moment."""


class LivePlot:
    """A uPlot whose value axis ``axis`` keeps readable, made where it is constructed (like any
    ``gui.add_*``, inside ``folder``'s ``with`` block) and rebuilt in ``folder`` (a viser folder
    handle); ``handle`` is the viser plot shown now (its ``data`` and ``series`` are what the
    page has)."""

    def __init__(self, gui: Any, folder: Any, series: Sequence[dict], axis: PlotAxis,
                 aspect: float) -> None:
        self._gui, self._folder, self.axis, self._aspect = gui, folder, axis, aspect
        self.series = tuple(series)
        self.handle: Any = None
        self._lock = threading.RLock()
        self._layout = self.axis.empty_layout()
        self.handle = self._add(self._empty(), self._layout, order=None)

    def _empty(self) -> tuple[np.ndarray, ...]:
        return (np.zeros(0),) * len(self.series)

    def _add(self, data: tuple[np.ndarray, ...], layout: Any, order: float | None) -> Any:
        unit, (low, high), size = layout
        return self._gui.add_uplot(
            data=data, series=self.series, order=order, aspect=self._aspect, padding=PADDING,
            scales={"x": {"time": False}, "y": {"range": [low, high]}},
            axes=self.axis.axes(unit, size),
        )

    def _build(self, data: tuple[np.ndarray, ...], layout: Any) -> None:
        """Replace the plot by a new one (same place) showing ``data`` with value axis ``layout``."""
        with self._lock:
            order = self.handle.order
            self.handle.remove()
            with ENTERING, self._folder:
                self.handle = self._add(data, layout, order)
            self._layout = layout

    def set_series(self, series: Sequence[dict]) -> None:
        """Other lines (a uPlot's series are fixed when it is made): an empty plot with them."""
        with self._lock:
            self.series = tuple(series)
            self._build(self._empty(), self.axis.empty_layout())

    def clear(self) -> None:
        """No data (a reset, a new scene): empty axes, no time range of the old run."""
        with self._lock:
            if self.handle.data[0].size or self._layout != self.axis.empty_layout():
                self._build(self._empty(), self.axis.empty_layout())

    def show(self, x: np.ndarray, columns: Sequence[np.ndarray]) -> None:
        """Plot ``columns`` (one per line, in the axis's unit) against ``x``."""
        columns = [np.asarray(column, dtype=float) for column in columns]
        with self._lock:
            factor, layout = self.axis.layout(
                np.concatenate(columns) if columns else np.zeros(0), self._layout)
            data = (np.asarray(x, dtype=float), *(column / factor for column in columns))
            if layout != self._layout:
                self._build(data, layout)
            else:
                self.handle.data = data
