"""Large lattices go to browsers as pictures: one encoded image per frame, shared by every page.

A point cloud of the 682x383 interference lattice costs 0.8 MB per frame (3 bytes of colour per
particle), sent to every browser separately: 20 MB/s per page at 25 frames/s.  Above
``IMAGE_LIMIT`` particles the points never move (``app.web.view.MOVE_POINTS_LIMIT``: they sit at
their rest sites and only their colours change), so a picture with one pixel per particle shows
exactly the same thing.  ``FieldImage`` puts that picture in the scene (``viser``'s image node, in
the lattice plane z = 0, one lattice spacing per pixel) and replaces its bytes each frame:

* the picture is encoded once per frame (``encode``), whatever the number of pages, and sent as
  one update message in viser's shared (broadcast) buffer; every page's sender reads the same
  bytes;
* ``FORMAT`` and ``QUALITY`` were chosen by ``benchmarks/frame_formats.py`` (bytes against
  peak signal-to-noise ratio on a running interference field);
* the server chooses the frame rate: at most ``MAX_FPS`` pictures per second and no more than
  ``BYTES_PER_SECOND`` per page (a 25 kB picture goes out at 10 frames/s, a 50 kB one at 5), so
  a class of 30 on one Wi-Fi network shares tens of Mbit/s, not Gbit/s;
* and no more than the page's "Pictures per second" (``FieldImage.max_fps``, by default
  ``DEFAULT_FPS``): viser draws the 3-D view on demand, and every scene update makes the page draw
  frames for a quarter of a second; a browser without graphics acceleration spends about 0.2 s of
  its only page thread on each such frame (read back for software compositing), so above about
  one picture a second it draws all the time and clicks wait seconds.  Pictures are dropped, the
  clicks are not; a student with a graphics card picks more pictures per second.

Small lattices keep their spheres and springs (``app.web.view``); ``uses_image`` is the switch.
Backpressure (a slow page gets fewer frames, a page that stops reading is dropped) lives in
``app.web.clients``.
"""

from __future__ import annotations

import io
import time

import numpy as np
import viser
from PIL import Image

from sim.model.lattice import Model

IMAGE_LIMIT = 50_000
"""From this many particles on (and while the points stay at rest), the field is a picture."""
FORMAT = "jpeg444"
"""Image format of the pictures: JPEG with colour at full resolution (see
``benchmarks/frame_formats.py``: at equal bytes it is 3 dB closer to the field than JPEG 4:2:0 or
WebP, whose halved colour resolution blurs one-particle-wide wave crests, and encodes in a few
milliseconds where WebP takes 50-100 ms)."""
QUALITY = 75
"""JPEG quality of the pictures (see ``benchmarks/frame_formats.py``)."""
MAX_FPS = 12.0
"""Most pictures per second sent to the pages."""
MIN_FPS = 2.0
"""Fewest pictures per second sent while the field changes (even if a picture is large)."""
DEFAULT_FPS = 1.0
"""Pictures per second by default (a page without graphics acceleration stays answering)."""
PICTURE_RATES = (1.0, 2.0, 4.0, MAX_FPS)
"""The pictures per second a page may choose."""
BYTES_PER_SECOND = 250_000
"""Bytes per second of pictures aimed at for each page (2 Mbit/s: a class of 30 shares 60 Mbit/s)."""


def uses_image(model: Model, points_move: bool) -> bool:
    """Whether the lattice is drawn as a picture: large (``IMAGE_LIMIT`` particles or more) and
    its points shown at rest (a moving point cloud cannot be one picture)."""
    return model.n_particles >= IMAGE_LIMIT and not points_move


def field_picture(model: Model, colours: np.ndarray) -> np.ndarray:
    """Per-particle colours (n, 3) uint8, particle p = row * nx + column with row 0 at the
    bottom, as a picture (ny, nx, 3) uint8 with row 0 at the top."""
    return np.ascontiguousarray(colours.reshape(model.ny, model.nx, 3)[::-1])


def encode(picture: np.ndarray, image_format: str = FORMAT, quality: int = QUALITY) -> bytes:
    """A picture (h, w, 3) uint8 as ``jpeg`` (colour at half resolution, 4:2:0), ``jpeg444``
    (colour at full resolution; shown as ``jpeg``), ``webp`` or ``png`` bytes."""
    buffer = io.BytesIO()
    image = Image.fromarray(picture, mode="RGB")
    if image_format == "png":
        image.save(buffer, format="PNG", optimize=False, compress_level=6)
    elif image_format == "webp":
        image.save(buffer, format="WEBP", quality=quality, method=4)
    else:
        subsampling = "4:4:4" if image_format == "jpeg444" else "4:2:0"
        image.save(buffer, format="JPEG", quality=quality, subsampling=subsampling)
    return buffer.getvalue()


def frame_rate(frame_bytes: int, budget: float = BYTES_PER_SECOND) -> float:
    """Pictures per second for pictures of ``frame_bytes``: the budget's worth, between
    ``MIN_FPS`` and ``MAX_FPS``."""
    if frame_bytes <= 0:
        return MAX_FPS
    return float(np.clip(budget / frame_bytes, MIN_FPS, MAX_FPS))


def image_pose(model: Model) -> tuple[tuple[float, float, float], float, float]:
    """(centre (m), width (m), height (m)) of the picture: one spacing per particle, centred on
    the rest sites."""
    rest = model.rest_positions
    centre = (float(rest[:, 0].min() + rest[:, 0].max()) / 2,
              float(rest[:, 1].min() + rest[:, 1].max()) / 2, 0.0)
    return centre, model.nx * model.spacing, model.ny * model.spacing


class FieldImage:
    """The picture node of one lattice in the scene; ``show`` sends a new picture when the
    server's frame rate allows (``force`` sends it now, e.g. the first frame after a pause)."""

    def __init__(self, server: viser.ViserServer, model: Model, colours: np.ndarray,
                 name: str = "/lattice/particles") -> None:
        self.model = model
        centre, width, height = image_pose(model)
        picture = field_picture(model, colours)
        self.handle = server.scene.add_image(
            name, picture, render_width=width, render_height=height, format="jpeg",
            jpeg_quality=QUALITY, position=centre, cast_shadow=False, receive_shadow=False,
        )
        self.last_bytes = len(self.handle._data)
        self.sent = 1
        self.bytes_sent = self.last_bytes
        self.encode_seconds = 0.0
        self.max_fps = DEFAULT_FPS
        """The page's choice of pictures per second (the most; the byte budget may send fewer)."""
        self._last_sent = time.perf_counter()

    @property
    def fps(self) -> float:
        """The frame rate the server chose for pictures of the current size."""
        return min(frame_rate(self.last_bytes), self.max_fps)

    def due_now(self) -> bool:
        """Whether the server's frame rate allows a picture now."""
        return time.perf_counter() - self._last_sent >= 1.0 / self.fps

    def show(self, colours: np.ndarray, force: bool = False) -> bool:
        """Encode and send ``colours`` (n, 3) uint8 if a picture is due; returns whether it was
        sent."""
        now = time.perf_counter()
        if not force and not self.due_now():
            return False
        data = encode(field_picture(self.model, colours))
        self.encode_seconds += time.perf_counter() - now
        self.handle._data = data
        self._last_sent = now
        self.last_bytes = len(data)
        self.sent += 1
        self.bytes_sent += len(data)
        return True

    def remove(self) -> None:
        self.handle.remove()
