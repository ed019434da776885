"""Field images for large lattices: one pixel per particle, colour-mapped or raw.

A lattice of ``nx`` by ``ny`` particles becomes an image of ``ny`` rows by ``nx`` columns whose
pixel (row r, column c) is particle ``(i=c, j=ny-1-r)``: the image is the lattice seen from the
front, top row first (image rows run downwards, lattice rows upwards).  The quantity is the
signed displacement component ``u_axis`` (m, diverging colour map, zero in the middle), the
displacement magnitude ``|x - x_rest|`` (m) or the speed ``|v|`` (m/s) of every particle (0 at
the map's start), see ``app.recording.scales``.

The colours follow a scale policy of ``app.colours`` (``SCALES``), by default the quantity's
scheme's, as on the page and in movies: ``adaptive-symlog``, a logarithmic map whose limit follows
the field's current amplitude (its 99th percentile, smoothed over a few simulated seconds), so
waves show at every moment of a long run as they spread and weaken; ``fixed`` keeps one linear
scale for the whole recording.  The limit in use is logged with every frame
(``settings/field_scale``, m or m/s) and the colour bar (``/legend/field``) is redrawn when its
numbers change, so the viewer shows the scale of the frame on screen.

Three encodings, one class each, all with ``log(stream, entity, field, scale)`` for a
``(ny, nx)`` float array and the ``ColourScale`` in use (the caller sets the time first) and
``finish(stream, entity)`` at the end:

* ``JpegField``: colour-mapped RGB, JPEG-compressed (``rr.EncodedImage``), ~30 kB a frame;
* ``VideoField``: colour-mapped, H.264 through PyAV into ``rr.VideoStream``, a few kB a frame;
  the frame is padded to even sizes (H.264 4:2:0 needs them) by repeating the last row/column;
* ``RawField``: the values themselves as a float32 (or float16) ``rr.DepthImage`` (lossless
  apart from the float conversion); the viewer colour-maps it.

``FieldView`` is a tree's field: it turns each frame's positions or velocities into the image and
hands it to its encoder.  With the first frame it logs, static on the field's entity, what the
colours mean (``quantity``, ``axis``, ``colour_policy`` and ``colour_scale``: the limit it
started with, m or m/s), so a movie can be made from the field alone
(``app.movie.recorded_field``).
"""

from __future__ import annotations

import io
from fractions import Fraction
from typing import Any, Protocol

import numpy as np

from app.colours import ColourScale, colour_fractions, make_scale, scheme
from app.recording.rerun_lazy import rr
from app.recording.scales import SIGNED, field_values
from sim.model.lattice import Model
from sim.runtime.runner import Frame

FIELD_MODES = ("jpeg", "video", "raw")


def video_available() -> bool:
    """True if PyAV with an H.264 encoder is installed (``pip install av``)."""
    try:
        import av
    except ImportError:
        return False
    return "libx264" in av.codecs_available


def lattice_image(values: np.ndarray, nx: int, ny: int) -> np.ndarray:
    """(n_particles,) per-particle values -> (ny, nx) image, top lattice row first."""
    return np.flipud(values.reshape(ny, nx))


def colour_map(field: np.ndarray, scale: ColourScale) -> np.ndarray:
    """(ny, nx) values -> (ny, nx, 3) uint8 RGB on ``scale``: signed ones on ``SIGNED_FIELD``
    (``app.colours``), magnitudes on ``MAGNITUDE`` (saturating beyond the limit)."""
    table = scheme("displacement" if scale.signed else "magnitude").field.table()
    return colour_fractions(scale.fraction(field), table)


class FieldEncoder(Protocol):
    def log(self, stream: rr.RecordingStream, entity: str, field: np.ndarray,
            scale: ColourScale) -> None:
        ...

    def finish(self, stream: rr.RecordingStream, entity: str) -> None:
        ...


class JpegField:
    """Colour-mapped JPEG frames (``rr.EncodedImage``)."""

    def __init__(self, quality: int = 80, signed: bool = False) -> None:
        from PIL import Image

        self._image_module = Image
        self.quality = quality
        self.signed = signed

    def log(self, stream: rr.RecordingStream, entity: str, field: np.ndarray,
            scale: ColourScale) -> None:
        rgb = colour_map(field, scale)
        buffer = io.BytesIO()
        self._image_module.fromarray(rgb).save(buffer, format="JPEG", quality=self.quality)
        stream.log(entity, rr.EncodedImage(contents=buffer.getvalue(), media_type="image/jpeg"))

    def finish(self, stream: rr.RecordingStream, entity: str) -> None:
        pass


