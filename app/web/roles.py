"""A class: one teacher drives the shared run, every other page watches (``serve --class``).

A page's role follows from how it connected, never from when:

* the **teacher** is a page opened with the teacher link that ``serve --class`` prints,
  ``http://HOST:PORT/?websocket=ws://HOST:PORT/teacher/TOKEN``, or a page opened on the server's
  own machine (its websocket comes from a loopback address).  viser's page opens its websocket at
  the page's address without the query string, except that a ``websocket=`` parameter names that
  address; so the link makes the page connect to the path ``/teacher/TOKEN`` and the server reads
  the token from the websocket handshake.  ``TOKEN`` is random (``secrets``, 96 bits) and new for
  every server unless given (``serve --teacher-token``, so that a teacher's page keeps its role
  when the server is restarted);
* every other page is a **student**, and so is a page opened with the student link
  (``.../?websocket=ws://HOST:PORT/student``: the teacher's own machine showing what students
  see).  A student page sees the run, the colour bar, the plots and the read-outs and moves its
  own camera; its copy of every shared control is shown disabled (``disable_controls``).  A click
  on the lattice selects a particle for that page only: a red marker in its own scene and a
  read-out of the particle's displacement in its own panel.  Nothing else it sends reaches the
  app.

A viser page reconnects by itself when its connection drops or the server restarts; it comes
back at the same address, by the same link, so it gets the same role: a student's page that
reconnects first cannot take the run.

``ClassRoles.gate`` is the one check: it sits in front of viser's dispatch of every message a
page sends (``install``), so whatever a student page sends (a button, a slider, a dropdown, a
drag of the gizmo, an upload, a shared-selection click), from the page or from a program
speaking viser's protocol, is refused on the server and counted in ``refused``; a refused
control is set back on that page to the value in use.  Only a page's own camera and its replies pass (the
requests answered, ``viser_adapter.is_reply_or_camera``).  Without ``--class`` there are no roles.
"""

from __future__ import annotations

import ipaddress
import secrets
import sys
import threading
import time
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit

import numpy as np
import viser

from app.web import viser_adapter
from app.web.inputs import as_html
from app.web.join import join_html
from sim.runtime.runner import Frame

TEACHER_PATH = "/teacher/"
"""Websocket path prefix of the teacher link (followed by the token)."""
STUDENT_PATH = "/student"
"""Websocket path of the student link (a student page, even on the server's own machine)."""
CONTROLS_CHECK = 1.0
"""Seconds between two checks that each student page shows the shared controls disabled."""
PROBE_INTERVAL = 0.5
"""Seconds between two updates of a student's own read-out."""
STUDENT_NOTE = ("Student view: the teacher runs this lattice (the shared controls are greyed "
                "out). Move the camera as you like; click a particle to follow it yourself.")


def is_loopback(address: object) -> bool:
    """Whether a peer address (``(host, port, ...)`` or a host) is this machine's loopback."""
    host = address[0] if isinstance(address, (tuple, list)) and address else address
    try:
        ip = ipaddress.ip_address(str(host).split("%")[0])
    except ValueError:
        return False
    mapped = getattr(ip, "ipv4_mapped", None)
    return (mapped or ip).is_loopback


def role_for(path: str, remote: object, token: str) -> str:
    """The role of a page whose websocket asked for ``path`` from the peer address ``remote``:
    ``teacher`` by the teacher link (its token) or from this machine, ``student`` by the
    student link or from anywhere else."""
    if path.startswith(TEACHER_PATH) and secrets.compare_digest(
            path[len(TEACHER_PATH):].split("?")[0].encode(), token.encode()):
        return "teacher"
    if path.startswith(STUDENT_PATH):
        return "student"
    return "teacher" if is_loopback(remote) else "student"


