"""Who may drive the web app: the Host and Origin checks in front of viser's server.

A web page on another site, open in the same browser as the app, can open a websocket to
``http://127.0.0.1:8080`` as easily as our own page can: browsers do not apply the same-origin
policy to websockets, they only send an ``Origin`` header saying which page opened them.  And a
site whose DNS name is re-pointed at 127.0.0.1 ("DNS rebinding") reaches the server with its own
name in the ``Host`` header.  So every request (the page, its files and the websocket) passes
``AccessPolicy.refusal`` before viser sees it:

* the ``Host`` header must name this server: an IP address (which DNS cannot re-point),
  ``localhost``, this machine's host name, or a host the user allowed with ``--allow-origin``;
* a websocket handshake that carries an ``Origin`` (every browser sends one) must come from the
  page's own address (``http://<Host>``) or an origin allowed with ``--allow-origin``.  A
  handshake without an ``Origin`` comes from a program, not a browser page; such a program can
  reach the port anyway and could send any header, so the check would protect nothing there.

viser 1.1.1 has no option for this.  ``checked_server`` wraps the ``process_request`` hook that
viser gives the ``websockets`` server (the documented way to accept or refuse a handshake): it
replaces ``websockets.asyncio.server.serve`` only while the ``ViserServer`` is being built (viser
starts listening inside its constructor), under a lock, and puts it back at once.

Once connected, what a page may send is closed by ``PageGate`` in two layers:

* every websocket message is looked at as it is read, before viser decodes it: only the
  message types in ``PAGE_MESSAGES`` (those the app handles) pass, and at most
  ``MESSAGE_RATE`` a second from one page (a burst of ``MESSAGE_BURST``).  Anything else (a
  request for viser's public share tunnel, a form, a command, a text frame) and anything over
  the rate is counted and dropped there, at the cost of reading its type; a page that keeps
  sending over the rate for ``FLOOD_SECONDS`` is disconnected.  So no message a page sends
  starts anything that reaches the network;
* only value updates for controls the server created, of the control's own type and range,
  from a connected client, pass ``PageGate.accept_page_value``, the one place where page values
  are accepted (anything else is dropped, logged, and the control shown again with the value in
  use on every page); uploads are capped in size and time while they arrive.
"""

from __future__ import annotations

import contextlib
import http
import ipaddress
import logging
import math
import socket
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

import viser
import websockets.asyncio.server

from app.web import viser_adapter
from app.web.join import JOIN_PATH
from app.web.page_messages import (
    FLOOD_SECONDS,
    MESSAGE_RATE,
    PAGE_MESSAGES,
    REFUSED_RATE,
    MessageBudget,
    message_type,
)
from app.web.roles import STUDENT_PATH
from sim.scenes.scene_files import MAX_UPLOAD_BYTES as MAX_SCENE_UPLOAD_BYTES

_SERVE_PATCH_LOCK = threading.Lock()


def _host_name(host_header: str) -> str:
    """The host part of a Host header (``[::1]:8080`` -> ``::1``, ``a.b:80`` -> ``a.b``)."""
    return (urlsplit(f"//{host_header}").hostname or "").lower()