class VideoField:
    """Colour-mapped frames encoded as an H.264 stream (``rr.VideoStream``, needs PyAV).

    Every frame is encoded at once (``tune=zerolatency``, no B-frames) and its packet logged at
    the frame's own time, so an interrupted recording loses nothing already logged.  A keyframe
    every ``keyframe_interval`` frames keeps seeking in the viewer quick.
    """

    def __init__(self, crf: int = 28, preset: str = "veryfast", keyframe_interval: int = 60,
                 signed: bool = False):
        import av

        self._av = av
        self.crf = crf
        self.preset = preset
        self.keyframe_interval = keyframe_interval
        self.signed = signed
        self._codec = None
        self._frame_index = 0

    def _open(self, stream: rr.RecordingStream, entity: str, height: int, width: int) -> None:
        codec = self._av.CodecContext.create("libx264", "w")
        codec.width = width + width % 2
        codec.height = height + height % 2
        codec.pix_fmt = "yuv420p"
        codec.time_base = Fraction(1, 30)
        codec.framerate = 30
        codec.gop_size = self.keyframe_interval
        codec.max_b_frames = 0
        codec.options = {"preset": self.preset, "crf": str(self.crf), "tune": "zerolatency"}
        codec.open()
        self._codec = codec
        stream.log(entity, rr.VideoStream(codec=rr.VideoCodec.H264), static=True)

    def log(self, stream: rr.RecordingStream, entity: str, field: np.ndarray,
            scale: ColourScale) -> None:
        height, width = field.shape
        if self._codec is None:
            self._open(stream, entity, height, width)
        rgb = colour_map(field, scale)
        if height % 2 or width % 2:
            rgb = np.pad(rgb, ((0, height % 2), (0, width % 2), (0, 0)), mode="edge")
        frame = self._av.VideoFrame.from_ndarray(rgb, format="rgb24")
        frame.pts = self._frame_index
        self._frame_index += 1
        for packet in self._codec.encode(frame):
            stream.log(entity, rr.VideoStream.from_fields(sample=bytes(packet)))

    def finish(self, stream: rr.RecordingStream, entity: str) -> None:
        """Drain the encoder; with zerolatency there is normally nothing left."""
        if self._codec is None:
            return
        for packet in self._codec.encode(None):
            stream.log(entity, rr.VideoStream.from_fields(sample=bytes(packet)))
        self._codec = None


class RawField:
    """The field values themselves as a depth image (``rr.DepthImage``, meter = 1); the viewer
    colours it linearly over the limit in use."""

    def __init__(self, dtype: str = "float32", signed: bool = False) -> None:
        if dtype not in ("float16", "float32"):
            raise ValueError(f"raw field dtype must be float16 or float32, got {dtype!r}")
        self.dtype = np.dtype(dtype)
        self.signed = signed

    def log(self, stream: rr.RecordingStream, entity: str, field: np.ndarray,
            scale: ColourScale) -> None:
        limit = scale.limit
        stream.log(
            entity,
            rr.DepthImage(
                np.ascontiguousarray(field, dtype=self.dtype), meter=1.0,
                colormap=rr.components.Colormap.Inferno,
                depth_range=(-limit if self.signed else 0.0, limit),
            ),
        )

    def finish(self, stream: rr.RecordingStream, entity: str) -> None:
        pass


def make_field_encoder(
    mode: str, jpeg_quality: int = 80, raw_dtype: str = "float32", signed: bool = False
) -> FieldEncoder:
    """The encoder for ``mode`` in FIELD_MODES; ``signed``: values from -scale to +scale."""
    if mode == "jpeg":
        return JpegField(jpeg_quality, signed)
    if mode == "video":
        if not video_available():
            raise RuntimeError(
                "--field video needs PyAV with libx264: pip install av (or use --field jpeg)"
            )
        return VideoField(signed=signed)
    if mode == "raw":
        return RawField(raw_dtype, signed)
    raise ValueError(f"field mode must be one of {FIELD_MODES}, got {mode!r}")


class FieldView:
    """The field image of one tree at ``entity``: each frame's per-particle ``quantity`` (see
    ``app.recording.scales``; ``axis`` is the signed displacement's component) as a (ny, nx)
    image encoded by ``mode``, coloured on a scale of ``policy`` (``app.colours.SCALES``)
    starting at ``scale`` (m or m/s).  ``scale_entity``: where the limit in use is logged each
    frame; ``on_scale(colour_scale)``: called after each frame (the colour bar follows it)."""

    def __init__(self, entity: str, mode: str, quantity: str, axis: int, scale: float, *,
                 policy: str = "fixed", floor: float = 0.0, scale_entity: str | None = None,
                 on_scale: Any = None, jpeg_quality: int = 80,
                 raw_dtype: str = "float32") -> None:
        self.entity = entity
        self.quantity = quantity
        self.axis = axis
        self.scale = scale
        self.colour_scale = make_scale(policy, scale, quantity in SIGNED, floor)
        self.scale_entity = scale_entity
        self.on_scale = on_scale
        self.encoder: FieldEncoder = make_field_encoder(mode, jpeg_quality, raw_dtype,
                                                        signed=quantity in SIGNED)
        self._described = False

    def log_static(self, stream: rr.RecordingStream) -> None:
        """Nothing yet: the field describes itself with its first frame."""

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        return None

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """One frame at its simulated time from its (n_particles, dim) positions (m) and
        velocities (m/s; the speed field skips frames without them)."""
        model, positions, velocities, time = (frame.model, frame.positions, frame.velocities,
                                              frame.time)
        if self.quantity == "speed" and velocities is None:
            return
        if not self._described:
            stream.log(self.entity, rr.AnyValues(
                quantity=self.quantity, axis=self.axis, colour_scale=self.scale,
                colour_policy=self.colour_scale.policy), static=True)
            self._described = True
        values = field_values(self.quantity, positions, model.rest_positions, velocities,
                              self.axis)
        self.colour_scale.observe(values, time)
        if self.scale_entity is not None:
            stream.log(self.scale_entity, rr.Scalars(self.colour_scale.limit))
        self.encoder.log(stream, self.entity, lattice_image(values, model.nx, model.ny),
                         self.colour_scale)
        if self.on_scale is not None:
            self.on_scale(self.colour_scale)

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        self.encoder.finish(stream, self.entity)
        return []
