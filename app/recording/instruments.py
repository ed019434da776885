"""Instruments in a recording: probes, mode energies, and the marks of a driver and a sponge.

* **Probes** (``--probe I,J``): the displacement from rest (m) of the particle in column I, row J,
  one time series per component that can move (x and y; z too in 3-D) at
  ``T/probes/<I>_<J>/<component>``, every recorded frame.  When the recording ends, the amplitude
  spectrum of each series (``sim.instruments.probes.spectrum``: Hann window, a sine of amplitude A reads A)
  is logged statically as a bar chart (m against Hz) at ``T/spectra/<I>_<J>/<component>``, and
  its strongest peaks, with the lattice's nearest normal-mode frequencies for equal masses
  (``sim.instruments.probes.nearest_modes``), go into the read-me.
* **Mode energies** (``--modes``): ``sim.theory.modes.mode_energies`` of a recorded frame, per
  polarisation, as a float32 tensor (J) at ``T/modes/<polarisation>/energy`` and as a heat map
  in log colour at ``T/modes/<polarisation>/image``.  They cost 7 bytes a mode and polarisation
  (4 for the tensor, 3 for the colours), so they are limited twice: lattices wider or taller than
  ``MODE_IMAGE_SIDE`` modes are summed over blocks of neighbouring modes (the sum is still the
  energy: each cell holds a band of modes), and they are logged every ``modes_every``-th
  recorded frame, chosen so that there are at most ``MODES_MAX_FRAMES`` of them and all of them
  together stay within ``MODES_BUDGET_BYTES``.
* **Driver and sponge**: a static marker on the driven particle's rest position, and a faint
  outline of the absorbing layer's inner edge (in the lattice view, and over the field image).

Nothing here steps a simulation; the recorder calls these from the thread that logs frames.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from app.colours import MAGNITUDE, Colour, map_values
from app.recording.layout import COMPONENT_NAMES, TreePaths, probe_label
from app.recording.rerun_lazy import rr
from app.recording.style import legend_png
from sim.instruments.mode_shares import ModeShares
from sim.model import boundaries
from sim.model.lattice import Model, ModelError
from sim.runtime.runner import Frame

MODE_IMAGE_SIDE = 128
"""Largest width and height (modes) of a mode-energy image; larger lattices are block-summed."""
MODES_BUDGET_BYTES = 2e6
"""The mode energies of a whole recording are thinned in time to stay within this (bytes)."""
MODES_MAX_FRAMES = 250
"""At most this many mode-energy frames by default: they change slowly (each is constant in an
undamped linear lattice), and each costs a few ms to compute and log."""
MODES_ASSUMED_FRAMES = 1000
"""Frames assumed when a recording does not know how many it will get (live recordings)."""
MODE_DECADES = 6
"""The log colour scale of the mode energies spans this many powers of ten."""
SPECTRUM_PEAKS = 3
"""Peaks of each probe's spectrum named in the read-me."""
NEAR_BINS = 3
"""A peak is attributed to a normal mode within this many frequency steps (1/T) of it."""
PROBE_COLOURS: tuple[Colour, ...] = (
    (220, 90, 30), (40, 110, 235), (30, 150, 60), (150, 70, 200), (200, 40, 140), (150, 120, 30),
)
"""Line colours of the probes' series, one per (probe, component) in turn (contrast >= 3 on both
themes, like the energy lines)."""
SPONGE_COLOUR = (128, 128, 128, 140)
DRIVER_COLOUR: Colour = (230, 120, 0)


# --- probes ----------------------------------------------------------------------------------------


def parse_probe(text: str) -> tuple[int, int]:
    """``"I,J"`` -> (column I, row J), whole numbers >= 0 (the lattice is checked later)."""
    try:
        column, row = (int(part) for part in text.split(","))
    except ValueError:
        raise ValueError(f"a probe is column,row (whole numbers from 0), got {text!r}") from None
    if column < 0 or row < 0:
        raise ValueError(f"a probe is column,row (whole numbers from 0), got {text!r}")
    return column, row


def check_probes(probes: Sequence[tuple[int, int]], model: Model) -> tuple[tuple[int, int], ...]:
    """The probes as (column, row) pairs inside the lattice, each once; raises ValueError."""
    checked: list[tuple[int, int]] = []
    for probe in probes:
        column, row = (int(value) for value in probe)
        if not (0 <= column < model.nx and 0 <= row < model.ny):
            raise ValueError(
                f"probe {column},{row} is outside the lattice: it has columns 0-{model.nx - 1} "
                f"and rows 0-{model.ny - 1}"
            )
        if (column, row) not in checked:
            checked.append((column, row))
    return tuple(checked)


