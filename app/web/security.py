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
"""

from __future__ import annotations

import contextlib
import http
import ipaddress
import socket
import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

import viser
import websockets.asyncio.server

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
