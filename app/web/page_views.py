"""What the server learns of each page's view through a short script: its size in CSS pixels,
and whether its browser draws WebGL in software (then it draws the scene at a lower resolution).

**The view's size.**  viser reports a page's view as its canvas's size in device pixels (CSS
pixels times the drawing resolution: 2x on a Retina laptop, 3x on many phones, 0.75x when viser's
page lowers its resolution because frames are slow).  Where the lattice goes beside the panel and
whether the page is laid out as a phone depend on CSS pixels, so each page writes its window's
size in CSS pixels into its local storage (``KEY_PREFIX`` and its client id; again on every
resize) and the server reads it back (viser's ``LocalStorageGetItemRequestMessage``) on
connecting and whenever the canvas's size changes; ``css_size`` is the latest, checked (finite,
``SMALLEST``..``LARGEST`` pixels) before it is used.

**Drawing in software.**  A browser without graphics acceleration (Chrome's SwiftShader, Mesa's
llvmpipe, Windows' Basic Render Driver: an old laptop, a virtual machine, a remote desktop) draws
each frame of the 3-D view on the page's only thread: at 1366x768 a frame of the flagship costs
it 120-220 ms, and the page shows two or three pictures a second and answers a click in over a
second.  viser's page lowers its resolution by itself only to 0.75 of the screen's pixel ratio.
The script asks WebGL which renderer draws the page; a software renderer's page reloads itself
once with viser's ``fixedDpr`` page setting at ``SOFTWARE_PIXEL_RATIO`` times its pixel ratio
(the rest of the address, the teacher link's included, is kept; the run plays on over the
reload, ``app.web.app.RECONNECT_GRACE``).  A page with a graphics card, or one opened with its
own ``fixedDpr``, is left as it is.  The panel, its plots and texts are HTML and keep their
sharpness; the field picture of a large lattice has about one pixel per particle.
"""

from __future__ import annotations

import json
import math
import re
import threading
from collections.abc import Callable
from typing import Any

import viser

from app.web import phone, viser_adapter

SOFTWARE_PIXEL_RATIO = 0.5
"""The drawing resolution of a page drawing in software, as a fraction of its pixel ratio."""
SOFTWARE_RENDERERS = ("swiftshader", "llvmpipe", "softpipe", "software", "basic render")
"""Words in WebGL's renderer name that mark drawing in software (case does not matter)."""
KEY_PREFIX = "oscillators-view-"
"""Start of the local-storage key a page writes its view's size under (then its client id)."""
SMALLEST, LARGEST = 100, 20_000
"""The CSS sizes (pixels) taken from a page; anything else is ignored."""

_SCRIPT = """
(() => {
  const key = KEY;
  const report = () => {
    try {
      localStorage.setItem(key, JSON.stringify([window.innerWidth, window.innerHeight]));
    } catch (error) {}
  };
  report();
  window.addEventListener("resize", report);
  const params = new URLSearchParams(window.location.search);
  if (params.has("fixedDpr")) return;
  let name = "";
  try {
    const gl = document.createElement("canvas").getContext("webgl");
    const info = gl && gl.getExtension("WEBGL_debug_renderer_info");
    name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
    const lose = gl && gl.getExtension("WEBGL_lose_context");
    if (lose) lose.loseContext();
  } catch (error) {
    return;
  }
  if (!PATTERN.test(name)) return;
  const ratio = Math.round(100 * RATIO * (window.devicePixelRatio || 1)) / 100;
  params.set("fixedDpr", String(ratio));
  window.location.replace(
    window.location.pathname + "?" + params.toString() + window.location.hash);
})();
"""


def script(client_id: int, ratio: float = SOFTWARE_PIXEL_RATIO) -> str:
    """The script sent to page ``client_id``: report the view's size, and reload at ``ratio``
    of the pixel ratio if WebGL draws in software."""
    pattern = "/" + "|".join(re.escape(word) for word in SOFTWARE_RENDERERS) + "/i"
    key = f"{viser_adapter.LOCAL_STORAGE_PREFIX}{KEY_PREFIX}{int(client_id)}"
    return (_SCRIPT.replace("KEY", json.dumps(key))
            .replace("PATTERN", pattern).replace("RATIO", repr(float(ratio))))


def parse_size(value: Any) -> tuple[int, int] | None:
    """A page's reported (width, height) in CSS pixels, or None if it is not two sizes within
    ``SMALLEST``..``LARGEST``."""
    if not isinstance(value, str) or len(value) > 100:
        return None
    try:
        size = json.loads(value)
    except ValueError:
        return None
    if not isinstance(size, list) or len(size) != 2:
        return None
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
               and SMALLEST <= v <= LARGEST for v in size):
        return None
    return int(size[0]), int(size[1])


class PageViews:
    """Each page's view size in CSS pixels (``css_size``, ``view_size``); ``on_size(client)`` is
    called when a page's size arrives or changes (the app fits that page's camera again).  The
    page is asked on connecting and whenever its canvas changes size (a resize, or another
    drawing resolution)."""

    def __init__(self, server: viser.ViserServer, on_size: Callable[[Any], None],
                 ratio: float = SOFTWARE_PIXEL_RATIO) -> None:
        self.server = server
        self.on_size = on_size
        self.ratio = ratio
        self.sizes: dict[int, tuple[int, int]] = {}
        self._lock = threading.Lock()
        viser_adapter.on_local_storage_reply(server, self._reply)
        server.on_client_connect(self._connected)
        server.on_client_disconnect(self._left)

    def css_size(self, client_id: int) -> tuple[int, int] | None:
        """The page's latest view size (width, height) in CSS pixels, or None if not known."""
        with self._lock:
            return self.sizes.get(client_id)

    def view_size(self, client: Any) -> tuple[int, int]:
        """The page's view (width, height) in CSS pixels once the page said it, else its
        canvas's pixels, else (0, 0) before the page reported its view."""
        size = self.css_size(client.client_id)
        if size is not None:
            return size
        try:
            return client.camera.image_width, client.camera.image_height
        except AssertionError:  # the page has not reported its view yet
            return 0, 0

    def ask(self, client: Any) -> None:
        """Ask the page for its view's size (the reply calls ``on_size`` if it changed)."""
        key = f"{KEY_PREFIX}{client.client_id}"
        viser_adapter.ask_local_storage(client, key, key)
        client.flush()

    def _connected(self, client: Any) -> None:
        viser_adapter.run_javascript(client, script(client.client_id, self.ratio))
        viser_adapter.run_javascript(client, phone.FOLD)
        self.ask(client)
        canvas = {"size": (0, 0)}

        @client.camera.on_update
        def _(camera: Any) -> None:
            size = (camera.image_width, camera.image_height)
            if size != canvas["size"] and all(size):
                canvas["size"] = size
                self.ask(client)

    def _left(self, client: Any) -> None:
        with self._lock:
            self.sizes.pop(client.client_id, None)

    def _reply(self, client_id: int, message: Any) -> None:
        if getattr(message, "request_uuid", None) != f"{KEY_PREFIX}{client_id}":
            return
        size = parse_size(getattr(message, "value", None))
        if size is None:
            return
        with self._lock:
            changed = self.sizes.get(client_id) != size
            self.sizes[client_id] = size
        client = self.server.get_clients().get(client_id)
        if changed and client is not None:
            self.on_size(client)
