"""Frames of a movie read back from the field image of a ``.rrd`` recording (large lattices,
which are recorded as one colour-mapped pixel per particle rather than positions).

The field's entity (``/field``, or a comparison's first tree's) holds, static, what its colours
mean: ``quantity`` (displacement, magnitude or speed), ``axis``, ``colour_policy`` (a scale policy
of ``app.colours``; recordings that do not say are ``fixed``) and ``colour_scale`` (the limit it
started with, m or m/s), and the tree's ``colour_scale/field`` holds the limit in use at each
frame, logged by ``app.recording.field.FieldView``.  Each frame is decoded
(H.264 ``VideoStream`` samples through PyAV, JPEG ``EncodedImage`` through Pillow, or the raw
float ``DepthImage``) one at a time, so memory holds the compressed samples and one picture.  A
colour image gives each particle's value back by the nearest of the 256 colours of the map
(``app.colours``) read on the frame's own scale (``ColourScale.values``): the movie shows the
field at that resolution, 128 levels either side of zero, and the level next to zero (on a log
scale the three next to it) is drawn as zero (compression noise of the video and the rounding of
the colour look-up, not a wave).  Such a movie is drawn with the recording's
own policy unless asked for another (``scale_policy``): a recording that followed the field makes
a movie that follows it, one on a fixed linear scale (where a scale that magnifies small values
would magnify the video's noise) a movie on that scale.
``open_recording`` picks this source or ``RecordingSource`` (positions).
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from app.colours import MAGNITUDE, SCALES, SIGNED_FIELD, make_scale
from app.movie.frames import FrameSource, State
from app.movie.options import MovieOptions
from app.movie.recorded import (
    RecordingSource,
    _flat,
    document_and_masses,
    model_from_document,
    read_chunks,
    scene_of,
)
from app.recording.scales import SIGNED, ColourScales

SAMPLE_COLUMNS = ("VideoStream:sample", "EncodedImage:blob", "DepthImage:buffer")


def open_recording(path: Path, options: MovieOptions) -> FrameSource:
    """The frame source of a recording: its positions if it has them, else its field image."""
    chunks = read_chunks(path)
    if any(not c.is_static and (c.entity_path.endswith("/lattice/particles")
                                or c.entity_path.endswith("/lattice/surface")) for c in chunks):
        return RecordingSource(path, options)
    if any(c.entity_path.endswith("field") and not c.is_static for c in chunks):
        return FieldRecordingSource(path, chunks, options)
    return RecordingSource(path, options)  # says what is missing


def inverse_table(table: np.ndarray) -> np.ndarray:
    """(32, 32, 32) uint8: for RGB >> 3, the index of the nearest colour of ``table`` (256, 3)."""
    centres = (np.indices((32, 32, 32)).reshape(3, -1).T * 8 + 4).astype(np.int32)
    best = np.zeros(len(centres), np.uint8)
    table = table.astype(np.int32)
    for start in range(0, len(centres), 4096):
        block = centres[start : start + 4096]
        distance = ((block[:, None, :] - table[None, :, :]) ** 2).sum(axis=2)
        best[start : start + 4096] = distance.argmin(axis=1)
    return best.reshape(32, 32, 32)


class FieldRecordingSource:
    """Frames of a recording's field image (see the module docstring)."""

    def __init__(self, path: Path, chunks: list, options: MovieOptions) -> None:
        document, masses = document_and_masses(chunks, path)
        self.model, integrator, dt = model_from_document(document, masses)
        described: dict[str, Any] = {}
        samples: dict[str, dict[int, tuple[float, str, Any]]] = {}
        limits: dict[str, dict[int, float]] = {}
        for chunk in chunks:
            if chunk.entity_path.endswith("colour_scale/field") and not chunk.is_static:
                batch = chunk.to_record_batch()
                if "Scalars:scalars" in batch.schema.names:
                    entity = chunk.entity_path[: -len("colour_scale/field")] + "field"
                    rows_of = limits.setdefault(entity, {})
                    for step, value in zip(batch.column("step").to_pylist(),
                                           batch.column("Scalars:scalars").to_pylist(),
                                           strict=True):
                        if value:
                            rows_of[step] = float(value[0])
                continue
            if not chunk.entity_path.endswith("field"):
                continue
            batch = chunk.to_record_batch()
            names = batch.schema.names
            if chunk.is_static:
                for key in ("quantity", "axis", "colour_scale", "colour_policy"):
                    if key in names:
                        described.setdefault(chunk.entity_path, {})[key] = \
                            batch.column(key)[0].as_py()[0]
                continue
            column = next((c for c in SAMPLE_COLUMNS if c in names), None)
            if column is None or "sim_time" not in names:
                continue
            rows = samples.setdefault(chunk.entity_path, {})
            steps = batch.column("step").to_pylist()
            nanoseconds = batch.column("sim_time").cast("int64").to_pylist()
            for step, ns, value in zip(steps, nanoseconds, batch.column(column), strict=True):
                if value.is_valid and len(value.values):
                    rows[step] = (ns * 1e-9, column, value)
        usable = [e for e in sorted(samples, key=lambda e: (e.count("/"), e))
                  if {"quantity", "axis", "colour_scale"} <= set(described.get(e, {}))]
        if not usable:
            raise ValueError(f"{path} holds neither particle positions nor a field image whose "
                             "colour scale it states: record with --positions all, or make the "
                             "movie from the scene")
        entity = usable[0]
        self.quantity = str(described[entity]["quantity"])
        self.axis = int(described[entity]["axis"])
        self.limit = float(described[entity]["colour_scale"])
        self.policy = str(described[entity].get("colour_policy", "fixed"))
        self.signed = self.quantity in SIGNED
        steps_with_limit = sorted(limits.get(entity, {}))
        self._limits = [limits[entity][s] for s in steps_with_limit]
        self._limit_steps = np.array(steps_with_limit, dtype=np.int64)
        self.colour = "speed" if self.quantity == "speed" else "displacement"
        order = sorted(samples[entity])
        self._steps = np.array(order, dtype=np.int64)
        self._all = [samples[entity][s] for s in order]
        times = np.array([row[0] for row in self._all])
        keep = np.ones(len(times), bool)
        if options.duration is not None:
            keep &= times <= times[0] + options.duration + 1e-9
        indices = np.flatnonzero(keep)
        wanted = options.frames or options.max_frames
        if wanted is not None and wanted < len(indices):
            indices = indices[np.unique(np.linspace(0, len(indices) - 1, wanted).round()
                                        .astype(int))]
        self.picks = indices
        self.frames = len(indices)
        self.times = times
        self.kind = self._all[0][1]
        duration = max(float(times[indices[-1]] - times[indices[0]]), dt)
        self.scene = scene_of(document, self.model, integrator, dt, duration,
                              self.model.rest_positions, path.stem)
        resolution = ("float values" if self.kind == "DepthImage:buffer" else
                      f"256 colours over {'±' if self.signed else '0-'}{self.limit:.3g}"
                      if not self._limits else f"256 colours, {self.policy} scale")
        self.summary = (f"{self.scene.summary()}; recording {path.name}, field image "
                        f"({resolution})")
        self.scale_policy = self.policy if self.kind != "DepthImage:buffer" else None
        self._table = (SIGNED_FIELD if self.signed else MAGNITUDE).table()

    def scales(self, colour: str, watch: Any = None) -> ColourScales:
        model = self.model
        rest_strain = (model.spacing - model.rest_length) / model.rest_length
        return ColourScales(strain=1.0, field=self.limit, height=0.0, axis=self.axis,
                            rest_strain=rest_strain, seconds=0.0)

    def limit_at(self, index: int) -> float:
        """The limit of the colour scale the recorded frame ``index`` was drawn on."""
        if not self._limits:
            return self.limit
        position = int(np.searchsorted(self._limit_steps, self._steps[index], side="right")) - 1
        return self._limits[max(0, position)]

    def _pictures(self) -> Iterator[np.ndarray]:
        """(ny, nx) values of every recorded frame in order (top lattice row first)."""
        ny, nx = self.model.ny, self.model.nx
        if self.kind == "DepthImage:buffer":
            for _, _, value in self._all:
                raw = np.ascontiguousarray(_flat(value)).view(np.uint8)
                dtype = np.float32 if raw.size == 4 * ny * nx else np.float16
                yield raw.view(dtype).reshape(ny, nx).astype(np.float32)
            return
        inverse = inverse_table(self._table)
        if self.kind == "EncodedImage:blob":
            import io

            from PIL import Image

            for k, (_, _, value) in enumerate(self._all):
                with Image.open(io.BytesIO(_flat(value).tobytes())) as image:
                    yield self._values(np.asarray(image.convert("RGB"))[:ny, :nx], inverse, k)
            return
        import av

        codec = av.CodecContext.create("h264", "r")
        decoded = 0
        for _, _, value in self._all:  # one sample is one encoded frame (no B-frames)
            for frame in codec.decode(av.Packet(_flat(value).tobytes())):
                yield self._values(frame.to_ndarray(format="rgb24")[:ny, :nx], inverse, decoded)
                decoded += 1
        for frame in codec.decode(None):
            yield self._values(frame.to_ndarray(format="rgb24")[:ny, :nx], inverse, decoded)
            decoded += 1

    def _values(self, rgb: np.ndarray, inverse: np.ndarray, index: int) -> np.ndarray:
        """Values of a decoded picture on the scale recorded frame ``index`` was drawn on."""
        levels = inverse[rgb[:, :, 0] >> 3, rgb[:, :, 1] >> 3, rgb[:, :, 2] >> 3].astype(
            np.float32)
        # the levels next to zero are the codec's noise and the colour look-up's rounding (RGB
        # read in steps of 8): a log scale would magnify them into a coloured background
        dead = 3.5 if SCALES[self.policy].logarithmic else 1.5
        if not self.signed:
            levels[levels <= dead - 0.5] = 0.0
        else:
            levels[np.abs(levels - np.float32(127.5)) <= dead] = 127.5
        scale = make_scale(self.policy, self.limit_at(min(index, len(self._all) - 1)),
                           self.signed)
        return scale.values(levels * np.float32(1.0 / 255.0))

    def states(self, velocities: bool, strains: bool) -> Iterator[State]:
        model = self.model
        wanted = set(int(k) for k in self.picks)
        for k, picture in enumerate(self._pictures()):
            if k not in wanted:
                continue
            values = np.flipud(picture).reshape(-1).astype(np.float64)
            positions = model.rest_positions.copy()
            speeds = None
            if self.colour == "speed":
                speeds = np.zeros_like(positions)
                speeds[:, 0] = values
            else:
                positions[:, self.axis] += values
            yield State(float(self.times[k]), positions, speeds, None)
