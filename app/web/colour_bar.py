"""The page's colour bar: what the colours mean (quantity, units, the numbers of the scale in
use), always in view whatever the camera does.

* On a laptop (views ``app.web.view.NARROW`` CSS pixels wide or more) the bar is a picture in a small window
  of its own that floats over the bottom-left corner of the 3-D view (viser's standalone panel,
  ``gui.add_panel``, holding a GUI image): fixed on the screen, not in the scene, so zooming or
  panning never loses it, and a new scale is a panel update (the page changes one ``<img>``;
  its 3-D view is not redrawn for it).
* On a phone viser shows every panel, that window included, as a section of the bottom sheet,
  hidden when the sheet is folded to its title bar.  So each narrow page also gets the bar in
  its own scene (``client.scene``: only that page sees it) under the lattice, where the camera
  fit (``app.web.view.camera_fit``) keeps it in view above the folded panel.

``ColourBar.show`` is called by the view (the frame pump thread) when the bar's numbers change;
nothing here posts commands (the picture has no callbacks).
"""

from __future__ import annotations

import threading

import numpy as np
import viser

from app.web.equilibrium import sag
from sim.model.lattice import Model

PHONE_BAR_WIDTH, PHONE_BAR_HEIGHT = 320, 124
"""Pixels of a phone's colour bar picture (``phone_picture``)."""
BAR_ASPECT = PHONE_BAR_HEIGHT / PHONE_BAR_WIDTH
"""Height / width of a phone's colour bar picture."""
PHONE_BAR_SPAN = 0.9 * 1.0 / (1.0 - 0.9 * 1.0 * BAR_ASPECT)
"""A phone's bar is at least this many times as wide as the lattice and the gap above the bar
are tall: then, in a free part of the view about as wide as tall (a phone's above its panel),
the bar spans about 90 % of the view's width whatever the lattice's shape, so its text keeps
its size on a tall lattice too."""
PHONE_FONTS = (16, 14)
"""Pixel sizes of a phone's bar's title and of its numbers and caption: shown as wide as a
lattice about 250 CSS px wide or more, they stay at least 11 CSS px."""
OVERLAY_WIDTH = 400
"""CSS pixels of the floating colour bar's window."""
OVERLAY_HEIGHT = 130
"""CSS pixels the floating window takes at the bottom of a laptop's view (its grip, its tab
and the picture), which the camera fit leaves free under the lattice."""
OVERLAY_MARGIN = 12
"""CSS pixels between the floating window and the view's left and bottom edges."""


def _wrapped(draw, text: str, font, width: float, lines: int) -> list[str]:
    """``text`` in at most ``lines`` lines no wider than ``width`` px (words kept whole)."""
    rows: list[str] = []
    for word in text.split():
        if rows and draw.textlength(f"{rows[-1]} {word}", font=font) <= width:
            rows[-1] = f"{rows[-1]} {word}"
        else:
            rows.append(word)
    return rows[:lines]


def phone_picture(scheme, scale, label: str, lines: bool = False) -> np.ndarray:
    """A colour bar for a phone as a (``PHONE_BAR_HEIGHT``, ``PHONE_BAR_WIDTH``, 3) uint8 RGB
    picture on white: the title (``label``) and the scale in words wrapped in two lines each,
    in ``PHONE_FONTS`` (large for its width, so readable when a phone draws it under the
    lattice), the map and the numbers of ``scale`` at its ticks."""
    from PIL import Image, ImageDraw, ImageFont

    big, small = (ImageFont.load_default(size=size) for size in PHONE_FONTS)
    width, height = PHONE_BAR_WIDTH, PHONE_BAR_HEIGHT
    image = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    margin, text = 6, (30, 30, 30)
    y = 3
    for row in _wrapped(draw, label, big, width - 2 * margin, 2):
        draw.text((margin, y), row, fill=text, font=big)
        y += PHONE_FONTS[0] + 3
    bar_top, bar_height, bar_width = 2 * (PHONE_FONTS[0] + 3) + 5, 16, width - 2 * margin
    table = (scheme.lines if lines else scheme.field).table()
    pixels = np.asarray(image).copy()
    pixels[bar_top : bar_top + bar_height, margin : margin + bar_width] = \
        table[np.linspace(0, 255, bar_width).round().astype(int)][None]
    image = Image.fromarray(pixels)
    draw = ImageDraw.Draw(image)
    marks = scale.ticks()
    for k, (position, value) in enumerate(marks):
        x = margin + position * (bar_width - 1)
        draw.line([(x, bar_top + bar_height), (x, bar_top + bar_height + 3)], fill=text)
        anchor = "la" if k == 0 else "ra" if k == len(marks) - 1 else "ma"
        draw.text((x, bar_top + bar_height + 4), f"{value:.2g}" if value else "0", fill=text,
                  font=small, anchor=anchor)
    y = bar_top + bar_height + 6 + PHONE_FONTS[1]
    for row in _wrapped(draw, scale.describe(), small, width - 2 * margin, 2):
        draw.text((margin, y), row, fill=(90, 90, 90), font=small)
        y += PHONE_FONTS[1] + 2
    return np.asarray(image)


