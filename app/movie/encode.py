"""Video writers: H.264 MP4, VP9 WebM (both through PyAV) and GIF (Pillow), chosen by suffix.

``open_writer(target, kind, width, height, fps)`` returns an object with ``write(frame)`` for
(height, width, 3) uint8 RGB frames and ``close()``; ``target`` is a path or a binary file object
(``io.BytesIO``).  MP4 is H.264 in yuv420p with the index at the front (``+faststart``), so it plays
in browsers and slide software; WebM is VP9 (if this PyAV build has libvpx-vp9); GIF frames are
reduced, without dithering, to one 256-colour palette: the movie's colour map (192 entries) and 64
greys (background, text), given as ``palette``; without one, taken from the first frame.  Pillow
merges identical consecutive GIF frames into one longer frame (the timing is kept).
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
        raise ValueError(f"the movie must end in .mp4, .webm or .gif, got {Path(path).name!r}")
    return suffix


def available(kind: str) -> bool:
    """True if this machine can write ``kind``."""
    if kind == "gif":
        return True
    try:
        import av
    except ImportError:
        return False
    return ("libx264" if kind == "mp4" else "libvpx-vp9") in av.codecs_available


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
            stream.options = {"preset": "veryfast", "crf": "23"}
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
    def __init__(self, target: str | Path | BinaryIO, width: int, height: int, fps: float,
                 palette: np.ndarray | None = None):
        self.target = target
        self.duration_ms = max(20, round(1000 / fps / 10) * 10)  # GIF counts hundredths
        self.frames: list[Any] = []
        self.palette: Any = None
        if palette is not None:
            from PIL import Image

            table = np.asarray(palette, np.uint8)
            picks = table[np.linspace(0, len(table) - 1, 192).round().astype(int)]
            greys = np.repeat(np.linspace(0, 255, 64).round().astype(np.uint8)[:, None], 3, 1)
            colours = np.concatenate([picks, greys])
            self.palette = Image.new("P", (1, 1))
            self.palette.putpalette(colours.ravel().tolist())

    def write(self, frame: np.ndarray) -> None:
        from PIL import Image

        image = Image.fromarray(frame)
        if self.palette is None:
            self.palette = image.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
        self.frames.append(image.quantize(palette=self.palette, dither=Image.Dither.NONE))

    def close(self) -> None:
        if not self.frames:
            raise ValueError("no frames to write")
        first, *rest = self.frames
        first.save(self.target, format="GIF", save_all=True, append_images=rest,
                   duration=self.duration_ms, loop=0, optimize=False, disposal=1)


def open_writer(target: str | Path | BinaryIO, kind: str, width: int, height: int, fps: float,
                palette: np.ndarray | None = None):
    """A writer of ``kind`` (mp4, webm, gif) for frames of ``width`` x ``height`` pixels;
    ``palette``: (n, 3) uint8 colours the GIF palette must hold (the colour map)."""
    if kind not in KINDS:
        raise ValueError(f"movie kind must be one of {KINDS}, got {kind!r}")
    if kind == "gif":
        return _GifWriter(target, width, height, fps, palette)
    if not available(kind):
        codec = "libx264" if kind == "mp4" else "libvpx-vp9"
        raise ValueError(f"this PyAV build has no {codec} encoder for .{kind}; try .mp4 or .gif")
    if isinstance(target, io.BytesIO) or not isinstance(target, (str, Path)):
        return _AvWriter(target, kind, width, height, fps)
    return _AvWriter(str(target), kind, width, height, fps)