def _is_ip_address(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def _origin_of(url: str) -> str:
    """``scheme://host[:port]`` of a URL, lower-case, without a trailing slash."""
    parts = urlsplit(url.strip())
    if not parts.scheme or not parts.netloc:
        raise ValueError(f"{url!r} is not an origin such as http://teacher-laptop:8080")
    return f"{parts.scheme.lower()}://{parts.netloc.lower()}"


@dataclass
class AccessPolicy:
    """Which Host and Origin headers the server accepts.  ``allowed_origins`` are full origins
    (``http://name:port``) that may also drive the app; ``"*"`` turns the Origin check off."""

    allowed_origins: Sequence[str] = ()
    local_names: set[str] = field(default_factory=set)
    join: bool = False
    """A class: ``JOIN_PATH`` answers with the student page (``redirect``)."""
    refused: int = 0
    """How many requests were refused (for tests and the log)."""

    def __post_init__(self) -> None:
        self.any_origin = "*" in self.allowed_origins
        self.origins = {_origin_of(origin) for origin in self.allowed_origins if origin != "*"}
        names = {"localhost", socket.gethostname().lower(), socket.getfqdn().lower()}
        names |= {_host_name(origin.split("://", 1)[1]) for origin in self.origins}
        self.local_names = {name for name in names | set(self.local_names) if name}

    def host_allowed(self, host_header: str | None) -> bool:
        if not host_header:
            return False
        name = _host_name(host_header)
        return _is_ip_address(name) or name in self.local_names

    def origin_allowed(self, origin: str | None, host_header: str | None) -> bool:
        if origin is None or self.any_origin:
            return True
        try:
            origin = _origin_of(origin)
        except ValueError:
            return False
        if origin in self.origins:
            return True
        own = {f"http://{(host_header or '').lower()}", f"https://{(host_header or '').lower()}"}
        return origin in own

    def redirect(self, path: str, host_header: str | None) -> str | None:
        """Where a request for ``path`` is sent instead: a class's short join address
        (``http://host:port/join``) to the student page, on the address the student used."""
        if not self.join or path.split("?")[0].rstrip("/") != JOIN_PATH or not host_header:
            return None
        return f"/?websocket=ws://{host_header}{STUDENT_PATH}"

    def refusal(self, headers: Any) -> str | None:
        """Why a request with these headers is refused, or None if it may pass."""
        host = headers.get("Host")
        if not self.host_allowed(host):
            return (f"refused: Host {host!r} is not this server (start it with "
                    "--allow-origin http://NAME:PORT to allow that name)")
        if headers.get("Upgrade", "").lower() == "websocket":
            origin = headers.get("Origin")
            if not self.origin_allowed(origin, host):
                return (f"refused: a page from {origin} may not drive this app (start it with "
                        f"--allow-origin {origin} to allow that page)")
        return None


@contextlib.contextmanager
def _checked_serve(policy: AccessPolicy) -> Iterator[None]:
    original = websockets.asyncio.server.serve

    def serve(handler: Any, *args: Any, process_request: Any = None, **kwargs: Any) -> Any:
        def checked(connection: Any, request: Any) -> Any:
            reason = policy.refusal(request.headers)
            if reason is not None:
                policy.refused += 1
                return connection.respond(http.HTTPStatus.FORBIDDEN, reason + "\n")
            target = policy.redirect(request.path, request.headers.get("Host"))
            if target is not None:
                response = connection.respond(http.HTTPStatus.FOUND, f"see {target}\n")
                response.headers["Location"] = target
                return response
            return process_request(connection, request) if process_request else None

        return original(handler, *args, process_request=checked, **kwargs)

    with _SERVE_PATCH_LOCK:
        websockets.asyncio.server.serve = serve  # type: ignore[assignment,misc]
        try:
            yield
        finally:
            websockets.asyncio.server.serve = original  # type: ignore[misc]


def checked_server(policy: AccessPolicy, **viser_arguments: Any) -> viser.ViserServer:
    """A ``viser.ViserServer`` whose every request passes ``policy`` first."""
    with _checked_serve(policy):
        return viser.ViserServer(**viser_arguments)


def check_origins(origins: Sequence[str]) -> None:
    """Raise ValueError with a clear message for an ``--allow-origin`` that is not an origin."""
    for origin in origins:
        if origin != "*":
            _origin_of(origin)


def network_warning(host: str, port: int, scenes_dir: str, recordings_dir: str) -> str:
    """What anyone on the network can do when the server listens beyond this machine."""
    return (
        f"warning: listening on {host}: anyone who can reach this machine on port {port} can open "
        "the page and, without a password, run, pause and change the simulation for everyone, "
        f"load the scene files in {scenes_dir}, upload scenes, download the current one and "
        f"start recordings that are written to {recordings_dir}. Use it on a network you trust "
        "(a classroom), and stop the server (Ctrl+C) afterwards."
    )


# --- what a connected page may send ------------------------------------------------------------

MAX_UPLOAD_BYTES = MAX_SCENE_UPLOAD_BYTES
"""Largest upload a page may announce (the scene reader's own limit)."""
MAX_UPLOAD_SECONDS = 120.0
"""An upload not complete this long after it started is dropped with what it holds."""
MAX_UPLOADS_PER_CLIENT = 2
MAX_TEXT_CHARACTERS = 10_000
"""Longest text a page may put in a text box."""
_LOG = logging.getLogger("oscillators.web")
_LOGGED_PER_CLIENT = 20
"""Refusals logged per client (later ones are counted, not logged: a flood is not a log flood)."""


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class _Bounds:
    """The range of one component of a vector control (its ``min`` / ``max`` at that index)."""

    min: float | None
    max: float | None


def _press_refusal(value: Any, options: Any) -> str | None:
    """Why a press of a button is refused, or None: a button sends ``True``; a button group
    sends the name of the button pressed, one of its ``options``."""
    if options is None:
        return None if value is True else "a button takes only a press"
    if isinstance(value, str) and value in options:
        return None
    return f"a button group takes only one of its buttons' names, not {value!r:.40}"


def _type_refusal(current: Any, value: Any, props: Any) -> str | None:
    """Why ``value`` cannot be a control's value whose value in use is ``current``, or None."""
    if isinstance(current, bool):
        return None if isinstance(value, bool) else f"wants true or false, got {value!r:.40}"
    if isinstance(current, (int, float)):
        if not _is_number(value) or not math.isfinite(value):
            return f"wants a finite number, got {value!r:.40}"
        if isinstance(current, int) and not float(value).is_integer():
            return f"wants a whole number, got {value!r:.40}"
        low, high = getattr(props, "min", None), getattr(props, "max", None)
        if (low is not None and value < low) or (high is not None and value > high):
            return f"wants a number in [{low:g}, {high:g}], got {value:g}"
        return None
    if isinstance(current, str):
        if not isinstance(value, str) or len(value) > MAX_TEXT_CHARACTERS:
            return f"wants text, got {value!r:.40}"
        options = getattr(props, "options", None)
        if options is not None and value not in options:
            return f"wants one of its options, got {value!r:.40}"
        return None
    if isinstance(current, tuple):
        if not isinstance(value, (list, tuple)) or len(value) != len(current):
            return f"wants {len(current)} values, got {value!r:.40}"
        low, high = getattr(props, "min", None), getattr(props, "max", None)
        for index, (old, new) in enumerate(zip(current, value, strict=True)):
            bounds = _Bounds(low[index] if isinstance(low, (tuple, list)) else None,
                             high[index] if isinstance(high, (tuple, list)) else None)
            reason = _type_refusal(old, new, bounds)
            if reason is not None:
                return reason
        return None
    return f"cannot be set from a page ({type(current).__name__})"


class PageGate:
    """Closes viser's protocol around the app: installed on a ``viser.ViserServer`` before any
    page connects.

    * a message whose type the app does not handle (``PAGE_MESSAGES``), or one over the page's
      rate, is dropped as it is read, before viser decodes it (``dropped`` counts them by type);
    * a ``GuiUpdateMessage`` passes only ``accept_page_value``; a refused one is dropped, logged,
      and the control is sent again with the value in use to every page;
    * a client counts as connected from its websocket handshake (viser registers a client, and
      runs the app's checks for it, only after its first camera message: the gate gives viser a
      first camera message at once, so the checks run for every client);
    * an upload must name a control the server created, announce at most ``MAX_UPLOAD_BYTES``
      and arrive within ``MAX_UPLOAD_SECONDS``; parts beyond the announced size, or late, drop it;
      an upload is its page's own: another upload under the same id, or a part of it sent by
      another page, is refused and the upload goes on.
    """

    def __init__(self, server: viser.ViserServer) -> None:
        self.server = server
        self.gui = server.gui
        self.websockets = viser_adapter.websocket_server(server)
        self.connected: set[int] = set()
        self.refused = 0
        """How many messages were dropped (for tests and the log)."""
        self._refused_by_client: dict[int, int] = {}
        self.dropped: dict[str, int] = {}
        """Messages dropped as they were read, by type (``"over the rate"`` for a flood)."""
        self.disconnected = 0
        """Pages disconnected for sending over the rate."""
        self.message_rate = MESSAGE_RATE
        self.role_messages: Callable[[int], frozenset[str] | None] = lambda client_id: None
        """The message types a page's role lets it send (None: all of ``PAGE_MESSAGES``);
        beyond ``REFUSED_RATE`` a second, others are dropped unread."""
        self.flood_seconds = FLOOD_SECONDS
        self._upload_started: dict[str, tuple[int, float]] = {}
        self.upload_seconds = MAX_UPLOAD_SECONDS

    def install(self) -> PageGate:
        _messages = viser_adapter.messages
        self._originals = viser_adapter.gui_handlers(self.gui)
        for message_class, original, checked in (
            (_messages.GuiUpdateMessage, self._originals["update"], self._gui_update),
            (_messages.FileTransferStartUpload, self._originals["start"], self._upload_start),
            (_messages.FileTransferPart, self._originals["part"], self._upload_part),
        ):
            self.websockets.unregister_handler(message_class, original)
            self.websockets.register_handler(message_class, checked)
        # and no handler for viser's share tunnel either, should a message reach dispatch
        for message_class in (_messages.ShareUrlRequest, _messages.ShareUrlDisconnect):
            self.websockets.unregister_handler(message_class)
        self.websockets.on_client_connect(self._connected)
        self.websockets.on_client_disconnect(self._disconnected)
        self.server.get_event_loop().call_soon_threadsafe(self._sweep)
        return self

    # --- the gate ------------------------------------------------------------------------------

    def accept_page_value(self, client_id: int, message: Any) -> str | None:
        """THE place where a value a page sends is accepted: why ``message`` (a
        ``GuiUpdateMessage`` from ``client_id``) is refused, or None to let it through to the
        control's callbacks (which check it against the app's own rules).  Who may change what
        (a role) is checked here too."""
        if client_id not in self.connected:
            return "from a client that is not connected"
        handle = viser_adapter.gui_input(self.gui, message.uuid)
        if handle is None or viser_adapter.control_state(handle).removed:
            return f"for an unknown control {message.uuid!r:.40}"
        updates = message.updates
        if not isinstance(updates, dict) or set(updates) != {"value"}:
            names = sorted(map(str, updates)) if isinstance(updates, dict) else updates
            return f"sets {names!r:.60}; a page may set only a control's value"
        state = viser_adapter.control_state(handle)
        if state.is_button:
            return _press_refusal(updates["value"], getattr(state.props, "options", None))
        if getattr(state.props, "disabled", False):
            return "for a control that is disabled"
        reason = _type_refusal(state.value, updates["value"], state.props)
        return None if reason is None else f"{getattr(state.props, 'label', 'a control')} {reason}"

    # --- handlers ------------------------------------------------------------------------------

    async def _gui_update(self, client_id: int, message: Any) -> None:
        reason = self.accept_page_value(client_id, message)
        if reason is None:
            await self._originals["update"](client_id, message)
            return
        self._refuse(client_id, f"value update {reason}")
        handle = viser_adapter.gui_input(self.gui, getattr(message, "uuid", None))
        state = None if handle is None else viser_adapter.control_state(handle)
        if state is not None and not state.removed and not state.is_button:
            GuiUpdateMessage = viser_adapter.messages.GuiUpdateMessage

            # every page shows the value in use again (the sender's widget shows its own)
            viser_adapter.gui_queue(self.gui).queue_message(
                GuiUpdateMessage(state.uuid, {"value": state.value}))

    def _upload_start(self, client_id: int, message: Any) -> None:
        self._drop_stalled_uploads()
        size, parts = message.size_bytes, message.part_count
        mine = sum(1 for owner, _ in self._upload_started.values() if owner == client_id)
        reason = None
        if client_id not in self.connected:
            reason = "from a client that is not connected"
        elif viser_adapter.gui_input(self.gui, message.source_component_uuid) is None:
            reason = "for an unknown control"
        elif not (isinstance(size, int) and isinstance(parts, int)
                  and 0 <= size <= MAX_UPLOAD_BYTES and 0 <= parts <= max(1, size)):
            reason = f"of {size!r:.20} bytes in {parts!r:.20} parts (at most {MAX_UPLOAD_BYTES:,})"
        elif mine >= MAX_UPLOADS_PER_CLIENT:
            reason = "while this client has uploads in progress"
        elif (message.transfer_uuid in self._upload_started
              or message.transfer_uuid in viser_adapter.upload_states(self.gui)):
            reason = "under an id already in use (each upload needs its own)"
        if reason is not None:
            self._refuse(client_id, f"upload {reason}")
            return
        self._upload_started[message.transfer_uuid] = (client_id, time.monotonic())
        self._originals["start"](client_id, message)

    def _upload_part(self, client_id: int, message: Any) -> None:
        self._drop_stalled_uploads()
        states = viser_adapter.upload_states(self.gui)
        state = states.get(message.transfer_uuid)
        if state is None:
            return
        if state.get("client_id") != client_id:  # another page's upload goes on untouched
            self._refuse(client_id, "upload part for another page's upload")
            return
        content = message.content
        if (not isinstance(content, bytes)
                or state["transferred_bytes"] + len(content) > state["total_bytes"]):
            self._drop_upload(message.transfer_uuid)
            self._refuse(client_id, "upload part beyond the announced size; upload dropped")
            return
        self._originals["part"](client_id, message)
        if message.transfer_uuid not in states:
            self._upload_started.pop(message.transfer_uuid, None)

    def _drop_upload(self, transfer: str) -> None:
        viser_adapter.upload_states(self.gui).pop(transfer, None)
        self._upload_started.pop(transfer, None)

    def _drop_stalled_uploads(self) -> None:
        now = time.monotonic()
        for transfer, (client_id, started) in list(self._upload_started.items()):
            if transfer not in viser_adapter.upload_states(self.gui):
                self._upload_started.pop(transfer, None)
            elif now - started > self.upload_seconds:
                self._drop_upload(transfer)
                self._refuse(client_id, f"upload not complete after {self.upload_seconds:g} s; "
                             "dropped")

    def _sweep(self) -> None:
        """Drop stalled uploads every second, so a client that sends nothing more is dropped
        too (runs on viser's event loop while it runs)."""
        self._drop_stalled_uploads()
        self.server.get_event_loop().call_later(1.0, self._sweep)

    # --- clients -------------------------------------------------------------------------------

    async def _connected(self, connection: Any) -> None:
        self.connected.add(connection.client_id)
        websocket = viser_adapter.live_connection(self.server, connection.client_id)
        if websocket is not None:
            self._read_through_gate(connection.client_id, websocket)
        # viser registers a client (and runs the app's checks for it) at its first camera
        # message: give it one now, the page's own follows
        await viser_adapter.dispatch_from(connection, viser_adapter.messages.ViewerCameraMessage(
            wxyz=(1.0, 0.0, 0.0, 0.0), position=(0.0, 0.0, -5.0), fov=0.9, near=0.01,
            far=1000.0, image_height=720, image_width=1280, look_at=(0.0, 0.0, 0.0),
            up_direction=(0.0, 0.0, 1.0)))

    def _read_through_gate(self, client_id: int, websocket: Any) -> None:
        """Make viser's reads of this page's websocket pass ``PAGE_MESSAGES`` and the rate first
        (viser's reader awaits ``websocket.recv()`` for each message, then decodes it)."""
        receive = websocket.recv
        refusals = MessageBudget(rate=REFUSED_RATE, burst=2.0 * REFUSED_RATE,
                                 tokens=2.0 * REFUSED_RATE, last=time.monotonic())
        budget = MessageBudget(rate=self.message_rate, burst=2.0 * self.message_rate,
                               tokens=2.0 * self.message_rate, last=time.monotonic())

        closing: list[float] = []

        async def gated_receive(*args: Any, **kwargs: Any) -> Any:
            while True:
                raw = await receive(*args, **kwargs)
                now = time.monotonic()
                if not budget.take(now):
                    self._drop(client_id, "over the rate")
                    if budget.flooding(now, self.flood_seconds) and not closing:
                        closing.append(now)
                        self.disconnected += 1
                        _LOG.warning("client %s: disconnected: more than %g messages a second "
                                     "for %g s", client_id, budget.rate, self.flood_seconds)
                        await websocket.close(1008, "too many messages")
                    continue
                kind = message_type(raw)
                if kind in PAGE_MESSAGES:
                    narrowed = self.role_messages(client_id)
                    if narrowed is None or kind in narrowed or refusals.take(now):
                        return raw  # (a few refused ones pass, to be answered on the page)
                    self._drop(client_id, "not for this page's role")
                    continue
                self._drop(client_id, kind if kind is not None else "not a viser message")

        websocket.recv = gated_receive

    def _drop(self, client_id: int, kind: str) -> None:
        self.dropped[kind] = self.dropped.get(kind, 0) + 1
        self._refuse(client_id, f"{kind:.60} (a message the app does not take)"
                     if kind != "over the rate" else "message over the rate")

    async def _disconnected(self, connection: Any) -> None:
        self.connected.discard(connection.client_id)
        self._refused_by_client.pop(connection.client_id, None)
        for transfer, (owner, _) in list(self._upload_started.items()):
            if owner == connection.client_id:
                self._drop_upload(transfer)

    def _refuse(self, client_id: int, what: str) -> None:
        self.refused += 1
        count = self._refused_by_client.get(client_id, 0) + 1
        self._refused_by_client[client_id] = count
        if count <= _LOGGED_PER_CLIENT:
            _LOG.warning("client %s: dropped a %s", client_id, what)
        elif count == _LOGGED_PER_CLIENT + 1:
            _LOG.warning("client %s: further dropped messages are not logged", client_id)
