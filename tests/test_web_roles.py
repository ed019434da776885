"""A class (``WebApp(class_mode=True)``): roles by the teacher link (or this machine), never by
the order pages come in, kept when a page reconnects; what a student page sends straight over the
websocket never changes the shared run, the same messages from the teacher do, a student's page
shows the shared controls disabled, a student's click selects a particle for that page only; and a
page that stops reading is disconnected."""

from __future__ import annotations

import asyncio
import socket

import msgspec
import numpy as np
import pytest
import viser
import websockets
import zstandard

import sim
from app.web.app import WebApp
from app.web.roles import STUDENT_PATH, TEACHER_PATH, role_for
from tests.helpers import free_port, wait_for

PROTOCOL = [f"viser-v{viser.__version__}"]


@pytest.fixture
def class_app(tmp_path):
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings",
                 class_mode=True)
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None)
    yield app
    app.stop()


def gui_update(handle, value) -> dict:
    return {"type": "GuiUpdateMessage", "uuid": handle._impl.uuid, "updates": {"value": value}}


def page_changes(app: WebApp, particle: int, target: tuple[float, float, float]) -> list[dict]:
    """What a page sends to play, reset, change dt, the integrator and gravity, and drag a
    particle, as the browser would send it."""
    panel = app.panel
    return [
        gui_update(panel.run.play_button, True),
        gui_update(panel.run.reset_button, True),
        gui_update(panel.integrator.dt, 0.004),
        gui_update(panel.integrator.method, "rk4"),
        gui_update(panel.physics.gravity_on, True),
        {"type": "TransformControlsDragStartMessage", "name": "/selection_gizmo", "owner": ""},
        {"type": "TransformControlsUpdateMessage", "name": "/selection_gizmo",
         "wxyz": (1.0, 0.0, 0.0, 0.0), "position": target, "owner": ""},
    ]


CAMERA = {"type": "ViewerCameraMessage", "wxyz": (1.0, 0.0, 0.0, 0.0), "position": (0.0, 0.0, 10.0),
          "fov": 1.0, "near": 0.01, "far": 1000.0, "image_height": 600, "image_width": 800,
          "look_at": (0.0, 0.0, 0.0), "up_direction": (0.0, 1.0, 0.0)}
"""A browser's first message: its camera (viser counts a page as connected from then on)."""


async def send_all(url: str, messages: list[dict], connections: list) -> None:
    async with websockets.connect(url, subprotocols=PROTOCOL, max_size=None) as connection:
        connections.append(connection)
        await connection.recv()  # the page's first window: the connection is registered
        await connection.send(msgspec.msgpack.encode(CAMERA))
        await asyncio.sleep(0.3)
        for message in messages:
            await connection.send(msgspec.msgpack.encode(message))
        await asyncio.sleep(1.0)  # let the server dispatch them


def run_pages(app: WebApp, teacher: list[dict], student: list[dict]) -> None:
    """A teacher page (by the teacher link) and then a student page (by the student link: the
    test's pages all come from this machine, whose plain pages are teachers) send their
    messages."""
    url = f"ws://127.0.0.1:{app.server.get_port()}"

    async def both() -> None:
        connections: list = []
        teacher_task = asyncio.create_task(
            send_all(f"{url}{TEACHER_PATH}{app.roles.token}", teacher, connections))
        while not connections:
            await asyncio.sleep(0.01)
        while not app.roles.teachers:
            await asyncio.sleep(0.01)
        await send_all(f"{url}{STUDENT_PATH}", student, [])
        await teacher_task

    asyncio.run(both())


def state(app: WebApp) -> dict:
    simulation = app.runner.simulation
    return {"playing": app.runner.playing, "step": simulation.step_count, "dt": simulation.dt,
            "integrator": simulation.integrator, "gravity": simulation.model.has_gravity,
            "positions": simulation.positions.copy(), "pins": dict(app.runner.pins)}


def test_student_changes_are_refused_and_teacher_changes_are_not(class_app):
    app = class_app
    app.control.single_step().result(timeout=30)  # something for Reset to undo
    app.set_selection(np.array([40]))
    assert wait_for(lambda: app._gizmo is not None)
    target = tuple(float(v) for v in app.view.last_positions[40]) + (0.0,)
    target = (target[0] + 0.3 * app.runner.simulation.model.spacing, target[1], 0.0)
    before = state(app)

    run_pages(app, teacher=[], student=page_changes(app, 40, target))
    after = state(app)
    assert after["playing"] is False and after["step"] == before["step"]
    assert after["dt"] == before["dt"] and after["integrator"] == before["integrator"]
    assert after["gravity"] is False and not after["pins"]
    np.testing.assert_array_equal(after["positions"], before["positions"])
    refused = [kind for _, kind in app.roles.refused]
    assert refused.count("GuiUpdateMessage") == 5
    assert "TransformControlsUpdateMessage" in refused
    assert app.panel.integrator.dt.value == before["dt"]  # the shared control kept its value

    # the same messages from the teacher page do change the run (they are well formed)
    run_pages(app, teacher=page_changes(app, 40, target), student=[])
    simulation = app.runner.simulation
    assert wait_for(lambda: simulation.dt == 0.004 and simulation.integrator == "rk4")
    assert wait_for(lambda: app.runner.simulation.model.has_gravity)
    assert app.runner.playing or app.runner.steps_taken > 0


