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
MOVIE_BASE_BYTES = 330e6
"""Memory (bytes) a movie takes whatever the lattice (Python, numba, viser or the encoder)."""
MOVIE_BYTES_PER_PARTICLE = 700.0
"""Memory (bytes) a movie takes per particle: the simulation, its look-ahead for the colour
scale and the frames' fields (measured peaks: 493 MB at 500x500, 1,003 MB at 1000x1000 for an
HTML page, 946 MB for an MP4; the same for 1 s and 3 s of run)."""
MOVIE_MEMORY_LIMIT = 2 * 2**30
"""Most memory a movie may plan to take (bytes): a laptop's fair share; the frames show at most
``PICTURE_SIZE``-class pictures, so a larger lattice adds no detail to them."""


def movie_bytes(n_particles: int) -> float:
    """Memory (bytes) a movie of a lattice of ``n_particles`` takes at its peak."""
    return MOVIE_BASE_BYTES + MOVIE_BYTES_PER_PARTICLE * n_particles


def check_movie_memory(model: Any, available: float | None = None) -> None:
    """Refuse (``ValueError``, with the figures) a movie of ``model`` that would take more
    memory than ``MOVIE_MEMORY_LIMIT`` or than is available now, before anything runs."""
    from sim.model.limits import available_memory

    needed = movie_bytes(model.n_particles)
    available = available_memory() if available is None else available
    limit = MOVIE_MEMORY_LIMIT if available is None else min(MOVIE_MEMORY_LIMIT, available)
    if needed > limit:
        largest = int(math.sqrt(max(0.0, limit - MOVIE_BASE_BYTES) / MOVIE_BYTES_PER_PARTICLE))
        why = ("the limit of a movie" if limit == MOVIE_MEMORY_LIMIT else
               "the memory available now")
        raise ValueError(
            f"a movie of the {model.nx}x{model.ny} lattice would take about "
            f"{needed / 2**30:.1f} GB of memory ({MOVIE_BYTES_PER_PARTICLE:.0f} bytes per "
            f"particle), over {why} ({limit / 2**30:.1f} GB); a lattice of up to about "
            f"{largest}x{largest} fits (its pictures show no more detail than that)")


MAX_FRAMES = 1000
"""Frames of an MP4 or WebM movie at most, unless asked for more (``MovieOptions.frames``)."""
DEFAULTS = {"mp4": ((1280, 720), 30.0, MAX_FRAMES), "webm": ((1280, 720), 30.0, MAX_FRAMES),
            "gif": ((640, 360), 15.0, 300)}
"""Per movie kind: the default (width, height), frames per second and most frames.  A GIF
stores every pixel that changes in every frame, so its defaults keep the flagship's under 25 MB
(docs/recording.md, "Movies": measured by benchmarks/movie_memory.py)."""
FRAMES_PER_SIMULATED_SECOND = 25
"""Frames of a movie per simulated second by default."""


@dataclasses.dataclass(frozen=True)
class MovieOptions:
    """How a movie is made.

    fps: movie frames per second (default: 30; GIF 15).
    frames: movie frames (default: min(``max_frames``, 25 per simulated second, one per step));
        the movie lasts frames / fps seconds.
    max_frames: frames at most when ``frames`` is not given (default: 1000; GIF 300).
    duration: simulated seconds to show (default: the scene's duration; a recording: all of it).
    size: (width, height) in pixels (default 1280x720; GIF 640x360); even numbers (odd ones
        are rounded down).
    colour: one of ``COLOURS`` (default: strain for small planar lattices, else displacement).
    scale: the colour scale policy, one of ``app.colours.SCALES`` (default: the quantity's
        scheme's, a log scale following the field's amplitude; "fixed" keeps the look-ahead's
        linear scale for the whole movie).
    exaggeration: 3-D: heights drawn this many times larger (default: typical height ~8 % of
        the width).
    integrator, dt: of a run from a scene (default: the scene's).
    progress: show a progress bar (tqdm) on stderr.
    start_time: the simulated time (s) of a scene's initial state, for the frames' labels (a
        snapshot of a run at t = 66 s starts at 66 s, not at 0).
    """

    fps: float | None = None
    frames: int | None = None
    max_frames: int | None = None
    duration: float | None = None
    size: tuple[int, int] | None = None
    colour: str | None = None
    scale: str | None = None
    exaggeration: float | None = None
    integrator: str | None = None
    dt: float | None = None
    progress: bool = True
    start_time: float = 0.0

    def resolved(self, kind: str) -> MovieOptions:
        """These options with the defaults of a movie of ``kind`` (mp4, webm, gif) filled in."""
        size, fps, max_frames = DEFAULTS.get(kind, DEFAULTS["mp4"])
        return dataclasses.replace(self, size=self.size or size, fps=self.fps or fps,
                                   max_frames=self.max_frames or max_frames)

    def checked(self) -> MovieOptions:
        if self.size is None or self.fps is None or self.max_frames is None:
            return self.resolved("mp4").checked()
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
