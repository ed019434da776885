"""A class (``WebApp(class_mode=True)``): what a student page sends straight over the websocket
never changes the shared run, the same messages from the teacher do, a student's click selects a
particle for that page only; and a page that stops reading is disconnected."""

from __future__ import annotations

import asyncio
import socket

import msgspec
import numpy as np
import pytest
import viser
import websockets

import sim
from app.web.app import WebApp
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
    """A teacher page (the first to connect) and then a student page send their messages."""
    url = f"ws://127.0.0.1:{app.server.get_port()}"

    async def both() -> None:
        connections: list = []
        teacher_task = asyncio.create_task(send_all(url, teacher, connections))
        while not connections:
            await asyncio.sleep(0.01)
        while not app.roles.teachers:
            await asyncio.sleep(0.01)
        await send_all(url, student, [])
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
    app.roles.teachers.clear()
    app.roles._first_taken = False
    run_pages(app, teacher=page_changes(app, 40, target), student=[])
    simulation = app.runner.simulation
    assert wait_for(lambda: simulation.dt == 0.004 and simulation.integrator == "rk4")
    assert wait_for(lambda: app.runner.simulation.model.has_gravity)
    assert app.runner.playing or app.runner.steps_taken > 0


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
