"""Render a run (or a recording) to a movie: the picture of every frame from the positions, with
a title line, the simulated time, a colour bar with its unit and the scene's one-line summary.

No screen or browser is involved: large lattices are drawn as a field image (one block of pixels
per particle, ``raster.upscale_nearest``), small ones as springs (segments) and particles (discs)
by the compiled kernels in ``app.movie.raster``; 3-D lattices in an oblique view with heights
exaggerated.  Text is drawn once with Pillow into a template (title, colour bar, summary); only the
time is drawn per frame.  The simulation and drawing run in the calling thread while a second
thread encodes (``app.movie.encode``), so both cores are used.

Colour scales are fixed for the whole movie from a look-ahead run (``app.recording.scales``), or,
for a recording, from its own frames, so frames are comparable.
"""

from __future__ import annotations

import dataclasses
import math
import queue
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from app.colours import MAGNITUDE, SIGNED_FIELD, SIGNED_LINES, map_values
from app.movie import encode, raster
from app.recording.scales import (
    AXIS_NAMES,
    SIGNED,
    UNITS,
    ColourScales,
    field_values,
    look_ahead,
)
from app.recording.style import NEUTRAL_COLOUR, PARTICLE_COLOUR, nice_number

COLOURS = ("displacement", "speed", "strain", "density")
"""What colours the picture: the signed displacement component (m), the speed |v| (m/s), the
strain of the springs minus the rest strain, the relative density change rho/rho_0 - 1."""
DETAIL_LIMIT = 2500
"""Lattices with at most this many particles are drawn as springs and particles."""
MAX_FRAMES = 1000
FRAMES_PER_SIMULATED_SECOND = 25
BACKGROUND = (250, 250, 250)
TEXT = (20, 20, 20)


