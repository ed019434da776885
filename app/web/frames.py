"""Large lattices go to browsers as pictures: one encoded image per frame, shared by every page.

A point cloud of the 682x383 interference lattice costs 0.8 MB per frame (3 bytes of colour per
particle), sent to every browser separately: 20 MB/s per page at 25 frames/s.  Above
``IMAGE_LIMIT`` particles the points never move (``app.web.view.MOVE_POINTS_LIMIT``: they sit at
their rest sites and only their colours change), so a picture with one pixel per particle shows
exactly the same thing.  ``FieldImage`` puts that picture in each page's scene (``viser``'s image
node, in the lattice plane z = 0, one lattice spacing per pixel) and replaces its bytes:

* the picture is encoded once (``encode``), whatever the number of pages; every page is sent
  the same bytes (viser appends them to its message without copying or compressing them);
* ``FORMAT`` and ``QUALITY`` were chosen by ``benchmarks/frame_formats.py`` (bytes against
  peak signal-to-noise ratio on a running interference field); as the waves fill the lattice with
  fine detail the encoding steps down ``PICTURE_STEPS`` so that a picture stays near
  ``PICTURE_BYTES`` and each page still gets ``PICTURES_AIMED`` a second within its byte
  budget;
* each page gets the newest picture as soon as it has drawn the previous one, at most
  ``MAX_FPS`` a second and ``BYTES_PER_SECOND`` per page (``app.web.pacing``): a page without
  graphics acceleration, which spends 0.1-0.2 s of its only thread on each drawn frame, gets a
  picture per frame it draws and stays answering; a slow page gets fewer pictures and never
  slows the others; the View folder's "Pictures per second" can lower the most for every page;
* a picture is encoded only when some page is ready for one.

Small lattices keep their spheres and springs (``app.web.view``); ``uses_image`` is the switch.
A page that stops reading altogether is dropped by ``app.web.clients``.
"""

from __future__ import annotations

import io
import time
from collections.abc import Callable

import numpy as np
import viser
from PIL import Image

from app.web import viser_adapter
from app.web.pacing import BYTES_PER_SECOND, MAX_FPS, PicturePacer  # noqa: F401 (re-exported)
from sim.model.lattice import Model

IMAGE_LIMIT = 50_000
"""From this many particles on (and while the points stay at rest), the field is a picture."""
FORMAT = "jpeg444"
"""Image format of the pictures: JPEG with colour at full resolution (see
``benchmarks/frame_formats.py``: at equal bytes it is 3 dB closer to the field than JPEG 4:2:0 or
WebP, whose halved colour resolution blurs one-particle-wide wave crests, and encodes in a few
milliseconds where WebP takes 50-100 ms)."""
QUALITY = 75
"""JPEG quality of the pictures while they are small (see ``benchmarks/frame_formats.py``)."""
PICTURE_STEPS = tuple((FORMAT, quality) for quality in range(QUALITY, 35, -5)) + (
    ("jpeg", 50), ("jpeg", 40))
"""The encodings (format, JPEG quality) a picture steps down through as the field grows
fine-grained (``next_step``), best first.  The flagship at t = 180 s, 682x383 shown 1.5 times
larger: 152 kB at 4:4:4 quality 75, 88 kB at 50, 72 kB at 40, then 57 and 49 kB with colour at
half resolution (4:2:0) at 50 and 40 (24.9, 21.7, 20.9, 20.0 and 19.7 dB), with no difference to
see between them at that size; the halved colour only costs where the field is still smooth
enough to afford full resolution, so it comes last."""
PICTURES_AIMED = 6.5
"""Pictures a second each page's byte budget is to hold (a page shows a few of them late, or
not at all when the next comes while it still decodes one, so it shows at least five)."""
PICTURE_BYTES = BYTES_PER_SECOND / PICTURES_AIMED
"""Bytes a picture aims at: ``PICTURES_AIMED`` pictures a second fit each page's byte budget."""
DEFAULT_FPS = MAX_FPS
"""Pictures per second by default: as many as each page draws, up to ``MAX_FPS``."""
PICTURE_RATES = (1.0, 2.0, 4.0, MAX_FPS)
"""The most pictures per second the View folder may choose for every page."""


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


