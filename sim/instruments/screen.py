"""An intensity screen: the time-averaged squared displacement <u^2> along one column of the
lattice, averaged over whole periods of the drive, as a ripple tank's screen or a photographic
plate records it.

The screen watches a State (it never changes it): each ``observe(time, positions)`` adds
u^2 * (time since the last observation) for every particle of the column, and when a whole period
has passed the period's mean is kept.  ``intensity`` is the mean over the last ``periods`` whole
periods (m^2), so it follows a pattern that is still building up without flickering with the
phase of the wave inside a period.
"""

from __future__ import annotations

import collections
import math

import numpy as np

from sim.model.lattice import Model

COMPONENTS = ("x", "y", "z")


class IntensityScreen:
    """<u^2> (m^2) of displacement ``component`` along column ``column`` of ``model``, averaged
    over the last ``periods`` whole periods of ``period`` (s); shape (ny,), row 0 first."""

    def __init__(self, model: Model, column: int, component: str, period: float,
                 periods: int = 4) -> None:
        if not 0 <= column < model.nx:
            raise ValueError(f"the screen's column must be in 0..{model.nx - 1}, got {column}")
        if component not in COMPONENTS[: model.dim]:
            raise ValueError(f"component must be one of {', '.join(COMPONENTS[: model.dim])}")
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f"the period must be positive and finite, got {period!r}")
        self.column = column
        self.component = COMPONENTS.index(component)
        self.period = float(period)
        self.rows = np.arange(model.ny) * model.nx + column
        self.rest = model.rest_positions[self.rows, self.component].copy()
        self.spacing = model.spacing
        self._means: collections.deque[np.ndarray] = collections.deque(maxlen=max(1, periods))
        self._sum = np.zeros(model.ny)
        self._elapsed = 0.0
        self._last_time: float | None = None
        self.completed = 0
        """Whole periods completed since the start or the last ``reset``."""

    def observe(self, time: float, positions: np.ndarray) -> None:
        """Add the displacement at ``time`` (s) from ``positions`` ((n_particles, dim) m), held
        since the previous observation."""
        u = positions[self.rows, self.component] - self.rest
        if self._last_time is None:
            self._last_time = time
            return
        interval = time - self._last_time
        self._last_time = time
        if interval <= 0.0:
            return
        while interval > 0.0:
            take = min(interval, self.period - self._elapsed)
            self._sum += u * u * take
            self._elapsed += take
            interval -= take
            if self._elapsed >= self.period * (1.0 - 1e-12):
                self._means.append(self._sum / self._elapsed)
                self.completed += 1
                self._sum = np.zeros_like(self._sum)
                self._elapsed = 0.0

    @property
    def whole_periods(self) -> int:
        """How many whole periods the intensity is averaged over now (0 before the first)."""
        return len(self._means)

    @property
    def intensity(self) -> np.ndarray | None:
        """<u^2> (m^2) per row over the last whole periods, or None before the first one."""
        if not self._means:
            return None
        return np.mean(np.array(self._means), axis=0)

    def reset(self) -> None:
        """Forget everything observed (the pattern changed: a new source or barrier)."""
        self._means.clear()
        self._sum = np.zeros_like(self._sum)
        self._elapsed = 0.0
        self._last_time = None
        self.completed = 0
