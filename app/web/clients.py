"""Backpressure: a slow page gets fewer frames, a page that stops reading is dropped.

How a frame reaches the pages (viser 1.1.1, ``viser.infra``): the server puts every scene update
into one shared broadcast buffer, and each connected page has a sender task that walks the buffer
with its own cursor and ``await``s the websocket's ``send``; ``send`` waits while the socket's
write buffer is above its high-water mark, that is while the page (or its network) is not taking
the bytes.  The buffer keeps only the newest update of each property of each scene node
(``redundancy_key``), so the picture a slow page has not yet been sent is replaced by the next one:
**the latest frame wins**, a slow page simply gets fewer frames, and the buffer never holds more
than one pending picture, whatever the number of pages.  Nothing of this waits on the
simulation: the runner thread publishes frames to the frame pump, which keeps only the latest
(``app.web.app``), so the simulation runs at the same speed with 0 or 30 pages.

What viser does not do is let go of a page that stops reading (a laptop lid closed mid-lesson):
its sender waits in ``send`` until the websocket's keep-alive gives up (20 s + 20 s), holding its
socket buffer.  ``ClientWatch`` caps each page's socket send buffer at ``SEND_BUFFER`` and
checks once a second whether each page's sender has moved on in the buffer; a page whose sender
is stuck behind newer messages for ``STALL_TIMEOUT`` seconds is disconnected (its socket
aborted; viser then runs its disconnect callbacks, which release whatever it was dragging).  A
browser that comes back reconnects by itself.
"""

from __future__ import annotations

import socket
import sys
import threading
import time
from typing import Any

import viser

from app.web import viser_adapter

STALL_TIMEOUT = 10.0
"""Seconds a page may take nothing while newer frames wait before it is disconnected."""
CHECK_PERIOD = 1.0
"""Seconds between two checks."""
SEND_BUFFER = 256 * 1024
"""Bytes the operating system may hold for one page (a few pictures): without a limit Linux lets
a socket's send buffer grow to megabytes, memory held for a page that may never read it."""


def limit_send_buffer(connection: Any, size: int = SEND_BUFFER) -> None:
    """Cap the kernel's send buffer of a page's socket at ``size`` bytes."""
    transport = getattr(connection, "transport", None)
    sock = transport.get_extra_info("socket") if transport is not None else None
    if sock is not None:
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, size)
        except OSError:  # not a TCP socket (tests), or the platform refuses: keep its default
            pass


class ClientWatch:
    """Disconnects pages that stop reading.  ``start()`` / ``stop()``; ``dropped`` lists the
    client ids let go of."""

    def __init__(self, server: viser.ViserServer, timeout: float = STALL_TIMEOUT,
                 period: float = CHECK_PERIOD) -> None:
        self.server = server
        self.timeout = timeout
        self.period = period
        self.dropped: list[int] = []
        self._progress: dict[int, tuple[int, float]] = {}
        """client id -> (its sender's cursor, when it last moved or was up to date)."""
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> ClientWatch:
        self._thread = threading.Thread(target=self._run, name="web-client-watch", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stopping.set()
        if self._thread is not None:
            self._thread.join(5.0)

    def _run(self) -> None:
        while not self._stopping.wait(self.period):
            loop = viser_adapter.event_loop(self.server)
            if loop is None or loop.is_closed():
                continue
            try:
                loop.call_soon_threadsafe(self.check)
            except RuntimeError:  # the loop closed meanwhile (the server stopped)
                return

    def check(self, now: float | None = None) -> list[int]:
        """Disconnect the pages stuck for ``timeout`` seconds; returns their ids.  Runs on
        viser's event loop (where the connections live)."""
        now = time.monotonic() if now is None else now
        buffer = viser_adapter.broadcast_buffer(self.server)
        newest = buffer.message_counter - 1
        live = viser_adapter.live_connections(self.server)
        stuck = []
        for client_id, connection in live.items():
            if client_id not in self._progress:
                limit_send_buffer(connection)
            cursor = buffer.generator_cursors.get(client_id)
            if cursor is None:
                continue
            last_cursor, since = self._progress.get(client_id, (cursor, now))
            if cursor != last_cursor or cursor >= newest:
                since = now
            self._progress[client_id] = (cursor, since)
            if now - since >= self.timeout:
                stuck.append(client_id)
                transport = getattr(connection, "transport", None)
                if transport is not None:
                    transport.abort()
        for client_id in list(self._progress):
            if client_id not in live or client_id in stuck:
                del self._progress[client_id]
        for client_id in stuck:
            self.dropped.append(client_id)
            print(f"web page: disconnected page {client_id}: it took no frames for "
                  f"{self.timeout:.0f} s", file=sys.stderr)
        return stuck