class ClassRoles:
    """Teacher and student pages of one server.  ``pick(ray_origin, ray_direction)`` returns
    the particle under a pointer ray (or None); ``install()`` puts the gate in front of viser."""

    def __init__(self, server: viser.ViserServer,
                 pick: Callable[[Any, Any], int | None], token: str | None = None) -> None:
        self.server = server
        self.pick = pick
        self.token = token or secrets.token_urlsafe(12)
        self.teachers: set[int] = set()
        self.students: set[int] = set()
        self.refused: list[tuple[int, str]] = []
        """(client id, message type) of every message refused."""
        self._lock = threading.Lock()
        self._probes: dict[int, dict[str, Any]] = {}
        self._last_probe_update = 0.0
        self._disabled: dict[int, dict[str, object]] = {}
        """student client id -> {control uuid: its shared ``disabled`` when sent disabled}."""
        self._last_controls_check = 0.0
        self.join_url: str | None = None
        """The class's join address (``app.web.join``), shown with its QR code on teachers'
        pages once set."""

    # --- roles -----------------------------------------------------------------------------------

    def teacher_link(self, page_url: str) -> str:
        """The teacher link for a page address ``http://host:port``."""
        return self._link(page_url, f"{TEACHER_PATH}{self.token}")

    def student_link(self, page_url: str) -> str:
        """The student link for a page address ``http://host:port``."""
        return self._link(page_url, STUDENT_PATH)

    @staticmethod
    def _link(page_url: str, path: str) -> str:
        parts = urlsplit(page_url)
        scheme = "wss" if parts.scheme == "https" else "ws"
        return f"{page_url}/?websocket={scheme}://{parts.netloc}{path}"

    def arrived(self, client_id: int) -> str:
        """Give a page whose websocket just opened its role (``teacher`` or ``student``), before
        anything it sends is read: by its link or its address, whoever came first."""
        connection = viser_adapter.live_connection(self.server, client_id)
        path = getattr(getattr(connection, "request", None), "path", "") or ""
        role = role_for(path, getattr(connection, "remote_address", None), self.token)
        with self._lock:
            (self.teachers if role == "teacher" else self.students).add(client_id)
        return role

    def greet(self, client: viser.ClientHandle) -> None:
        """Tell a student page, in its own panel, what it may do, and grey out its shared
        controls."""
        if client.client_id in self.students:
            client.gui.add_html(as_html(STUDENT_NOTE, color="#1f5eea", bold=True), order=-2.0)
            self.disable_controls(client)
        elif self.join_url is not None:
            client.gui.add_html(join_html(self.join_url), order=-2.0)

    def disable_controls(self, client: viser.ClientHandle) -> int:
        """Show every shared control disabled on a student's page (that page alone): each one
        not yet sent, and each one whose shared state the server changed since (a change sent to
        every page would enable it there).  Returns how many were sent."""
        connection = viser_adapter.client_queue(client)
        count = 0
        with self._lock:
            if client.client_id not in self.students:
                return 0
            shown = self._disabled.setdefault(client.client_id, {})
            for uuid, handle in list(viser_adapter.gui_inputs(self.server.gui).items()):
                shared = getattr(viser_adapter.control_state(handle).props, "disabled", None)
                if shown.get(uuid, "unsent") == shared:
                    continue
                viser_adapter.show_control(connection, uuid, {"disabled": True})
                shown[uuid] = shared
                count += 1
        return count

    def left(self, client_id: int) -> None:
        with self._lock:
            self.teachers.discard(client_id)
            self.students.discard(client_id)
            self._probes.pop(client_id, None)
            self._disabled.pop(client_id, None)

    # --- the gate --------------------------------------------------------------------------------

    def install(self) -> ClassRoles:
        """Put ``gate`` in front of viser's dispatch of the messages pages send, and follow
        pages connecting and leaving."""
        websocket_server = viser_adapter.websocket_server(self.server)
        dispatch = viser_adapter.incoming_dispatch(self.server)

        async def gated(client_id: int, message: Any) -> None:
            if self.gate(client_id, message):
                await dispatch(client_id, message)

        async def opened(connection: Any) -> None:  # on the event loop, before any message
            self.arrived(connection.client_id)

        async def closed(connection: Any) -> None:
            self.left(connection.client_id)

        viser_adapter.replace_incoming_dispatch(self.server, gated)
        websocket_server.on_client_connect(opened)
        websocket_server.on_client_disconnect(closed)
        self.server.on_client_connect(self.greet)
        return self

    def gate(self, client_id: int, message: Any) -> bool:
        """Whether ``message`` from page ``client_id`` may reach the app.  A student page may
        send its own camera and replies to the server's requests; its click goes to its own
        probe instead; anything else a student sends is refused."""
        if client_id in self.teachers or viser_adapter.is_reply_or_camera(message):
            return True
        if viser_adapter.is_pointer(message):
            click = viser_adapter.pointer_click(message)
            if click is not None:
                self.student_click(client_id, *click)
            return False
        name = viser_adapter.message_name(message)
        self.refused.append((client_id, name))
        if len(self.refused) == 1 or len(self.refused) % 100 == 0:
            print(f"web page: refused {len(self.refused)} change(s) from student pages "
                  f"(the last a {name} from page {client_id})", file=sys.stderr)
        update = viser_adapter.control_update(message)
        if update is not None:
            self._restore(client_id, *update)
        return False

    def _restore(self, client_id: int, uuid: Any, updates: dict) -> None:
        """Set a refused control back, on that page, to the value in use."""
        handle = viser_adapter.gui_input(self.server.gui, uuid)
        client = self.server.get_clients().get(client_id)
        if handle is None or client is None:
            return
        state = viser_adapter.control_state(handle)
        current = {name: getattr(state, name) for name in updates if hasattr(state, name)}
        if current:
            viser_adapter.show_control(viser_adapter.client_queue(client), uuid, current)

    # --- a student's own probe -------------------------------------------------------------------

    def student_click(self, client_id: int, ray_origin: Any, ray_direction: Any) -> int | None:
        """Select the particle under the ray for this student page only (shown at the next
        ``update``)."""
        particle = self.pick(ray_origin, ray_direction)
        if particle is None:
            return None
        with self._lock:
            if client_id in self.students:
                self._probes.setdefault(client_id, {})["particle"] = particle
        self._last_probe_update = 0.0
        return particle

    def update(self, frame: Frame) -> None:
        """Follow a frame: move each student's marker and refresh its read-out (at most every
        ``PROBE_INTERVAL`` seconds)."""
        now = time.perf_counter()
        if now - self._last_controls_check >= CONTROLS_CHECK:
            self._last_controls_check = now
            clients = self.server.get_clients()
            for client_id in list(self.students):
                if client_id in clients:
                    self.disable_controls(clients[client_id])
        if not self._probes or now - self._last_probe_update < PROBE_INTERVAL:
            return
        self._last_probe_update = now
        clients = self.server.get_clients()
        model = frame.model
        for client_id, probe in list(self._probes.items()):
            client = clients.get(client_id)
            particle = probe.get("particle")
            if client is None or particle is None or particle >= model.n_particles:
                continue
            if "readout" not in probe:
                probe["readout"] = client.gui.add_html("", order=-1.0)
            position = np.zeros(3, np.float32)
            position[: model.dim] = frame.positions[particle]
            position[2] += 0.5 * model.spacing  # in front of a field picture in the plane z = 0
            marker = probe.get("marker")
            if marker is None:
                size = max(1.5, 0.02 * max(model.nx, model.ny)) * model.spacing  # seen at any size
                probe["marker"] = client.scene.add_point_cloud(
                    "/my_particle", position[None], (255, 30, 30),
                    point_size=size, point_shape="circle", precision="float32")
            else:
                marker.points = position[None]
            displacement = frame.positions[particle] - model.rest_positions[particle]
            row, column = divmod(int(particle), model.nx)
            probe["readout"].content = as_html(
                f"my particle (column {column}, row {row}) at t = {frame.time:.2f} s: "
                f"displacement {np.linalg.norm(displacement):.3e} m",
                color="#b00000")
