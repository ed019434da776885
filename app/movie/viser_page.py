"""The one place that knows how viser plays a serialised scene in a page (the adapter for
``app.movie.html``).

viser records the messages of a scene and the pauses between them
(``ViserServer.get_scene_serializer``, ``StateSerializer.insert_sleep``) and writes a page that
plays them with no server (``StateSerializer.as_html``: viser's client build, the recording in it
as base64).  That page's player has play/pause, a time field, a time slider and a speed menu; the
slider's thumb carries the playback time (``[role=slider]``'s ``aria-valuenow``, seconds), which
our overlay (title, time, colour bar) reads to follow the player (``PLAYBACK_TIME_JS``).  If a new
viser lays its player out differently, ``tests/test_html_movie.py`` fails on the overlay's time.
"""

from __future__ import annotations

import contextlib
import io
import socket
from typing import Any

import viser

PLAYBACK_TIME_JS = """function playbackSeconds() {
  const thumb = document.querySelector('[role="slider"][aria-valuenow]');
  return thumb === null ? null : parseFloat(thumb.getAttribute('aria-valuenow'));
}"""
"""A JavaScript function ``playbackSeconds()``: the player's time (s), or null before it loads."""
HIDDEN_NOTICES = ".mantine-Notifications-root { display: none !important; }"
"""CSS that hides viser's notices (such as its note on software graphics) over our title."""


def fit_camera_script(centre: tuple[float, float], width: float, height: float, fov: float,
                      free_y: float, shift: float) -> str:
    """A ``<script>`` for ``<head>`` that frames a planar lattice (``width`` x ``height`` m
    around ``centre``, seen from above) for the page's own shape: the camera's distance is
    chosen for the window's width / height, so a phone held upright sees the whole lattice as a
    laptop does.  viser's player reads the initial camera from the page's URL
    (``initialCameraPosition``, ``initialCameraLookAt``), so the script sets them before the
    player starts (a page that already names them keeps them)."""
    return f"""<script>(function () {{
  try {{
    const search = new URLSearchParams(window.location.search);
    if (search.has("initialCameraPosition")) return;
    const aspect = Math.max(0.2, window.innerWidth / Math.max(1, window.innerHeight));
    const tangent = Math.tan({fov} / 2);
    const distance = Math.max({width} / (2 * tangent * aspect * 0.95),
                              {height} / (2 * tangent * {free_y}));
    const y = {centre[1]} + {shift} * 2 * tangent * distance;
    search.set("initialCameraPosition", [{centre[0]}, y, distance].join(","));
    search.set("initialCameraLookAt", [{centre[0]}, y, 0].join(","));
    search.set("initialCameraFar", String(10 * distance));
    window.history.replaceState(null, "", "?" + search.toString() + window.location.hash);
  }} catch (error) {{ /* the camera the file was written with stays */ }}
}})();</script>"""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def start_server() -> viser.ViserServer:
    """A viser server bound to 127.0.0.1 (no page connects to it: it only builds the scene);
    its banner is not printed."""
    with contextlib.redirect_stdout(io.StringIO()):
        return viser.ViserServer(host="127.0.0.1", port=_free_port(), verbose=False)


def stop_server(server: viser.ViserServer) -> None:
    """Stop ``server`` quietly."""
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


def page(serializer: Any, head: str, body: str) -> str:
    """The self-contained page that plays ``serializer``'s recording, with ``head`` added to its
    ``<head>`` and ``body`` (our overlay) at the end of its ``<body>``."""
    document = serializer.as_html(dark_mode=False)
    head = f"<style>{HIDDEN_NOTICES}</style>" + head
    head_end = document.index("</head>")
    document = document[:head_end] + head + document[head_end:]
    body_end = document.rindex("</body>")
    return document[:body_end] + body + document[body_end:]
