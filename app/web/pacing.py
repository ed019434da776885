"""Each page gets the newest picture as soon as it has shown the previous one.

A large lattice goes to the pages as one picture per frame (``app.web.frames``), encoded once
and sent to each page through its own message buffer, so that every page gets pictures at the
pace it can show them:

* **the page's acknowledgement.**  After each picture the server asks that page for a value of
  its local storage (viser's ``LocalStorageGetItemRequestMessage``).  viser's page applies every
  message that touches its 3-D scene inside its render loop, in order, so the reply comes back
  when the page has taken the picture in, at the start of a drawn frame; the server then asks
  once more, and that reply comes from the page's next frame, by which time the picture (decoded
  in between) is on the screen.  A page drawing a frame in 5 ms replies at once; a page without
  graphics acceleration (0.1-0.2 s a frame in software) replies as its frames get done.  Only
  then is that page sent the next picture (the newest one, encoded by then), so a page never
  holds a picture it has not drawn (viser's page drops a picture still being decoded when the
  next one comes), and a slow page gets fewer pictures while the others go on;
* **time to answer.**  A page that took long (over ``SLOW_DRAW``) to draw a picture can be left
  ``IDLE_SHARE`` times as long without one before the next.  0 by default: a page drawing in
  software answers a click within about one of its frames however many pictures it gets, and
  the idle time cost it pictures (``benchmarks/web_clicks.py``, figures in ``docs/web.md``);
* **at most** ``MAX_FPS`` pictures a second per page and ``BYTES_PER_SECOND`` of pictures per
  page (a class on one Wi-Fi network), whatever the page could take;
* a page that does not reply within ``ACK_TIMEOUT`` seconds (a program speaking viser's protocol
  that ignores the request, a tab the browser froze) gets the next picture anyway, at that slow
  pace.

``PicturePacer`` keeps one picture node per page (``client.scene.add_image``: the node and its
updates travel in that page's buffer, in order) and the state of each page; it runs on the
frame pump's thread (``publish``) and on viser's event loop (the replies).
"""

from __future__ import annotations

import dataclasses
import itertools
import threading
import time
from collections.abc import Callable
from typing import Any

import viser

from app.web import viser_adapter

MAX_FPS = 15.0
"""Most pictures per second sent to one page."""
BYTES_PER_SECOND = 480_000
"""Bytes per second of pictures aimed at for each page (3.8 Mbit/s: the flagship's pictures,
80 kB late in the run, 6 times a second; a class of 30 shares about 115 Mbit/s at most)."""
IDLE_SHARE = 0.0
"""After a page took more than ``SLOW_DRAW`` seconds to draw a picture, it is left this many
times as long before the next picture (a page with a graphics card draws in milliseconds, so
nothing changes for it).  0: a page drawing in software then shows more pictures and answers
clicks about as fast (``docs/web.md``, "Pictures at the pace of each page")."""
SLOW_DRAW = 0.15
"""Seconds from a picture sent to the page's second reply above which the page is slow to draw
(a page with a graphics card on a busy network replies in two round trips and a frame)."""
ENCODE_AHEAD = 0.08
"""Seconds before a page may have its next picture from which that picture is encoded (longer
than the frame pump's gap between two frames, 0.04 s, plus an encoding): the picture is ready
when the page is, also while the page's second reply is still on its way."""
ACK_TIMEOUT = 3.0
"""Seconds after which a page that has not replied gets the next picture anyway."""
ACK_PREFIX = "picture-shown-"
"""Start of the request ids of the acknowledgements (the page echoes them)."""
ACK_KEY = "oscillators-picture"
"""The local-storage key asked for (never written: the reply is what counts)."""


@dataclasses.dataclass
class PageState:
    """What the pacer knows of one page."""

    handle: Any
    serial: int = 0
    """The serial number of the newest picture sent to the page."""
    waiting: str | None = None
    """The request id of the acknowledgement awaited, or None."""
    sent_at: float = -1e9
    last_bytes: int = 0
    sent: int = 0
    bytes_sent: int = 0
    acknowledged: int = 0
    scheduled: bool = False
    """A delayed send (byte budget) is already scheduled on the event loop."""
    draw_seconds: float = 0.0
    """How long the page took from a picture sent to its second reply (smoothed)."""
    confirming: bool = False
    """The page took the picture in; the reply awaited now says it drew a frame since."""