class ProbeLog:
    """The probes of one tree: their series every frame, their spectra at the end."""

    def __init__(self, paths: TreePaths, model: Model, probes: Sequence[tuple[int, int]]) -> None:
        from sim.instruments.probes import ProbeSeries

        self.paths = paths
        self.model = model
        self.probes = tuple(probes)
        self.labels = [probe_label(column, row) for column, row in self.probes]
        self.components = COMPONENT_NAMES[: model.dim]
        particles = [row * model.nx + column for column, row in self.probes]
        self.series = ProbeSeries(model, particles)

    def colour(self, probe: int, component: int) -> Colour:
        return PROBE_COLOURS[(probe * len(self.components) + component) % len(PROBE_COLOURS)]

    def log_static(self, stream: rr.RecordingStream) -> None:
        for index, ((column, row), label) in enumerate(zip(self.probes, self.labels, strict=True)):
            for component, name in enumerate(self.components):
                stream.log(
                    self.paths.probe(label, name),
                    rr.SeriesLines(names=f"({column}, {row}) u_{name}",
                                   colors=self.colour(index, component)),
                    static=True,
                )

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """Log the probes' displacements (m) of a frame and keep them for the spectra."""
        positions = frame.positions
        self.series.add(frame.time, positions)
        displacement = np.asarray(positions)[self.series.particles] - self.series.rest
        for label, values in zip(self.labels, displacement, strict=True):
            for name, value in zip(self.components, values, strict=True):
                stream.log(self.paths.probe(label, name), rr.Scalars(float(value)))

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        """Probes follow particles of one lattice: another shape or spacing ends them."""
        if not same_lattice:
            return "probes stop here: the lattice changed shape or spacing"
        self.model = model
        return None

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        """Log each series' spectrum (static bar charts, m against Hz) and return markdown lines
        naming the peaks and the normal modes nearest to them (and the driver's frequency)."""
        driver = self.model.driver
        from sim.instruments.probes import dominant_frequencies, spectrum, uniform_series

        times = self.series.times
        if times.size < 3:
            return [f"* Probes: {times.size} recorded frame(s), too few for a spectrum."]
        displacements = self.series.displacements
        span = float(times[-1] - times[0])
        lines = [
            f"* Spectra of {times.size} frames over {span:.4g} s (resolution 1/T = "
            f"{1 / span:.3g} Hz, up to {0.5 * (times.size - 1) / span:.3g} Hz): bar charts "
            f"`spectra/<column>_<row>/<component>` (amplitude in m against frequency in Hz)."
        ]
        if driver is not None:
            lines.append(f"* The driver's frequency: {driver.frequency:.4g} Hz.")
        for index, ((column, row), label) in enumerate(zip(self.probes, self.labels, strict=True)):
            strongest = float(displacements[:, index, :].std(axis=0).max())
            for component, name in enumerate(self.components):
                values, interval = uniform_series(times, displacements[:, index, component])
                frequencies, amplitudes = spectrum(values, interval)
                stream.log(
                    self.paths.spectrum(label, name),
                    rr.BarChart(amplitudes.astype(np.float32), abscissa=frequencies,
                                color=self.colour(index, component)),
                    static=True,
                )
                if strongest <= 0 or values.std() < 1e-3 * strongest:
                    continue  # this component hardly moves: its peaks would be noise
                peaks = []
                for frequency, amplitude in dominant_frequencies(values, interval, SPECTRUM_PEAKS):
                    near = nearest_mode(self.model, frequency)
                    note = ""
                    if near and abs(near.frequency - frequency) <= NEAR_BINS / span:
                        note = f", normal mode {near.describe().removeprefix('mode ')}"
                    elif near:
                        note = (f"; no normal mode within {NEAR_BINS / span:.2g} Hz, the nearest "
                                f"is {near.describe()}: a harmonic or a combination?")
                    peaks.append(f"{frequency:.4g} Hz ({amplitude:.3g} m{note})")
                if peaks:
                    lines.append(f"* Probe ({column}, {row}), u_{name}: " + "; ".join(peaks) + ".")
        if not self.model.uniform_mass:
            lines.append("* Unequal masses: the normal modes are not sine waves, so no mode is "
                         "named beside the peaks.")
        return lines


