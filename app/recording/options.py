"""What a recording logs: ``RecordingOptions`` (the caller's choices, "auto" allowed) resolved
per lattice into a ``LoggingPlan`` (what each tree logs, and a size estimate per frame).

Small planar lattices (at most ``DETAIL_LIMIT`` particles) get every particle and spring each
frame; small 3-D ones a surface mesh through the particles coloured by height (no springs); large
ones a colour-mapped field image, positions only on request, no springs.
"""

from __future__ import annotations

import dataclasses

import app.recording.instruments as instruments
from app.colours import SCALES, scheme
from app.recording.field import FIELD_MODES, video_available
from app.recording.scales import QUANTITIES
from app.recording.screen import check_screen
from sim.model.lattice import Model

DETAIL_LIMIT = 2500
"""Lattices with at most this many particles (50x50) are logged particle by particle (and drawn
as springs and particles in movies)."""
DEFAULT_FRAME_INTERVAL = 0.04
"""Simulated seconds between frames recorded from a live runner by default (25 per second)."""


@dataclasses.dataclass(frozen=True)
class RecordingOptions:
    """What to log.  ``"auto"`` values are resolved per lattice by ``plan``.

    field: "auto" (none for small lattices; video if PyAV is installed, else jpeg, for large
        ones), "jpeg", "video", "raw" (float image, lossless) or "none".
    quantity: the field's quantity, "displacement" (the signed component u_axis, m; diverging
        colours), "magnitude" (|x - x_rest|, m) or "speed" (|v|, m/s).
    field_scale: value at the end of the field's colour map (m or m/s) to start from; None: from
        the look-ahead run (``app.recording.scales``).
    field_policy: the field's colour-scale policy (``app.colours.SCALES``); None: ``fixed`` when
        ``field_scale`` is given, else the quantity's scheme's (``adaptive-symlog``: a log scale
        following the field's amplitude, as on the page and in movies).
    exaggeration: 3-D lattices: display scale of heights (z); None picks one so the typical
        height shows as 8 % of the lattice width.
    frame_interval: simulated seconds between recorded frames at least, for frames published
        while the runner plays (its own loop, e.g. the web app, which publishes a frame every
        step); sooner ones are skipped, never a blow-up frame.  None: ``DEFAULT_FRAME_INTERVAL``
        or the scene's duration / 1000, whichever is longer; 0: every frame.  Frames published
        by ``Runner.advance(steps, every=K)`` or ``publish()`` are all recorded (the caller
        chose them).
    positions: "auto" (every frame for small lattices, never for large ones), "all", "none",
        or an integer N: every N-th recorded frame.
    detail_limit: the particle count up to which a lattice counts as small.
    jpeg_quality: 1-95; raw_dtype: "float32" or "float16".
    flush_every: frames between waits for the file writer (bounds memory).
    background: log in a worker thread fed by a bounded queue (default) instead of in the
        runner's thread (see the measurements in docs/recording.md).
    queue_frames: frames that may wait for the worker before the simulation is held back.
    probes: (column, row) of particles whose displacement is recorded every frame, with their
        spectra at the end (``app.recording.instruments``).
    screen: column of an intensity screen (``app.recording.screen``), or None.
    modes: record the energy per normal mode (``sim.theory.modes.mode_energies``).
    modes_every: recorded frames between two mode-energy frames; None: as often as
        ``instruments.MODES_BUDGET_BYTES`` allows for the expected number of frames.
    """

    field: str = "auto"
    quantity: str = "displacement"
    field_scale: float | None = None
    field_policy: str | None = None
    exaggeration: float | None = None
    frame_interval: float | None = None
    positions: str | int = "auto"
    detail_limit: int = DETAIL_LIMIT
    jpeg_quality: int = 80
    raw_dtype: str = "float32"
    flush_every: int = 50
    background: bool = True
    queue_frames: int = 4
    probes: tuple[tuple[int, int], ...] = ()
    screen: int | None = None
    modes: bool = False
    modes_every: int | None = None

    def plan(self, model: Model, expected_frames: int | None = None) -> LoggingPlan:
        """Resolve the "auto" choices for this lattice (and, for mode energies, the expected
        number of frames); raises ValueError on bad options."""
        if self.field not in ("auto", "none", *FIELD_MODES):
            raise ValueError(f"field must be auto, none, jpeg, video or raw, got {self.field!r}")
        if self.quantity not in QUANTITIES:
            raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, got "
                             f"{self.quantity!r}")
        if self.field_policy is not None and self.field_policy not in SCALES:
            raise ValueError(f"field colour scale must be one of {', '.join(SCALES)}, got "
                             f"{self.field_policy!r}")
        if self.field_scale is not None and not self.field_scale > 0:
            raise ValueError(f"field scale must be positive, got {self.field_scale!r}")
        detailed = model.n_particles <= self.detail_limit
        if self.field == "auto":
            field_mode = None if detailed else ("video" if video_available() else "jpeg")
        elif self.field == "none":
            field_mode = None
        else:
            field_mode = self.field
        positions_every = _positions_every(self.positions, detailed)
        surface = detailed and model.dim == 3 and positions_every > 0
        probes = instruments.check_probes(self.probes, model)
        screen = check_screen(self.screen, model)
        if self.modes_every is not None and not (
                isinstance(self.modes_every, int) and self.modes_every >= 1):
            raise ValueError(f"modes_every must be a whole number >= 1, got {self.modes_every!r}")
        modes_every = 0
        if self.modes:
            modes_every = self.modes_every or instruments.modes_every(model, expected_frames)
        policy = self.field_policy or (
            "fixed" if self.field_scale is not None else scheme(self.quantity).scale)
        return LoggingPlan(
            detailed=detailed,
            field=field_mode,
            quantity=self.quantity,
            field_policy=policy,
            positions_every=positions_every,
            springs=detailed and positions_every == 1 and not surface,
            surface=surface,
            probes=probes,
            screen=screen,
            modes_every=modes_every,
        )


