"""How a movie is made: ``MovieOptions`` (frame rate, length, size, colour, 3-D exaggeration, the
run's integrator and dt) and the colours a movie can show."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from app.colours import SCALES
from app.recording.options import DETAIL_LIMIT

COLOURS = ("displacement", "speed", "strain", "density")
"""What colours the picture: the signed displacement component (m), the speed |v| (m/s), the
strain of the springs minus the rest strain, the relative density change rho/rho_0 - 1."""
MAX_FRAMES = 1000
"""Frames of a movie at most, unless asked for more (``MovieOptions.frames``)."""
FRAMES_PER_SIMULATED_SECOND = 25
"""Frames of a movie per simulated second by default."""


@dataclasses.dataclass(frozen=True)
class MovieOptions:
    """How a movie is made.

    fps: movie frames per second.
    frames: movie frames (default: min(1000, 25 per simulated second, one per step));
        the movie lasts frames / fps seconds.
    duration: simulated seconds to show (default: the scene's duration; a recording: all of it).
    size: (width, height) in pixels; even numbers for MP4/WebM (odd ones are rounded down).
    colour: one of ``COLOURS`` (default: strain for small planar lattices, else displacement).
    scale: the colour scale policy, one of ``app.colours.SCALES`` (default: the quantity's
        scheme's, a log scale following the field's amplitude; "fixed" keeps the look-ahead's
        linear scale for the whole movie).
    exaggeration: 3-D: heights drawn this many times larger (default: typical height ~8 % of
        the width).
    integrator, dt: of a run from a scene (default: the scene's).
    progress: show a progress bar (tqdm) on stderr.
    """

    fps: float = 30.0
    frames: int | None = None
    duration: float | None = None
    size: tuple[int, int] = (1280, 720)
    colour: str | None = None
    scale: str | None = None
    exaggeration: float | None = None
    integrator: str | None = None
    dt: float | None = None
    progress: bool = True

    def checked(self) -> MovieOptions:
        width, height = self.size
        if not (160 <= width <= 7680 and 90 <= height <= 4320):
            raise ValueError(f"size must be between 160x90 and 7680x4320 pixels, got {width}x{height}")
        if not (math.isfinite(self.fps) and 1 <= self.fps <= 120):
            raise ValueError(f"fps must be between 1 and 120, got {self.fps}")
        if self.frames is not None and not 2 <= self.frames <= 100_000:
            raise ValueError(f"frames must be between 2 and 100000, got {self.frames}")
        if self.colour is not None and self.colour not in COLOURS:
            raise ValueError(f"colour must be one of {', '.join(COLOURS)}, got {self.colour!r}")
        if self.scale is not None and self.scale not in SCALES:
            raise ValueError(f"scale must be one of {', '.join(SCALES)}, got {self.scale!r}")
        return dataclasses.replace(self, size=(width - width % 2, height - height % 2))


def default_colour(model: Any) -> str:
    """Strain for small planar lattices (springs coloured), else the signed displacement."""
    return "strain" if model.n_particles <= DETAIL_LIMIT and model.dim == 2 else "displacement"