def nearest_mode(model: Model, frequency: float) -> Any:
    """The normal mode (``sim.instruments.probes.ModeMatch``) whose frequency is closest to ``frequency``
    (Hz), for equal masses between walls (None otherwise)."""
    from sim.instruments.probes import nearest_modes

    found = nearest_modes(model, frequency)
    return found[0] if found else None


# --- mode energies ---------------------------------------------------------------------------------


def check_modes(model: Model) -> None:
    """Raise ValueError if the normal modes of ``model`` cannot be computed (unequal masses on
    more than ``sim.theory.modes.DENSE_PARTICLE_LIMIT`` particles), without computing them."""
    from sim.theory.modes import DENSE_PARTICLE_LIMIT

    if not model.uniform_mass and model.n_particles > DENSE_PARTICLE_LIMIT:
        raise ValueError(
            f"mode energies cannot be recorded for this lattice: the modes of an unequal-mass "
            f"lattice are computed up to {DENSE_PARTICLE_LIMIT:,} particles (dense "
            f"eigen-decomposition); this one has {model.n_particles:,}"
        )


def modal_basis(model: Model) -> Any:
    """``sim.theory.modes.ModalBasis`` of ``model``; raises ValueError saying why there is none."""
    from sim.theory.modes import ModalBasis

    try:
        return ModalBasis.of(model)
    except ModelError as error:
        raise ValueError(f"mode energies cannot be recorded for this lattice: {error}") from None


def mode_blocks(model: Model) -> tuple[int, int]:
    """(rows, columns) of modes summed into one cell of the mode-energy image."""
    return math.ceil(model.ny / MODE_IMAGE_SIDE), math.ceil(model.nx / MODE_IMAGE_SIDE)


def mode_image_shape(model: Model) -> tuple[int, int]:
    rows, columns = mode_blocks(model)
    return math.ceil(model.ny / rows), math.ceil(model.nx / columns)


def mode_frame_bytes(model: Model) -> float:
    """Estimated bytes on disk of one frame's mode energies (tensor + colours, all
    polarisations)."""
    height, width = mode_image_shape(model)
    return model.dim * (height * width * 7 + 300)


def modes_every(model: Model, expected_frames: int | None) -> int:
    """Recorded frames between two mode-energy frames: at most ``MODES_MAX_FRAMES`` of them,
    together within ``MODES_BUDGET_BYTES``."""
    frames = expected_frames or MODES_ASSUMED_FRAMES
    return max(1, math.ceil(frames / MODES_MAX_FRAMES),
               math.ceil(frames * mode_frame_bytes(model) / MODES_BUDGET_BYTES))


def modes_reserve_bytes(model: Model) -> float:
    """What a recording's mode energies take at most (bytes): their budget, or less when even
    ``MODES_MAX_FRAMES`` of them are smaller (``record`` keeps this out of its size budget)."""
    return min(MODES_BUDGET_BYTES, MODES_MAX_FRAMES * mode_frame_bytes(model))


def block_sum(values: np.ndarray, rows: int, columns: int) -> np.ndarray:
    """(ny, nx) -> sums over blocks of ``rows`` x ``columns`` (the last blocks may be partial)."""
    if rows == 1 and columns == 1:
        return values
    ny, nx = values.shape
    padded = np.zeros((math.ceil(ny / rows) * rows, math.ceil(nx / columns) * columns))
    padded[:ny, :nx] = values
    height, width = padded.shape[0] // rows, padded.shape[1] // columns
    return padded.reshape(height, rows, width, columns).sum(axis=(1, 3))


def mode_colour_range(top_energy: float) -> tuple[float, float]:
    """(bottom, top) energies (J) of the log colour scale: ``MODE_DECADES`` powers of ten below
    the look-ahead's largest kinetic + spring energy."""
    top = max(float(top_energy), 1e-30)
    return top * 10.0**-MODE_DECADES, top


def mode_legend_png(top_energy: float) -> bytes:
    bottom, top = mode_colour_range(top_energy)
    return legend_png(
        MAGNITUDE, math.log10(bottom), math.log10(top), "modes: log10 energy per mode (J)",
        note="columns m = 1, 2, ... (half-waves along x), rows n = 1, 2, ... upwards",
    )