def next_step(step: int, picture_bytes: int) -> int:
    """The encoding (index into ``PICTURE_STEPS``) of the next picture after one of
    ``picture_bytes`` at ``step``: a step down while pictures are larger than ``PICTURE_BYTES``, a
    step back up while they are under 70 % of it.  Late in a run the waves fill the lattice with
    fine detail and a picture at quality 75 takes 150-190 kB, so the byte budget alone would hold
    each page under 3 pictures a second."""
    if picture_bytes > PICTURE_BYTES and step < len(PICTURE_STEPS) - 1:
        return step + 1
    if picture_bytes < 0.7 * PICTURE_BYTES and step > 0:
        return step - 1
    return step


def image_pose(model: Model) -> tuple[tuple[float, float, float], float, float]:
    """(centre (m), width (m), height (m)) of the picture: one spacing per particle, centred on
    the rest sites."""
    rest = model.rest_positions
    centre = (float(rest[:, 0].min() + rest[:, 0].max()) / 2,
              float(rest[:, 1].min() + rest[:, 1].max()) / 2, 0.0)
    return centre, model.nx * model.spacing, model.ny * model.spacing


class FieldImage:
    """The picture of one lattice, a node in each page's own scene; ``show`` encodes a new
    picture when some page is ready for one (``force``: now, e.g. a frame while paused) and
    hands it to the pacer."""

    def __init__(self, server: viser.ViserServer, model: Model, colours: np.ndarray,
                 name: str = "/lattice/particles",
                 on_ready: Callable[[], object] | None = None) -> None:
        self.model = model
        self.name = name
        self.max_fps = DEFAULT_FPS
        """The View folder's choice of pictures per second (the most, for every page)."""
        self.pacer = PicturePacer(server, self._make_node, max_fps=lambda: self.max_fps,
                                  on_ready=on_ready)
        self.sent = 0
        self.bytes_sent = 0
        self.last_bytes = 0
        self.step = 0
        """The encoding of the next picture, an index into ``PICTURE_STEPS`` (``next_step``)."""
        self.encode_seconds = 0.0
        self._last_encoded = -1e9
        self.frame: object = None
        """The frame the newest picture shows (set by the view)."""
        self.show(colours, force=True)

    def _make_node(self, client: viser.ClientHandle, data: bytes) -> viser.ImageHandle:
        centre, width, height = image_pose(self.model)
        handle = client.scene.add_image(
            self.name, np.zeros((1, 1, 3), np.uint8), render_width=width, render_height=height,
            format="jpeg", jpeg_quality=QUALITY, position=centre, cast_shadow=False,
            receive_shadow=False,
        )
        viser_adapter.set_image_bytes(handle, data)
        return handle

    def due_now(self) -> bool:
        """Whether a new picture would go to some page now (at most ``MAX_FPS`` encodings a
        second)."""
        if time.perf_counter() - self._last_encoded < 1.0 / MAX_FPS:
            return False
        return self.pacer.wanted()

    def show(self, colours: np.ndarray, force: bool = False) -> bool:
        """Give each page that came its picture node; encode ``colours`` (n, 3) uint8 and send
        it if a picture is due (or ``force``); returns whether it was encoded."""
        self.pacer.sync_pages()
        now = time.perf_counter()
        if not force and not self.due_now():
            return False
        data = encode(field_picture(self.model, colours), *PICTURE_STEPS[self.step])
        self.encode_seconds += time.perf_counter() - now
        self._last_encoded = now
        self.last_bytes = len(data)
        self.step = next_step(self.step, len(data))
        self.sent += 1
        self.bytes_sent += len(data)
        self.pacer.publish(data)
        return True

    def remove(self) -> None:
        self.pacer.remove()