@dataclasses.dataclass(frozen=True)
class MovieOptions:
    """How a movie is made.

    fps: movie frames per second.
    frames: movie frames (default: min(1000, 25 per simulated second, one per step));
        the movie lasts frames / fps seconds.
    duration: simulated seconds to show (default: the scene's duration; a recording: all of it).
    size: (width, height) in pixels; even numbers for MP4/WebM (odd ones are rounded down).
    colour: one of ``COLOURS`` (default: strain for small planar lattices, else displacement).
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
        return dataclasses.replace(self, size=(width - width % 2, height - height % 2))


@dataclasses.dataclass
class State:
    """One frame's state: simulated time (s), positions (n_particles, dim) m, velocities (m/s)
    or None, strains (n_springs,) or None."""

    time: float
    positions: np.ndarray
    velocities: np.ndarray | None = None
    strains: np.ndarray | None = None


# --- sources -----------------------------------------------------------------------------------------


class SimulationSource:
    """Frames of a fresh run of ``scene`` (its initial state at t = 0)."""

    def __init__(self, scene: Any, options: MovieOptions) -> None:
        from sim import Simulation

        self.scene = scene
        self.model = scene.model
        self.simulation = Simulation(scene, integrator=options.integrator, dt=options.dt)
        dt = self.simulation.dt
        duration = options.duration or scene.duration
        steps = max(1, math.ceil(duration / dt - 1e-9))
        frames = options.frames or min(
            MAX_FRAMES, steps + 1, max(2, round(duration * FRAMES_PER_SIMULATED_SECOND) + 1)
        )
        self.frames = frames
        self.every = max(1, round(steps / (frames - 1)))
        self.summary = (f"{scene.name}: {self.model.describe()}; {self.simulation.integrator}, "
                        f"dt={dt:g} s")

    def scales(self, colour: str) -> ColourScales:
        quantity = "speed" if colour == "speed" else colour
        return look_ahead(self.scene, integrator=self.simulation.integrator,
                          dt=self.simulation.dt, quantity=quantity,
                          strains=colour == "strain" and self.model.n_particles <= DETAIL_LIMIT)

    def states(self, velocities: bool, strains: bool) -> Iterator[State]:
        from sim import BlowUpError

        simulation = self.simulation
        for index in range(self.frames):
            if index:
                try:
                    simulation.step(self.every)
                except BlowUpError:
                    return
            yield State(
                simulation.time, simulation.peek_positions().copy(),
                simulation.velocities.copy() if velocities else None,
                simulation.strains() if strains else None,
            )


# --- layout and drawing ------------------------------------------------------------------------------


def _font(size: int):
    from PIL import ImageFont

    return ImageFont.load_default(size=max(8, size))


def _fit_text(draw: Any, text: str, font: Any, width: int) -> str:
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(text + "…", font=font) > width:
        text = text[:-1]
    return text + "…"


def _title(scene: Any) -> str:
    description = (scene.description or "").strip()
    return f"{scene.name}: {description}" if description else scene.name


class Painter:
    """Draws frames of ``width`` x ``height`` pixels for one model, colour and set of scales."""

    def __init__(self, scene: Any, model: Any, summary: str, colour: str, scales: ColourScales,
                 options: MovieOptions) -> None:
        self.model = model
        self.colour = colour
        self.scales = scales
        self.width, self.height = options.size
        self.detailed = model.n_particles <= DETAIL_LIMIT
        self.signed = colour in SIGNED
        self.table = ((SIGNED_LINES if self.detailed else SIGNED_FIELD) if self.signed
                      else MAGNITUDE).table()
        if colour == "displacement" and model.dim == 3 and self.detailed:
            self.scale = scales.height
        else:
            self.scale = scales.strain if (colour == "strain" and self.detailed) else scales.field
        self.scale = max(self.scale, 1e-12)
        self.exaggeration = 1.0
        if model.dim == 3:
            width_m = (max(model.nx, model.ny) + 1) * model.spacing
            self.exaggeration = options.exaggeration or nice_number(
                0.08 * width_m / max(scales.height, 1e-12))
        self.top = max(24, round(self.height * 0.085))
        self.bottom = max(40, round(self.height * 0.15))
        self._layout_picture()
        self.template = self._template(scene, summary)
        self.time_font = _font(round(self.top * 0.5))

    # -- geometry --

    def _layout_picture(self) -> None:
        model = self.model
        pad = round(0.02 * self.width)
        box_w = self.width - 2 * pad
        box_h = self.height - self.top - self.bottom - 2 * pad
        if not self.detailed:
            aspect = model.nx / model.ny
        else:
            points = np.concatenate([model.rest_positions, model.anchor_positions])[:, :2]
            self.low = points.min(axis=0) - 0.6 * model.spacing
            self.high = points.max(axis=0) + 0.6 * model.spacing
            if self.scales.bounds is not None and model.dim == 2:  # where the particles went
                self.low = np.minimum(self.low, np.array(self.scales.bounds[0]) - 0.6 * model.spacing)
                self.high = np.maximum(self.high, np.array(self.scales.bounds[1]) + 0.6 * model.spacing)
            if model.dim == 3:  # oblique view: y shortened, room above and below for heights
                self.tilt = math.radians(50.0)
                span = (self.high[1] - self.low[1]) * math.sin(self.tilt)
                lift = 0.12 * (self.high[0] - self.low[0])
                self.low = np.array([self.low[0], self.low[1] * math.sin(self.tilt) - lift])
                self.high = np.array([self.high[0], self.low[1] + span + 2 * lift])
            extent = self.high - self.low
            aspect = extent[0] / extent[1]
        width = min(box_w, box_h * aspect)
        height = width / aspect
        self.px = int(round(width))
        self.py = int(round(height))
        self.x0 = (self.width - self.px) // 2
        self.y0 = self.top + pad + (box_h - self.py) // 2
        if self.detailed:
            self.pixels_per_metre = self.px / (self.high[0] - self.low[0])

    def _to_pixels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n, dim) metres -> pixel x, y and a depth for painter's order."""
        s = self.pixels_per_metre
        if self.model.dim == 3:
            y = points[:, 1] * math.sin(self.tilt) + self.exaggeration * points[:, 2] * math.cos(
                self.tilt)
            depth = -points[:, 1]
        else:
            y = points[:, 1]
            depth = np.zeros(len(points))
        px = self.x0 + (points[:, 0] - self.low[0]) * s
        py = self.y0 + self.py - (y - self.low[1]) * s
        return px, py, depth

    # -- static parts --

    def _template(self, scene: Any, summary: str) -> np.ndarray:
        from PIL import Image, ImageDraw

        image = Image.new("RGB", (self.width, self.height), BACKGROUND)
        draw = ImageDraw.Draw(image)
        margin = round(0.02 * self.width)
        title_font = _font(round(self.top * 0.5))
        title = _fit_text(draw, _title(scene), title_font, int(self.width * 0.72))
        draw.text((margin, self.top // 2), title, fill=TEXT, font=title_font, anchor="lm")
        # colour bar: left half of the bottom band
        bar_top = self.height - self.bottom + round(self.bottom * 0.2)
        bar_h = max(6, round(self.bottom * 0.18))
        bar_w = int(self.width * 0.42)
        low = -self.scale if self.signed else 0.0
        gradient = self.table[np.linspace(0, 255, bar_w).astype(int)]
        pixels = np.asarray(image).copy()
        pixels[bar_top : bar_top + bar_h, margin : margin + bar_w] = gradient[None, :, :]
        image = Image.fromarray(pixels)
        draw = ImageDraw.Draw(image)
        small = _font(round(self.bottom * 0.16))
        for fraction in (0.0, 0.25, 0.5, 0.75, 1.0):
            x = margin + fraction * (bar_w - 1)
            value = low + fraction * (self.scale - low)
            draw.line([(x, bar_top + bar_h), (x, bar_top + bar_h + 3)], fill=TEXT)
            draw.text((x, bar_top + bar_h + 4), f"{value:.3g}", fill=TEXT, font=small, anchor="ma")
        draw.text((margin, bar_top - 3), self._colour_label(), fill=TEXT, font=small, anchor="lb")
        right = margin + bar_w + 2 * margin
        width = self.width - right - margin
        lines = [summary, "colour scale fixed for the whole movie"]
        if self.model.dim == 3:
            lines.append(f"heights drawn {self.exaggeration:g} times larger")
        y = bar_top - 3
        for line in lines:
            draw.text((right, y), _fit_text(draw, line, small, width), fill=TEXT, font=small,
                      anchor="lt")
            y += round(self.bottom * 0.22)
        return np.asarray(image).copy()

    def _colour_label(self) -> str:
        unit = UNITS[self.colour]
        if self.colour == "displacement":
            axis = "z (height)" if self.model.dim == 3 and self.detailed else AXIS_NAMES[self.scales.axis]
            return f"displacement u_{axis} ({unit})" if self.model.dim == 2 or not self.detailed \
                else f"height z ({unit})"
        if self.colour == "speed":
            return "speed |v| (m/s)"
        if self.colour == "strain":
            return "spring strain - rest strain (dimensionless)"
        return "density change rho/rho_0 - 1 (dimensionless)"

    # -- per frame --

    def values(self, state: State) -> np.ndarray:
        """The per-particle value of this frame's colour."""
        model = self.model
        quantity = self.colour
        if quantity == "displacement" and model.dim == 3 and self.detailed:
            return state.positions[:, 2] - model.rest_positions[:, 2]
        return field_values(quantity, state.positions, model.rest_positions, state.velocities,
                            self.scales.axis, model)

    def paint(self, state: State, frame: np.ndarray) -> None:
        """Draw ``state`` into ``frame`` (height, width, 3) uint8."""
        np.copyto(frame, self.template)
        low = -self.scale if self.signed else 0.0
        if not self.detailed:
            rows, columns = self.model.ny, self.model.nx
            values = np.asarray(self.values(state), dtype=np.float64)
            block = math.ceil(columns / self.px)
            if block > 1:
                # fewer pixels than particles: each block shows its largest value (with its
                # sign), so short waves neither alias into noise nor average away
                rows, columns = rows // block, columns // block
                blocks = values.reshape(self.model.ny, self.model.nx)[
                    : rows * block, : columns * block
                ].reshape(rows, block, columns, block).transpose(0, 2, 1, 3).reshape(
                    rows, columns, block * block)
                pick = np.abs(blocks).argmax(axis=2)
                values = np.take_along_axis(blocks, pick[:, :, None], axis=2).ravel()
            raster.field_to_frame(frame, np.ascontiguousarray(values), rows, columns, low,
                                  self.scale, self.table, self.x0, self.y0, self.px, self.py)
        else:
            self._paint_lattice(state, frame, low)
        self._paint_time(state.time, frame)

    def _paint_lattice(self, state: State, frame: np.ndarray, low: float) -> None:
        model = self.model
        ends = np.concatenate([state.positions, model.anchor_positions])
        x, y, depth = self._to_pixels(ends)
        springs = model.springs
        if self.colour == "strain" and state.strains is not None:
            spring_colours = map_values(state.strains - self.scales.rest_strain, low,
                                              self.scale, self.table)
        elif model.dim == 3:
            height = ends[:, 2] - np.concatenate([model.rest_positions[:, 2],
                                                  model.anchor_positions[:, 2]])
            mean = 0.5 * (height[springs[:, 0]] + height[springs[:, 1]])
            spring_colours = map_values(mean, -self.scale, self.scale, self.table)
        else:
            spring_colours = np.tile(np.array(NEUTRAL_COLOUR, np.uint8), (len(springs), 1))
        half = max(0.8, (0.12 if model.dim == 3 else 0.05) * model.spacing * self.pixels_per_metre)
        if model.dim == 3:
            order = np.argsort(np.minimum(depth[springs[:, 0]], depth[springs[:, 1]]))
            springs = springs[order]
            spring_colours = spring_colours[order]
        raster.draw_segments(frame, x[springs[:, 0]], y[springs[:, 0]], x[springs[:, 1]],
                             y[springs[:, 1]], np.ascontiguousarray(spring_colours), half)
        if model.dim == 3:
            return  # the surface of springs coloured by height carries the picture
        n = model.n_particles
        masses = model.masses.ravel()
        radii = np.maximum(1.5, 0.16 * model.spacing * self.pixels_per_metre
                           * (masses / masses.mean()) ** (1 / 3))
        if self.colour == "strain" and model.dim == 2:
            colours = np.tile(np.array(PARTICLE_COLOUR, np.uint8), (n, 1))
        else:
            colours = map_values(self.values(state), low, self.scale, self.table)
        order = np.argsort(depth[:n], kind="stable")
        raster.draw_discs(frame, x[:n], y[:n], radii, np.ascontiguousarray(colours), order)

    def _paint_time(self, seconds: float, frame: np.ndarray) -> None:
        from PIL import Image, ImageDraw

        text = f"t = {seconds:7.2f} s"
        box_w, box_h = int(self.width * 0.25), self.top
        mask = Image.new("L", (box_w, box_h), 0)
        ImageDraw.Draw(mask).text((box_w - round(0.02 * self.width), box_h // 2), text, fill=255,
                                  font=self.time_font, anchor="rm")
        alpha = np.asarray(mask, dtype=np.float32)[:, :, None] / 255.0
        region = frame[:box_h, self.width - box_w :]
        region[:] = (region * (1.0 - alpha) + np.array(TEXT, np.float32) * alpha).astype(np.uint8)


# --- the pipeline ------------------------------------------------------------------------------------


def default_colour(model: Any) -> str:
    """Strain for small planar lattices (springs coloured), else the signed displacement."""
    return "strain" if model.n_particles <= DETAIL_LIMIT and model.dim == 2 else "displacement"


def _encode_in_background(writer: Any, frames: queue.Queue, errors: list[BaseException]) -> None:
    while True:
        frame = frames.get()
        if frame is None:
            return
        if errors:
            continue
        try:
            writer.write(frame)
        except BaseException as error:  # noqa: BLE001 - handed to the producer
            errors.append(error)


def _render(source: Any, target: str | Path | BinaryIO, kind: str, options: MovieOptions) -> int:
    from tqdm import tqdm

    model = source.model
    colour = options.colour or default_colour(model)
    scales = source.scales(colour)
    painter = Painter(source.scene, model, source.summary, colour, scales, options)
    width, height = options.size
    writer = encode.open_writer(target, kind, width, height, options.fps, palette=painter.table)
    frames: queue.Queue = queue.Queue(maxsize=6)
    errors: list[BaseException] = []
    worker = threading.Thread(target=_encode_in_background, args=(writer, frames, errors),
                              name="movie-encoder", daemon=True)
    worker.start()
    count = 0
    bar = tqdm(total=source.frames, unit="frame", disable=not options.progress,
               dynamic_ncols=True, desc="movie")
    try:
        buffers = [np.empty((height, width, 3), np.uint8) for _ in range(8)]
        wants_velocities = colour == "speed"
        wants_strains = colour == "strain" and painter.detailed
        for state in source.states(wants_velocities, wants_strains):
            if errors:
                break
            frame = buffers[count % len(buffers)]
            painter.paint(state, frame)
            frames.put(frame)
            count += 1
            bar.update(1)
    finally:
        bar.close()
        frames.put(None)
        worker.join()
    if errors:
        raise errors[0]
    if count == 0:
        raise ValueError("no frames to render")
    writer.close()
    return count


def _source(scene_or_simulation: Any, options: MovieOptions) -> Any:
    """A frame source: a Scene, a Simulation (its current state becomes t = 0), or a recording
    (a path ending in .rrd)."""
    if isinstance(scene_or_simulation, (str, Path)) and str(scene_or_simulation).endswith(".rrd"):
        from app.movie.recorded import RecordingSource

        return RecordingSource(Path(scene_or_simulation), options)
    scene = scene_or_simulation
    if hasattr(scene, "step") and hasattr(scene, "state"):  # a running Simulation: snapshot it
        from sim.scenes import scene_from_simulation

        scene = scene_from_simulation(scene)
        options = dataclasses.replace(
            options, integrator=options.integrator or scene.integrator, dt=options.dt or scene.dt)
    return SimulationSource(scene, options)


def render_movie(
    scene_or_simulation: Any, path: str | Path, options: MovieOptions | None = None, **changes: Any
) -> Path:
    """Render a movie to ``path`` (.mp4, .webm or .gif) and return the path.

    scene_or_simulation: a ``sim.Scene`` (run from its initial state), a ``sim.Simulation``
    (its current state is copied and run on; call it between steps, e.g. through
    ``Runner.post``), or the path of a ``.rrd`` recording (re-rendered from its positions).
    ``changes`` override fields of ``options`` (``MovieOptions``): fps, frames, duration, size,
    colour, exaggeration, integrator, dt, progress.  Raises ``ValueError`` on bad options.
    """
    options = dataclasses.replace(options or MovieOptions(), **changes).checked()
    path = Path(path)
    kind = encode.kind_of(path)
    source = _source(scene_or_simulation, options)
    partial = path.with_name(path.name + ".partial")
    try:
        _render(source, partial, kind, options)
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)
    return path


def movie_bytes(
    scene_or_simulation: Any, kind: str = "mp4", options: MovieOptions | None = None,
    **changes: Any,
) -> bytes:
    """The movie as bytes (``kind``: mp4, webm or gif), for a download; see ``render_movie``."""
    import tempfile

    options = dataclasses.replace(options or MovieOptions(), **changes).checked()
    encode.kind_of(f"movie.{kind}")
    # through a temporary file: MP4's index goes to the front (+faststart) in a second pass
    # that reopens the file by name
    with tempfile.TemporaryDirectory(prefix="movie-") as directory:
        path = Path(directory) / f"movie.{kind}"
        _render(_source(scene_or_simulation, options), path, kind, options)
        return path.read_bytes()
