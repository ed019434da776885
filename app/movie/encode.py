"""Video writers: H.264 MP4, VP9 WebM (both through PyAV) and GIF (Pillow), chosen by suffix.

``open_writer(target, kind, width, height, fps)`` returns an object with ``write(frame)`` for
(height, width, 3) uint8 RGB frames and ``close()``; ``target`` is a path or a binary file object
(``io.BytesIO``).  MP4 is H.264 in yuv420p with the index at the front (``+faststart``), so it plays
in browsers and slide software; WebM is VP9 (if this PyAV build has libvpx-vp9); GIF frames are
reduced, without dithering, to one 256-colour palette: the movie's colour map (192 entries) and 64
greys (background, text), given as ``palette``; without one, taken from the first frame.  Every
kind is encoded frame by frame as frames come (GIF by ffmpeg's GIF encoder, which stores only the
rectangle that changed), so memory does not grow with the length of the movie.
"""

from __future__ import annotations

import io
from fractions import Fraction
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

KINDS = ("mp4", "webm", "gif")


def kind_of(path: str | Path) -> str:
    """The movie kind from a file name's suffix (.mp4, .webm, .gif)."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in KINDS:
        raise ValueError(f"the movie must end in .mp4, .webm, .gif (or .html: one page, "
                         f"`oscillators movie`), got {Path(path).name!r}")
    return suffix


CODECS = {"mp4": "libx264", "webm": "libvpx-vp9", "gif": "gif"}
H264_OPTIONS = {"preset": "medium", "crf": "31"}
"""libx264's settings for MP4: measured by ``benchmarks/movie_settings.py`` on the flagship's
default movie (1000 frames at 1280x720 of fine waves that the adaptive colour scale shows
everywhere): veryfast at CRF 23 wrote 53.5 MB, medium at CRF 31 15.1 MB, while the decoded
frames stay as close to the drawn ones (PSNR 23.9 and 23.0 dB: yuv420p's half-resolution colour
limits both) and the interference cells stay as sharp to the eye; the encoder takes about twice
the CPU time (its own thread, beside the simulation and the drawing)."""


def available(kind: str) -> bool:
    """True if this machine can write ``kind``."""
    try:
        import av
    except ImportError:
        return False
    return CODECS[kind] in av.codecs_available


class _AvWriter:
    def __init__(self, target: str | Path | BinaryIO, kind: str, width: int, height: int,
                 fps: float) -> None:
        import av

        self._av = av
        rate = Fraction(fps).limit_denominator(1000)
        options = {"movflags": "+faststart"} if kind == "mp4" else {}
        self.container = av.open(target, mode="w", format=kind, options=options)
        if kind == "mp4":
            stream = self.container.add_stream("libx264", rate=rate)
            stream.options = dict(H264_OPTIONS)
        else:
            stream = self.container.add_stream("libvpx-vp9", rate=rate)
            stream.options = {"crf": "36", "b": "0", "deadline": "realtime", "cpu-used": "8",
                              "row-mt": "1"}
        stream.width, stream.height = width, height
        stream.pix_fmt = "yuv420p"
        stream.codec_context.time_base = 1 / rate
        self.stream = stream
        self.index = 0

    def write(self, frame: np.ndarray) -> None:
        video_frame = self._av.VideoFrame.from_ndarray(frame, format="rgb24")
        video_frame.pts = self.index
        self.index += 1
        self.container.mux(self.stream.encode(video_frame))

    def close(self) -> None:
        self.container.mux(self.stream.encode(None))
        self.container.close()


class _GifWriter:
    """GIF frames streamed into the file as they come (ffmpeg's GIF encoder through PyAV,
    which stores only what changed since the previous frame); memory does not grow with the
    number of frames."""

    def __init__(self, target: str | Path | BinaryIO, width: int, height: int, fps: float,
                 palette: np.ndarray | None = None):
        import av
        from PIL import Image

        self._av = av
        # GIF counts hundredths of a second: the frame rate the file can hold
        rate = Fraction(100, max(2, round(100 / fps)))
        self.container = av.open(target if not isinstance(target, Path) else str(target),
                                 mode="w", format="gif")
        self.stream = self.container.add_stream("gif", rate=rate)
        self.stream.width, self.stream.height = width, height
        self.stream.pix_fmt = "pal8"
        self.stream.codec_context.time_base = 1 / rate
        self.palette: Any = None
        self.argb: np.ndarray | None = None
        if palette is not None:
            table = np.asarray(palette, np.uint8)
            picks = table[np.linspace(0, len(table) - 1, 192).round().astype(int)]
            greys = np.repeat(np.linspace(0, 255, 64).round().astype(np.uint8)[:, None], 3, 1)
            self._use_palette(np.concatenate([picks, greys]))
        self._image = Image
        self.index = 0

    def _use_palette(self, colours: np.ndarray) -> None:
        """(256, 3) uint8 RGB: the palette of every frame."""
        from PIL import Image

        self.palette = Image.new("P", (1, 1))
        self.palette.putpalette(colours.ravel().tolist())
        self.argb = np.empty((256, 4), np.uint8)  # PyAV's pal8 palette: A, R, G, B bytes
        self.argb[:, 0] = 255
        self.argb[:, 1:] = colours

    def write(self, frame: np.ndarray) -> None:
        Image = self._image
        image = Image.fromarray(frame)
        if self.palette is None:
            quantised = image.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
            colours = np.zeros((256, 3), np.uint8)
            used = np.asarray(quantised.getpalette()[: 3 * 256], np.uint8).reshape(-1, 3)
            colours[: len(used)] = used
            self._use_palette(colours)
        indices = np.asarray(image.quantize(palette=self.palette, dither=Image.Dither.NONE))
        video_frame = self._av.VideoFrame.from_ndarray((np.ascontiguousarray(indices), self.argb),
                                                       format="pal8")
        video_frame.pts = self.index
        self.index += 1
        self.container.mux(self.stream.encode(video_frame))

    def close(self) -> None:
        if not self.index:
            raise ValueError("no frames to write")
        self.container.mux(self.stream.encode(None))
        self.container.close()


def open_writer(target: str | Path | BinaryIO, kind: str, width: int, height: int, fps: float,
                palette: np.ndarray | None = None):
    """A writer of ``kind`` (mp4, webm, gif) for frames of ``width`` x ``height`` pixels;
    ``palette``: (n, 3) uint8 colours the GIF palette must hold (the colour map)."""
    if kind not in KINDS:
        raise ValueError(f"movie kind must be one of {KINDS}, got {kind!r}")
    if not available(kind):
        raise ValueError(f"this PyAV build has no {CODECS[kind]} encoder for .{kind}; try .mp4")
    if kind == "gif":
        return _GifWriter(target, width, height, fps, palette)
    if isinstance(target, io.BytesIO) or not isinstance(target, (str, Path)):
        return _AvWriter(target, kind, width, height, fps)
    return _AvWriter(str(target), kind, width, height, fps)
