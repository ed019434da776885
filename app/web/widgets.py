"""What the page's folders share to show things: messages, numbers in sliders, download names.

* ``say`` shows an error (red) in a message area, or clears it;
* ``show_number`` shows a value in a slider, widening the slider's range when the value lies
  outside it (a scene's value is shown as it is, never rounded or clamped);
* ``Limits`` are the server's own limits of some sliders, widened the same way, so that a value
  the page shows is also a value the server accepts back;
* ``History`` keeps the values a plot shows against simulated time;
* ``PlotAxis`` gives a plot's value axis readable ticks: a unit with an SI prefix that puts the
  numbers between 1 and 1000 (or %, ppm, ppb for a ratio), a range that fits the data but spans
  at least 1 % of their size (the page's plots print at most three decimals, so a nearly flat
  line would else read "0.598, 0.598, 0.598"), and an axis wide enough for the longest tick
  label with its minus sign;
* ``download_name`` makes a harmless file name for the user's browser from a scene name;
* ``MATPLOTLIB_LOCK`` is held while a folder draws a matplotlib picture.
"""

from __future__ import annotations

import collections
import math
import threading
from typing import Any

import numpy as np

import sim
from app.web.inputs import InputRefused, number, warning_html
from app.web.recording import RecordingBusy

ERRORS = (InputRefused, sim.ModelError, sim.SceneError, ValueError, RecordingBusy)
"""What a refused user action raises; shown in the page, never a traceback."""

MATPLOTLIB_LOCK = threading.Lock()
"""Held while the page draws a matplotlib picture (the Modes folder's, the speed-vs-accuracy
study's): matplotlib is not thread-safe (its text layout shares one mathtext parser), and the
pictures are drawn in different background threads."""


def say(area: Any, error: BaseException | str | None, verb: str = "refused") -> None:
    """Show ``error`` in a message ``area`` (an HTML widget, red), or clear it (None)."""
    if error is None:
        area.content = ""
    else:
        area.content = warning_html(f"{verb}: {error}")


def show_number(handle: Any, value: float) -> None:
    """Show ``value`` in a slider or number box, widening its range if needed."""
    if value > handle.max:
        handle.max = value
    if value < handle.min:
        handle.min = value
    handle.value = value


class Limits:
    """The server's (low, high) limit of each named slider; ``show`` widens a limit to take a
    scene's value, ``check`` reads a slider's value from the page against its limit."""

    def __init__(self, limits: dict[str, tuple[float, float]],
                 low_open: tuple[str, ...] = (), sliders: dict[str, Any] | None = None) -> None:
        self._limits = dict(limits)
        self._low_open = low_open
        self._accepted: dict[str, float] = {
            key: float(handle.value) for key, handle in (sliders or {}).items()}
        """The last value of each slider that was shown or accepted (what the page shows back
        when a value is refused)."""

    def show(self, key: str, handle: Any, value: float) -> None:
        low, high = self._limits[key]
        self._limits[key] = (min(low, value), max(high, value))
        self._accepted[key] = value
        show_number(handle, value)

    def check(self, key: str, handle: Any, label: str) -> float:
        """``handle``'s value if it lies within the limit ``key``; else the slider shows its
        last accepted value again (on every page) and ``InputRefused`` says why."""
        low, high = self._limits[key]
        try:
            value = number(handle.value, label, low, high, low_open=key in self._low_open)
        except InputRefused:
            if key in self._accepted:
                handle.value = self._accepted[key]
            raise
        self._accepted[key] = value
        return value


class History:
    """Values against simulated time for a plot: one row of values per frame, the last ``length``
    frames; it starts again when the time goes back (a reset, a new scene)."""

    def __init__(self, length: int) -> None:
        self._times: collections.deque[float] = collections.deque(maxlen=length)
        self._rows: collections.deque[tuple[float, ...]] = collections.deque(maxlen=length)

    def __len__(self) -> int:
        return len(self._times)

    def clear(self) -> None:
        self._times.clear()
        self._rows.clear()

    def add(self, time: float, row: tuple[float, ...]) -> bool:
        """Add a frame's values at ``time`` (s; a frame at the same time again is left out).
        Returns whether the history started again."""
        restarted = bool(self._times) and time < self._times[-1]
        if restarted:
            self.clear()
        if not self._times or time > self._times[-1]:
            self._times.append(time)
            self._rows.append(row)
        return restarted

    def columns(self) -> tuple[np.ndarray, np.ndarray]:
        """(times (n,) s, values (values per row, n))."""
        return np.array(self._times), np.array(self._rows).T


PREFIXES = ((1e-12, "p"), (1e-9, "n"), (1e-6, "µ"), (1e-3, "m"), (1.0, ""), (1e3, "k"),
            (1e6, "M"), (1e9, "G"))
