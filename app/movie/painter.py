"""Drawing one movie frame: the picture of the lattice (a field image for large lattices,
springs and particles for small ones, an oblique view of 3-D ones with heights exaggerated), a
title line, the simulated time, a colour bar with its unit and the scene's one-line summary.

Colours follow the quantity's scheme (``app.colours.scheme``) on a scale that may follow the
field frame by frame (``MovieOptions.scale``, default the scheme's: adaptive, logarithmic), so
the waves stay visible as they spread and weaken; the colour bar's numbers are those of the scale
in use at each frame.  Text is drawn once with Pillow into a template (title, colour bar,
summary); only the time and the colour bar's numbers are drawn per frame.  The pixels of the
picture come from the compiled kernels of ``app.movie.raster``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

import app.movie.raster as raster
from app.colours import colour_fractions, make_scale, scheme
from app.movie.frames import State
from app.movie.options import MovieOptions
from app.recording.options import DETAIL_LIMIT
from app.recording.scales import AXIS_NAMES, UNITS, ColourScales, field_values
from app.recording.style import NEUTRAL_COLOUR, PARTICLE_COLOUR, nice_number

BACKGROUND = (250, 250, 250)
TEXT = (20, 20, 20)


def _font(size: int):
    from PIL import ImageFont

    return ImageFont.load_default(size=max(8, size))


def _fit_text(draw: Any, text: str, font: Any, width: int) -> str:
    """``text``, or as many of its words as fit in ``width`` pixels followed by "…" (a word,
    such as a number, is never cut)."""
    if draw.textlength(text, font=font) <= width:
        return text
    words = text.split(" ")
    while len(words) > 1 and draw.textlength(" ".join(words) + " …", font=font) > width:
        words.pop()
    kept = " ".join(words).rstrip(",;:(")
    if draw.textlength(kept + " …", font=font) > width:  # one long word: cut it after all
        while kept and draw.textlength(kept + "…", font=font) > width:
            kept = kept[:-1]
        return kept + "…"
    return kept + " …"


def _fit_title(draw: Any, text: str, size: int, width: int) -> tuple[str, Any]:
    """The title in the largest font from ``size`` down to 70 % of it that holds it all in
    ``width`` pixels, else cut after a whole word (``_fit_text``) in the smallest."""
    for share in (1.0, 0.9, 0.8, 0.7):
        font = _font(round(size * share))
        if draw.textlength(text, font=font) <= width:
            return text, font
    return _fit_text(draw, text, font, width), font


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
        self.scheme = scheme(colour)
        self.signed = self.scheme.signed
        self.table = (self.scheme.lines if self.detailed else self.scheme.field).table()
        if colour == "displacement" and model.dim == 3 and self.detailed:
            limit = scales.height
        else:
            limit = scales.strain if (colour == "strain" and self.detailed) else scales.field
        limit = max(limit, 1e-12)
        floor = 1e-9 * model.spacing if colour in ("displacement", "speed") else 1e-9
        self.colour_scale = make_scale(options.scale or self.scheme.scale, limit, self.signed, floor)
        self.ticks_at = [position for position, _ in self.colour_scale.ticks()]
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
        title, title_font = _fit_title(draw, _title(scene), round(self.top * 0.5),
                                       int(self.width * 0.72))
        draw.text((margin, self.top // 2), title, fill=TEXT, font=title_font, anchor="lm")
        # colour bar: left half of the bottom band; its numbers are drawn per frame
        self.bar_top = bar_top = self.height - self.bottom + round(self.bottom * 0.2)
        self.bar_h = bar_h = max(6, round(self.bottom * 0.18))
        self.bar_w = bar_w = int(self.width * 0.42)
        self.margin = margin
        gradient = self.table[np.linspace(0, 255, bar_w).astype(int)]
        pixels = np.asarray(image).copy()
        pixels[bar_top : bar_top + bar_h, margin : margin + bar_w] = gradient[None, :, :]
        image = Image.fromarray(pixels)
        draw = ImageDraw.Draw(image)
        self.small = small = _font(round(self.bottom * 0.16))
        for fraction in self.ticks_at:
            x = margin + fraction * (bar_w - 1)
            draw.line([(x, bar_top + bar_h), (x, bar_top + bar_h + 3)], fill=TEXT)
        draw.text((margin, bar_top - 3), self._colour_label(), fill=TEXT, font=small, anchor="lb")
        right = margin + bar_w + 2 * margin
        width = self.width - right - margin
        lines = [summary, f"colours: {self.colour_scale.describe()}"]
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
        return self.scheme.title()

    # -- per frame --

    def values(self, state: State) -> np.ndarray:
        """The per-particle value of this frame's colour."""
        model = self.model
        quantity = self.colour
        if quantity == "displacement" and model.dim == 3 and self.detailed:
            return state.positions[:, 2] - model.rest_positions[:, 2]
        return field_values(quantity, state.positions, model.rest_positions, state.velocities,
                            self.scales.axis, model)

    def _colours(self, values: np.ndarray) -> np.ndarray:
        """uint8 RGB of ``values`` on the scale in use."""
        return colour_fractions(self.colour_scale.fraction(values), self.table)

    def paint(self, state: State, frame: np.ndarray) -> None:
        """Draw ``state`` into ``frame`` (height, width, 3) uint8."""
        np.copyto(frame, self.template)
        if not self.detailed:
            rows, columns = self.model.ny, self.model.nx
            values = np.asarray(self.values(state), dtype=np.float64)
            self.colour_scale.observe(values, state.time)
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
            fractions = self.colour_scale.fraction(values).astype(np.float64)
            raster.field_to_frame(frame, np.ascontiguousarray(fractions), rows, columns, 0.0,
                                  1.0, self.table, self.x0, self.y0, self.px, self.py)
        else:
            self._paint_lattice(state, frame)
        self._paint_time(state.time, frame)
        self._paint_bar_numbers(frame)

    def _paint_lattice(self, state: State, frame: np.ndarray) -> None:
        model = self.model
        ends = np.concatenate([state.positions, model.anchor_positions])
        x, y, depth = self._to_pixels(ends)
        springs = model.springs
        if self.colour == "strain" and state.strains is not None:
            strains = state.strains - self.scales.rest_strain
            self.colour_scale.observe(strains, state.time)
            spring_colours = self._colours(strains)
        elif model.dim == 3:
            height = ends[:, 2] - np.concatenate([model.rest_positions[:, 2],
                                                  model.anchor_positions[:, 2]])
            self.colour_scale.observe(height[: model.n_particles], state.time)
            spring_colours = self._colours(0.5 * (height[springs[:, 0]] + height[springs[:, 1]]))
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
            values = self.values(state)
            self.colour_scale.observe(values, state.time)
            colours = self._colours(values)
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

    def _paint_bar_numbers(self, frame: np.ndarray) -> None:
        """The colour bar's numbers of the scale in use, under its ticks; the end ones aligned
        inwards so no sign or digit leaves the frame."""
        from PIL import Image, ImageDraw

        top = self.bar_top + self.bar_h + 4
        right = min(self.width, self.margin * 2 + self.bar_w)
        region = frame[top : top + round(self.bottom * 0.2), :right]
        image = Image.fromarray(region)
        draw = ImageDraw.Draw(image)
        marks = self.colour_scale.ticks()
        texts = [f"{value:.2g}" if value else "0" for _, value in marks]
        widest = max(draw.textlength(text, font=self.small) for text in texts)
        if widest * 1.3 * len(marks) > self.bar_w:  # a narrow bar: the ends and zero only
            keep = {0, len(marks) // 2, len(marks) - 1}
            marks = [m for k, m in enumerate(marks) if k in keep]
            texts = [t for k, t in enumerate(texts) if k in keep]
        for k, ((fraction, _), text) in enumerate(zip(marks, texts, strict=True)):
            x = self.margin + fraction * (self.bar_w - 1)
            anchor = "la" if k == 0 else "ra" if k == len(marks) - 1 else "ma"
            draw.text((x, 0), text, fill=TEXT, font=self.small, anchor=anchor)
        region[:] = np.asarray(image)