class PicturePacer:
    """Per-page delivery of one shared stream of encoded pictures.

    ``make_node(client, data)`` creates the picture node in one page's scene showing ``data``
    and returns its handle (whose ``_data`` the pacer replaces).  ``max_fps()`` is the most
    pictures per second the app allows now (the View folder's choice)."""

    def __init__(self, server: viser.ViserServer, make_node: Callable[[Any, bytes], Any],
                 max_fps: Callable[[], float] = lambda: MAX_FPS,
                 budget: float = BYTES_PER_SECOND,
                 on_ready: Callable[[], Any] | None = None) -> None:
        self.server = server
        self.on_ready = on_ready
        """Called when a page that has the newest picture becomes ready for another (the app
        then pictures its newest frame without waiting for the next one)."""
        self.make_node = make_node
        self.max_fps = max_fps
        self.budget = budget
        self.pages: dict[int, PageState] = {}
        self.serial = 0
        self.data: bytes | None = None
        self._ids = itertools.count()
        self._lock = threading.RLock()
        self._handler = self._acknowledged
        viser_adapter.on_local_storage_reply(server, self._handler)

    # --- the stream -------------------------------------------------------------------------------

    def publish(self, data: bytes) -> None:
        """A new picture: send it to every page that is ready for one (the others get it, or a
        newer one, when they reply)."""
        with self._lock:
            self.serial += 1
            self.data = data
        self.sync_pages()
        now = time.monotonic()
        for client_id in list(self.pages):
            self._offer(client_id, now)

    def wanted(self) -> bool:
        """Whether a page will take a new picture within ``ENCODE_AHEAD`` seconds (it has the
        newest, has taken it in or drawn it, and its rate allows one by then): the pump encodes
        a picture only then, and the page gets it as soon as it may."""
        now = time.monotonic()
        with self._lock:
            if self.data is None:
                return True
            return any((page.waiting is None or page.confirming) and page.serial >= self.serial
                       and now >= self._next_allowed(page) - ENCODE_AHEAD
                       for page in self.pages.values()) or any(
                page.waiting is not None and now - page.sent_at > ACK_TIMEOUT
                for page in self.pages.values())

    def sync_pages(self) -> None:
        """Create the picture node of each page that came, forget the pages that left."""
        clients = self.server.get_clients()
        with self._lock:
            for client_id in [c for c in self.pages if c not in clients]:
                del self.pages[client_id]
            data = self.data
            for client_id, client in clients.items():
                if client_id not in self.pages and data is not None:
                    page = PageState(handle=self.make_node(client, data), serial=self.serial,
                                     sent_at=time.monotonic(), last_bytes=len(data))
                    self.pages[client_id] = page
                    self._ask(client, page)

    def remove(self) -> None:
        """Take every page's picture node away and stop listening to replies."""
        with self._lock:
            pages, self.pages = self.pages, {}
        for page in pages.values():
            page.handle.remove()
        viser_adapter.off_local_storage_reply(self.server, self._handler)

    # --- one page ---------------------------------------------------------------------------------

    def _next_allowed(self, page: PageState) -> float:
        rate = max(0.1, min(MAX_FPS, self.max_fps()))
        drawing = page.draw_seconds if page.draw_seconds > SLOW_DRAW else 0.0
        return page.sent_at + max(1.0 / rate, page.last_bytes / self.budget,
                                  (1.0 + IDLE_SHARE) * drawing)

    def _offer(self, client_id: int, now: float) -> None:
        """Send the newest picture to a page if it is ready; if only its budget holds it back,
        send it when the budget allows."""
        with self._lock:
            page = self.pages.get(client_id)
            if page is None or self.data is None or page.serial >= self.serial:
                return
            if page.waiting is not None and now - page.sent_at < ACK_TIMEOUT:
                return
            due = self._next_allowed(page)
            if now < due:
                if not page.scheduled:
                    page.scheduled = True
                    self._later(due - now, client_id)
                return
            client = self.server.get_clients().get(client_id)
            if client is None:
                return
            data, page.serial = self.data, self.serial
            viser_adapter.set_image_bytes(page.handle, data)
            page.sent_at, page.last_bytes = now, len(data)
            page.sent += 1
            page.bytes_sent += len(data)
            page.confirming = False
            self._ask(client, page)

    def _ask(self, client: Any, page: PageState) -> None:
        """Ask the page to say when it has drawn what it was sent."""
        page.waiting = f"{ACK_PREFIX}{next(self._ids)}"
        viser_adapter.ask_local_storage(client, ACK_KEY, page.waiting)
        client.flush()

    def _later(self, delay: float, client_id: int) -> None:
        loop = viser_adapter.event_loop(self.server)
        if loop is None or loop.is_closed():
            return

        def run() -> None:
            with self._lock:
                page = self.pages.get(client_id)
                if page is not None:
                    page.scheduled = False
                has_newest = page is not None and page.serial >= self.serial
            self._offer(client_id, time.monotonic())
            if has_newest and self.on_ready is not None:
                self.on_ready()

        try:
            loop.call_soon_threadsafe(loop.call_later, delay, run)
        except RuntimeError:  # the loop closed meanwhile
            pass

    def _acknowledged(self, client_id: int, message: Any) -> None:
        """A page replied (on viser's event loop): it has drawn its picture; send the newest."""
        request = getattr(message, "request_uuid", "")
        if not isinstance(request, str) or not request.startswith(ACK_PREFIX):
            return
        with self._lock:
            page = self.pages.get(client_id)
            if page is None or page.waiting != request:
                return
            if not page.confirming:  # taken in: ask again, answered after the next frame
                client = self.server.get_clients().get(client_id)
                if client is not None:
                    page.confirming = True
                    self._ask(client, page)
                    return
            page.waiting = None
            page.acknowledged += 1
            took = time.monotonic() - page.sent_at
            page.draw_seconds = took if page.acknowledged == 1 else (
                0.7 * page.draw_seconds + 0.3 * took)
            has_newest = page.serial >= self.serial
        self._offer(client_id, time.monotonic())
        if has_newest and self.on_ready is not None:
            self.on_ready()