"""SI prefixes (factor, symbol) a plot's unit may take."""
RATIO_UNITS = ((1e-15, "×1e-15"), (1e-12, "×1e-12"), (1e-9, "ppb"), (1e-6, "ppm"), (1e-2, "%"))
"""Units (factor, name) of a plotted ratio (a relative error): per cent down to 1 %, then parts
per million (1 to 10 000 ppm), per billion, and powers of ten below."""
MIN_SPAN = 0.01
"""Least span of a plot's value axis, as a fraction of the largest value's size."""


def axis_range(values: np.ndarray, unit: str,
               prefixes: tuple[tuple[float, str], ...] = PREFIXES
               ) -> tuple[float, str, tuple[float, float]]:
    """(factor, unit shown, (low, high) in shown units) for plotting ``values`` (any shape, in
    ``unit``): the largest factor of ``prefixes`` (SI by default) not above the values' size, so
    that values / factor lie between 1 and 1000 in size (for SI prefixes); the range holds every finite value,
    spans at least ``MIN_SPAN`` of the largest size, and is rounded out to a round step so it moves
    seldom."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    size = float(np.abs(finite).max()) if finite.size else 0.0
    if size == 0.0:
        return 1.0, unit, (-1.0, 1.0)
    factor, prefix = prefixes[0]
    for candidate, symbol in prefixes:
        if size / candidate >= 1.0:
            factor, prefix = candidate, symbol
    low, high = float(finite.min()) / factor, float(finite.max()) / factor
    span = max(high - low, MIN_SPAN * size / factor)
    middle = (low + high) / 2
    low, high = middle - 0.55 * span, middle + 0.55 * span
    step = 10.0 ** math.floor(math.log10(span)) / 2
    low, high = math.floor(low / step) * step, math.ceil(high / step) * step
    if float(finite.min()) >= 0.0:
        low = max(low, 0.0)
    if float(finite.max()) <= 0.0:
        high = min(high, 0.0)
    return factor, prefix + unit, (low, high)


KEEP_RANGE = 2.5
"""A plot's value range stays while it is at most this many times the range its data need."""
MIN_AXIS_SIZE = 50
"""Least width (CSS px) of a plot's value axis (uPlot's own)."""


class PlotAxis:
    """A plot's value axis: its quantity, its unit with the prefix ``axis_range`` picks (from
    ``prefixes``: SI by default), its range, and a width that holds the longest tick label with
    its sign.  ``app.web.plots.LivePlot`` builds its plot with what ``layout`` says."""

    def __init__(self, quantity: str, unit: str, x_label: str,
                 prefixes: tuple[tuple[float, str], ...] = PREFIXES) -> None:
        self.quantity, self.unit, self.x_label, self.prefixes = quantity, unit, x_label, prefixes

    def axes(self, unit: str | None = None, size: int = MIN_AXIS_SIZE) -> tuple[dict, dict]:
        """The plot's (x axis, value axis) options."""
        shown = self.unit if unit is None else unit
        label = f"{self.quantity} ({shown})" if shown else self.quantity
        return ({"label": self.x_label}, {"label": label, "size": size})

    def layout(self, values: np.ndarray, current: tuple | None = None
               ) -> tuple[float, tuple[str, tuple[float, float], int]]:
        """(factor, (unit shown, (low, high), axis width px)) for plotting ``values`` / factor.
        The ``current`` layout stays while it holds the values in the same unit and its range is
        at most ``KEEP_RANGE`` times the one they need, so the axis moves seldom."""
        factor, unit, (low, high) = axis_range(values, self.unit, self.prefixes)
        if current is not None and current[0] == unit:
            (kept_low, kept_high) = current[1]
            finite = np.asarray(values, dtype=float)
            finite = finite[np.isfinite(finite)] / factor
            if (finite.size and kept_low <= finite.min() and finite.max() <= kept_high
                    and kept_high - kept_low <= KEEP_RANGE * (high - low)):
                return factor, current
        return factor, (unit, (low, high), axis_size(low, high))

    def empty_layout(self) -> tuple[str, tuple[float, float], int]:
        """The layout of a plot without data."""
        return self.layout(np.zeros(0))[1]


def tick_labels(low: float, high: float, count: int = 5) -> list[str]:
    """``count`` ticks across [low, high] as the page's plots print them (uPlot: at most three
    decimals, a minus sign kept)."""
    return [f"{tick:.3f}".rstrip("0").rstrip(".") for tick in np.linspace(low, high, count)]


def axis_size(low: float, high: float) -> int:
    """Width (CSS px) of a value axis whose ticks span [low, high]: the longest tick label (with
    its minus sign) at about 7 px a character (a thousands separator included), plus the tick
    marks and gap."""
    longest = max(len(label) for label in tick_labels(low, high, 9))
    return max(MIN_AXIS_SIZE, 7 * longest + 24)


def download_name(name: str) -> str:
    """A harmless download name (no suffix) from a scene name."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)[:60] or "scene"