def test_roles_follow_the_link_and_the_address_never_the_order():
    token = "k3y-0f-the-teacher-link"
    remote = ("192.168.1.23", 50123)
    assert role_for(f"{TEACHER_PATH}{token}", remote, token) == "teacher"
    assert role_for(f"{TEACHER_PATH}{token}x", remote, token) == "student"
    assert role_for(f"{TEACHER_PATH}", remote, token) == "student"
    assert role_for("/", remote, token) == "student"  # whether it is the first page or not
    assert role_for("/", ("127.0.0.1", 40000), token) == "teacher"  # the server's own machine
    assert role_for("/", ("::1", 40000, 0, 0), token) == "teacher"
    assert role_for("/", ("::ffff:127.0.0.1", 40000, 0, 0), token) == "teacher"
    assert role_for("/", ("::ffff:10.0.0.7", 40000, 0, 0), token) == "student"
    assert role_for(STUDENT_PATH, ("127.0.0.1", 40000), token) == "student"
    assert role_for("/", None, token) == "student"


def test_a_student_first_stays_a_student_and_a_reconnect_keeps_its_role(class_app):
    """A student page connects before any teacher and is a student; it sees the shared
    controls disabled (the teacher's page does not); pages that go and come back (viser's pages
    reconnect by themselves) come back with the same role."""
    app = class_app
    url = f"ws://127.0.0.1:{app.server.get_port()}"
    teacher_url = f"{url}{TEACHER_PATH}{app.roles.token}"
    play = app.panel.run.play_button._impl.uuid

    def disabled_play(received: list[dict]) -> bool:
        return any(m.get("type") == "GuiUpdateMessage" and m.get("uuid") == play
                   and (m.get("updates") or {}).get("disabled") is True for m in received)

    async def visit(address: str, seconds: float = 2.0) -> tuple[str, list[dict]]:
        """Connect, say the camera, listen for ``seconds`` (or until Play is shown disabled);
        the role given and what was received."""
        received: list[dict] = []
        decompressor = zstandard.ZstdDecompressor()
        async with websockets.connect(address, subprotocols=PROTOCOL, max_size=None) as page:
            await page.send(msgspec.msgpack.encode(CAMERA))
            client_id = None
            ends = asyncio.get_running_loop().time() + seconds
            while (left := ends - asyncio.get_running_loop().time()) > 0 and not disabled_play(
                    received):
                try:
                    raw = await asyncio.wait_for(page.recv(), left)
                except TimeoutError:
                    break
                received += decoded(raw, decompressor)
                if client_id is None:
                    client_id = max(app.server._websock_server._live_connections, default=None)
                    role = "teacher" if client_id in app.roles.teachers else "student"
        return role, received

    async def scenario() -> list[tuple[str, list[dict]]]:
        student = f"{url}{STUDENT_PATH}"
        return [await visit(student, 30.0), await visit(teacher_url),
                await visit(student, 30.0), await visit(teacher_url)]

    visits = asyncio.run(scenario())
    assert [role for role, _ in visits] == ["student", "teacher", "student", "teacher"]
    assert [disabled_play(received) for _, received in visits] == [True, False, True, False]
    assert wait_for(lambda: not app.roles.teachers and not app.roles.students)  # all left


def test_the_teacher_link_can_be_kept_across_restarts(tmp_path):
    token = "same-link-after-a-restart"
    for _ in range(2):
        app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=4, ny=3)), port=free_port(),
                     scenes_dir=tmp_path / "s", recordings_dir=tmp_path / "r", class_mode=True,
                     teacher_token=token)
        assert app.roles.token == token
        assert app.roles.teacher_link(app.url).endswith(f"{TEACHER_PATH}{token}")
        app.server.stop()


def decoded(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    size = int.from_bytes(raw[:8], "little")
    compressed = int.from_bytes(raw[8:16], "little")
    payload = decompressor.decompress(raw[16:16 + compressed], max_output_size=size)
    return msgspec.msgpack.decode(payload)["messages"]


def test_student_click_selects_a_particle_for_that_page_only(class_app):
    app = class_app
    particle = 3 * app.runner.simulation.model.nx + 5
    x, y = app.view.last_positions[particle]
    click = {"type": "ScenePointerMessage", "event_type": "click",
             "ray_origin": (float(x), float(y), 10.0), "ray_direction": (0.0, 0.0, -1.0),
             "screen_pos": ((0.5, 0.5),), "modifier": None}
    followed = []
    student_click = app.roles.student_click

    def recording_click(client_id, ray_origin, ray_direction):
        chosen = student_click(client_id, ray_origin, ray_direction)
        followed.append((chosen, dict(app.roles._probes)))
        return chosen

    app.roles.student_click = recording_click
    run_pages(app, teacher=[], student=[click])
    assert app.view.selection.size == 0  # the shared selection is untouched
    [(chosen, probes)] = followed
    assert chosen == particle
    assert [probe["particle"] for probe in probes.values()] == [particle]
    assert not app.roles.refused


@pytest.mark.slow  # waits for the server to give up on a page
def test_a_page_that_stops_reading_is_disconnected(tmp_path):
    app = WebApp(sim.Simulation(sim.scenes.build("interference", nx=40, ny=30)),
                 port=free_port(), play=True, scenes_dir=tmp_path / "s",
                 recordings_dir=tmp_path / "r")
    app.clients.timeout = 2.0
    app.start()
    url = f"ws://127.0.0.1:{app.server.get_port()}"

    async def stall() -> bool:
        async with websockets.connect(url, subprotocols=PROTOCOL, max_size=None,
                                      max_queue=1) as connection:
            sock = connection.transport.get_extra_info("socket")
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 16 * 1024)
            await connection.recv()
            for _ in range(600):  # read nothing more
                if app.clients.dropped:
                    return True
                await asyncio.sleep(0.1)
        return False

    try:
        assert asyncio.run(stall())
    finally:
        app.stop()