def shares_measured(model: Model) -> bool:
    """Whether a recording of ``model``'s modes also has the lines of the shares of modes 1-4
    (a chain of equal masses between walls: ``sim.instruments.mode_shares``)."""
    return model.ny == 1 and model.uniform_mass and model.row_ends == "walls"


SHARE_COLOURS = ((31, 119, 180), (214, 39, 40), (44, 160, 44), (148, 103, 189))
"""Colours of modes 1-4's share lines (as on the page's Modes folder)."""


class ModeLog:
    """The mode energies of one tree: a tensor and a log-colour heat map per polarisation; on a
    chain (``shares_measured``) also the share of modes 1-4 of the harmonic energy, every
    frame, and mode 1's returns, marked at the end."""

    def __init__(self, paths: TreePaths, model: Model, top_energy: float, basis: Any = None,
                 every: int = 1) -> None:
        self.paths = paths
        self.every = every
        """Frames between two frames of mode energies."""
        self.polarisations = COMPONENT_NAMES[: model.dim]
        self.bottom, self.top = mode_colour_range(top_energy)
        self.model = model
        self.basis = basis if basis is not None else modal_basis(model)
        self.shares = ModeShares(model, len(SHARE_COLOURS)) if shares_measured(model) else None

    def log_static(self, stream: rr.RecordingStream) -> None:
        """The share lines' names and colours (the heat maps' legend is the recording's,
        ``mode_legend_png``)."""
        if self.shares is None:
            return
        for mode, colour in enumerate(SHARE_COLOURS, 1):
            stream.log(self.paths.mode_share(mode),
                       rr.SeriesLines(names=f"mode {mode}", colors=[colour]), static=True)
        stream.log(self.paths.mode_share("returns"),
                   rr.SeriesPoints(names="mode 1 back", colors=[(0, 0, 0)], marker_sizes=[6.0]),
                   static=True)

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        """Mode 1's returns, each marked at its time, and a note saying them."""
        if self.shares is None or not self.shares.times.size:
            return []
        returns = self.shares.recurrences()
        for back in returns:
            stream.set_time("sim_time", duration=back.time)
            stream.log(self.paths.mode_share("returns"), rr.Scalars(back.share))
        stream.set_time("sim_time", duration=float(self.shares.times[-1]))
        if not returns:
            return ["mode 1's energy did not come back within the recording"]
        return ["mode 1's energy came back: " + ", ".join(
            f"{back.share:.1%} at {back.periods:.1f} periods of mode 1 (t = {back.time:,.0f} s)"
            for back in returns)]

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        """Recompute the modes for new parameters; a reason to stop if that is impossible (the
        lattice changed shape or spacing, or its modes cannot be found)."""
        if not same_lattice:
            return "mode energies stop here: the lattice changed shape or spacing"
        self.model = model
        try:
            self.basis = modal_basis(model)
        except ValueError as error:  # the track drops this view
            return f"mode energies stop here: {error}"
        return None

    def energies(self, positions: np.ndarray, velocities: np.ndarray) -> list[np.ndarray]:
        """Per polarisation the (ny', nx') float64 energies (J) the file holds: [n-1, m-1] for
        mode (m, n) with equal masses, modes in rising frequency row by row otherwise; summed
        over blocks for lattices larger than ``MODE_IMAGE_SIDE``."""
        from sim.theory.modes import mode_energies

        model = self.model
        rows, columns = mode_blocks(model)
        return [
            block_sum(np.asarray(values).reshape(model.ny, model.nx), rows, columns)
            for values in mode_energies(model, positions, velocities, self.basis)
        ]

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """Every ``every``-th frame that carries velocities: each mode's energy."""
        positions, velocities = frame.positions, frame.velocities
        if velocities is None:
            return
        if self.shares is not None:
            self.shares.add(frame.time, positions, velocities)
            for mode, share in enumerate(self.shares.shares[-1], 1):
                stream.log(self.paths.mode_share(mode), rr.Scalars(float(share)))
        if index % self.every:
            return
        table = MAGNITUDE.table()
        for name, energies in zip(self.polarisations, self.energies(positions, velocities),
                                  strict=True):
            stream.log(self.paths.mode_energy(name),
                       rr.Tensor(energies.astype(np.float32), dim_names=["n", "m"]))
            logarithm = np.log10(np.maximum(energies, self.bottom))
            rgb = map_values(logarithm, math.log10(self.bottom), math.log10(self.top),
                                     table)
            # image rows run downwards: n = 1 (the longest waves across rows) at the bottom;
            # an explicit format, so that a one-row image is not taken for a grey one
            height, width = energies.shape
            image_format = rr.components.ImageFormat(width=width, height=height,
                                                     color_model="RGB", channel_datatype="U8")
            stream.log(self.paths.mode_image(name),
                       rr.Image.from_fields(buffer=np.ascontiguousarray(rgb[::-1]).tobytes(),
                                            format=image_format))