def bar_width(model: Model) -> float:
    """Width (m) of a phone's in-scene bar: the lattice's, or ``PHONE_BAR_SPAN`` times the height
    of the lattice (sagged) and the gap above the bar, whichever is larger."""
    a = model.spacing
    tall = (model.ny + 1) * a + sum(sag(model)[2:]) + 1.5 * a
    return max((model.nx + 1) * a, PHONE_BAR_SPAN * tall)


def bar_pose(model: Model) -> tuple[tuple[float, float, float], float, float]:
    """(centre (m), width (m), height (m)) of a phone's in-scene bar: centred under the
    lattice, 1.5 spacings below its lowest row (at its sagged equilibrium under gravity)."""
    width = bar_width(model)
    height = width * BAR_ASPECT
    down = sag(model)[2]
    centre = (model.origin[0] + (model.nx - 1) * model.spacing / 2,
              model.origin[1] - down - 1.5 * model.spacing - height / 2, 0.0)
    return centre, width, height


class ColourBar:
    """The colour bar on every page: a floating window on laptops, an in-scene picture on
    phones (see the module's docstring)."""

    def __init__(self, server: viser.ViserServer) -> None:
        self.server = server
        self._lock = threading.Lock()
        self._panel: viser.PanelHandle | None = None
        self._image: viser.GuiImageHandle | None = None
        self.picture: np.ndarray | None = None
        """The bar shown now (height, width, 3) uint8, or None."""
        self.phone: np.ndarray | None = None
        """The bar phones show now in their scenes, or None."""
        self._model: Model | None = None
        self._phones: dict[int, tuple[viser.ClientHandle, viser.ImageHandle | None]] = {}
        self.updates = 0
        """How many bars were sent (for tests)."""

    def show(self, picture: np.ndarray, model: Model, phone: np.ndarray | None = None) -> None:
        """Show ``picture`` (an ``app.colours.colour_bar``) for a lattice ``model``, and on
        phones ``phone`` (a ``phone_picture``; default ``picture``)."""
        with self._lock:
            new_lattice = model is not self._model
            self.picture, self._model = picture, model
            self.phone = picture if phone is None else phone
            if self._panel is None:
                self._panel = self.server.gui.add_panel(order=-1)
                with self._panel.add_tab("Colours"):
                    self._image = self.server.gui.add_image(picture, format="png")
                self._panel.float(x=OVERLAY_MARGIN, y=-OVERLAY_MARGIN, width=OVERLAY_WIDTH)
            else:
                assert self._image is not None
                self._image.image = picture
            for client_id in list(self._phones):
                self._draw_in_scene(client_id, new_lattice)
            self.updates += 1

    def hide(self) -> None:
        """No colour bar (the particles carry no colour): every page's bar goes."""
        with self._lock:
            if self._panel is not None:
                self._panel.remove()
            self._panel = self._image = self.picture = self.phone = None
            for client_id, (client, handle) in list(self._phones.items()):
                if handle is not None:
                    handle.remove()
                self._phones[client_id] = (client, None)

    def set_narrow(self, client: viser.ClientHandle, narrow: bool) -> None:
        """``client``'s view is a phone's (``narrow``) or a laptop's: a phone gets the bar in
        its own scene too."""
        with self._lock:
            known = client.client_id in self._phones
            if narrow and not known:
                self._phones[client.client_id] = (client, None)
                self._draw_in_scene(client.client_id, True)
            elif not narrow and known:
                _, handle = self._phones.pop(client.client_id)
                if handle is not None:
                    handle.remove()

    def client_left(self, client_id: int) -> None:
        with self._lock:
            self._phones.pop(client_id, None)

    def _draw_in_scene(self, client_id: int, new_lattice: bool) -> None:
        client, handle = self._phones[client_id]
        if self.phone is None or self._model is None:
            return
        picture = np.ascontiguousarray(self.phone[::-1])  # image rows run along -y
        if handle is not None and not new_lattice:
            handle.image = picture
            return
        if handle is not None:
            handle.remove()
        centre, width, height = bar_pose(self._model)
        try:
            handle = client.scene.add_image("/colour_bar", picture, render_width=width,
                                            render_height=height, format="png", position=centre)
        except Exception:  # noqa: BLE001 - the page went away meanwhile
            handle = None
        self._phones[client_id] = (client, handle)
