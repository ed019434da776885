"""What the renderer draws from: a frame source and the states it yields.

A source (``app.movie.simulated.SimulationSource`` runs a scene, ``app.movie.recorded
.RecordingSource`` reads a ``.rrd`` file) gives the lattice (``model``), a ``scene`` for the
title, a one-line ``summary``, the number of ``frames``, the fixed colour ``scales(colour)`` and
the ``states(velocities, strains)`` to draw, one per frame.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any, Protocol

import numpy as np

from app.recording.scales import ColourScales


@dataclasses.dataclass
class State:
    """One frame's state: simulated time (s), positions (n_particles, dim) m, velocities (m/s)
    or None, strains (n_springs,) or None."""

    time: float
    positions: np.ndarray
    velocities: np.ndarray | None = None
    strains: np.ndarray | None = None


class FrameSource(Protocol):
    """Frames of a movie: ``frames`` states of ``model``, drawn on fixed colour scales."""

    model: Any
    scene: Any
    summary: str
    frames: int

    def scales(self, colour: str, watch: Any = None) -> ColourScales:
        """The fixed colour scales of the whole movie for ``colour`` (one of ``COLOURS``)."""
        ...

    def states(self, velocities: bool, strains: bool) -> Iterator[State]:
        """The states to draw, with velocities (m/s) and strains only when asked."""
        ...