# --- driver and sponge -----------------------------------------------------------------------------


def _layer_edges(nx: int, ny: int, width: int, sides: Sequence[str]
                 ) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Inner edges of the layer in "cell" coordinates (column c spans [c, c + 1], row r spans
    [r, r + 1], rows upwards): one segment per absorbing wall, each spanning the interior."""
    left = width if "left" in sides else 0
    right = nx - width if "right" in sides else nx
    bottom = width if "bottom" in sides else 0
    top = ny - width if "top" in sides else ny
    segments = []
    if "left" in sides:
        segments.append(((left, bottom), (left, top)))
    if "right" in sides:
        segments.append(((right, bottom), (right, top)))
    if "bottom" in sides:
        segments.append(((left, bottom), (right, bottom)))
    if "top" in sides:
        segments.append(((left, top), (right, top)))
    return [((float(a), float(b)), (float(c), float(d))) for (a, b), (c, d) in segments]


def log_sponge(stream: rr.RecordingStream, paths: TreePaths, model: Model, *, lattice: bool,
               field: bool) -> None:
    """A faint outline of the absorbing layer's inner edge: in the lattice view (metres) and
    over the field image (pixels, top row first)."""
    if not boundaries.get(model.boundary).absorbing:
        return
    edges = _layer_edges(model.nx, model.ny, model.sponge_width, model.sponge_sides)
    if not edges:
        return
    cells = np.asarray(edges, dtype=np.float32)  # (segments, 2 ends, (column, row))
    if lattice:
        origin = np.asarray(model.rest_positions[0, :2], dtype=np.float32)
        metres = origin + (cells - 0.5) * np.float32(model.spacing)
        if model.dim == 3:
            metres = np.concatenate([metres, np.zeros(metres.shape[:2] + (1,), np.float32)], axis=2)
            archetype: Any = rr.LineStrips3D
        else:
            archetype = rr.LineStrips2D
        stream.log(paths.sponge, archetype(metres, colors=SPONGE_COLOUR,
                                           radii=0.03 * model.spacing), static=True)
    if field:
        pixels = cells.copy()
        pixels[..., 1] = model.ny - cells[..., 1]
        stream.log(paths.field_sponge, rr.LineStrips2D(pixels, colors=SPONGE_COLOUR, radii=0.5),
                   static=True)


def log_driver(stream: rr.RecordingStream, paths: TreePaths, model: Model) -> None:
    """A ring on the driven particle's rest position in the lattice view."""
    driver = model.driver
    if driver is None:
        return
    index = driver.row * model.nx + driver.column
    position = np.asarray(model.rest_positions[index], dtype=np.float32)[None]
    archetype = rr.Points3D if model.dim == 3 else rr.Points2D
    stream.log(paths.driver, archetype(position, radii=0.3 * model.spacing,
                                       colors=(*DRIVER_COLOUR, 110), labels="driver"), static=True)


def describe_sponge(model: Model) -> str:
    """A sentence about the absorbing layer, "along the ... wall(s) a sponge layer ..." (empty
    for fixed walls)."""
    if not boundaries.get(model.boundary).absorbing:
        return ""
    omega_0 = math.sqrt(model.stiffness / float(np.mean(model.masses)))
    sides = ", ".join(model.sponge_sides)
    return (
        f"along the {sides} wall(s) a sponge layer {model.sponge_width} particles deep "
        f"(a perfectly matched layer) in which the springs' stretch and the forces along the "
        f"wall's normal relax at a rate rising as depth² from 0 at the "
        f"layer's inner edge to {model.sponge_strength:g} ω0 = "
        f"{model.sponge_strength * omega_0:.3g} 1/s at the wall (ω0 = √(k/m)); waves that enter "
        "it die out instead of reflecting, and the energy it takes counts as `dissipated`."
    )
