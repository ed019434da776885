"""What the page's folders share to show things: messages, numbers in sliders, download names.

* ``say`` shows an error (red) in a message area, or clears it;
* ``show_number`` shows a value in a slider, widening the slider's range when the value lies
  outside it (a scene's value is shown as it is, never rounded or clamped);
* ``Limits`` are the server's own limits of some sliders, widened the same way, so that a value
  the page shows is also a value the server accepts back;
* ``History`` keeps the values a plot shows against simulated time;
* ``download_name`` makes a harmless file name for the user's browser from a scene name;
* ``MATPLOTLIB_LOCK`` is held while a folder draws a matplotlib picture.
"""

from __future__ import annotations

import collections
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


def download_name(name: str) -> str:
    """A harmless download name (no suffix) from a scene name."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)[:60] or "scene"