def _positions_every(positions: str | int, detailed: bool) -> int:
    if isinstance(positions, str) and positions.strip().isdigit():
        positions = int(positions)
    if positions == "auto":
        return 1 if detailed else 0
    if positions == "all":
        return 1
    if positions == "none":
        return 0
    if isinstance(positions, int) and not isinstance(positions, bool) and positions >= 1:
        return positions
    raise ValueError(f"positions must be auto, all, none or a whole number >= 1, got {positions!r}")


@dataclasses.dataclass(frozen=True)
class LoggingPlan:
    """What one tree logs: detailed (per particle) or not, field mode or None, positions every
    N-th recorded frame (0: never), spring strips or not (planar lattices), a surface mesh through
    the particles coloured by height instead of points and springs (3-D lattices); probes as
    (column, row); mode energies every N-th recorded frame (0: never)."""

    detailed: bool
    field: str | None
    quantity: str
    positions_every: int
    springs: bool
    surface: bool = False
    probes: tuple[tuple[int, int], ...] = ()
    modes_every: int = 0
    screen: int | None = None
    field_policy: str = "fixed"
    """The field's colour-scale policy (``app.colours.SCALES``)."""

    def describe(self) -> str:
        parts = []
        if self.surface:
            parts.append("a surface through the particles coloured by height (the positions "
                         "are its vertices)"
                         + ("" if self.positions_every == 1 else f", every {self.positions_every} "
                            "frames"))
        elif self.positions_every == 1:
            parts.append("positions every frame")
        elif self.positions_every:
            parts.append(f"positions every {self.positions_every} frames")
        if self.springs:
            parts.append("springs coloured by strain")
        if self.field:
            parts.append(f"{self.quantity} field as {self.field} image")
        if self.probes:
            parts.append("probes at " + ", ".join(f"({i}, {j})" for i, j in self.probes))
        if self.screen is not None:
            parts.append(f"intensity screen on column {self.screen}")
        if self.modes_every == 1:
            parts.append("mode energies every frame")
        elif self.modes_every:
            parts.append(f"mode energies every {self.modes_every} frames")
        return ", ".join(parts) or "energies only"

    def estimated_bytes_per_frame(self, model: Model, jpeg_quality: int = 80,
                                  modes: bool = True) -> float:
        """A size estimate a frame on disk (the measured sizes are in docs/recording.md); used for
        the disk-space check and to choose the default frame interval of ``record``.  ``modes``:
        include the mode energies (thinned to their own budget)."""
        total = 400.0  # energies, drift, dt, timestamps
        total += 150.0 * len(self.probes) * model.dim  # measured on resonance
        if modes and self.modes_every:
            total += instruments.mode_frame_bytes(model) / self.modes_every
        if self.positions_every:
            per_vertex = model.dim * 4 + (4 if self.surface else 0)
            total += model.n_particles * per_vertex / self.positions_every
        if self.springs:
            total += model.n_springs * (2 * model.dim * 4 + 4 + 4 + 4)
        if self.field == "jpeg":
            total += model.n_particles * 0.2 * (1 + jpeg_quality / 50)
        elif self.field == "video":
            # measured on interference: ~9.5 kB a frame on a fixed linear scale, ~2 kB at 100x60
            # (per-frame overhead); on a scale that follows the field (log) the whole lattice
            # shows its waves: ~26 kB a frame (H.264 at CRF 28, docs/recording.md "Sizes")
            detail = 0.1 if (SCALES[self.field_policy].follows
                             or SCALES[self.field_policy].logarithmic) else 0.04
            total += 1500.0 + model.n_particles * detail
        elif self.field == "raw":
            total += model.n_particles * 4
        return total
