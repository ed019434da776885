"""The page protocol is closed: messages a program sends over a real websocket to `oscillators
serve` (viser's msgpack messages, no browser) can only set the values of controls the server
created, of the right type and range; anything else is dropped and every page keeps showing the
value in use; the controls still work for the next client; SIGTERM stops the server."""

from __future__ import annotations

import asyncio
import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import psutil
import pytest
import websockets

from tests.helpers import free_port, wait_for
from tests.page_client import Page

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """`oscillators serve grid` in a subprocess; stopped with one SIGTERM at the end, which
    must end it within 5 s."""
    folder = tmp_path_factory.mktemp("serve")
    port = free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", "grid", "--port", str(port)],
        cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONPATH": str(REPO)})
    deadline = time.monotonic() + 180
    served_port = None
    output = []
    while time.monotonic() < deadline and served_port is None:
        line = process.stdout.readline()
        output.append(line)
        match = re.search(r"serving on http://127\.0\.0\.1:(\d+)", line)
        if match:
            served_port = int(match.group(1))
        if not line and process.poll() is not None:
            break
    assert served_port is not None, "".join(output)
    yield process, served_port
    process.send_signal(signal.SIGTERM)
    started = time.monotonic()
    process.wait(timeout=30)
    assert time.monotonic() - started < 5.0


async def first_state(port: int, seconds: float = 3.0) -> Page:
    async with Page(port) as page:
        await page.camera()
        await page.listen(seconds)
    return page


def run(coroutine: Any) -> Any:
    return asyncio.run(coroutine)


@pytest.mark.slow  # starts `oscillators serve` (about a minute for the module)
def test_handle_attributes_unknown_ids_and_buttons_cannot_be_tampered_with(served):
    _, port = served

    async def scenario() -> Page:
        async with Page(port) as attacker:
            await attacker.camera()
            await attacker.listen(3.0)
            await attacker.set("Play", {"update_cb": []})
            await attacker.set("Single step", {"update_cb": "x"})
            await attacker.set("Time step dt (s)", {"removed": True})
            await attacker.set("Time step dt (s)", {"update_cb": [], "value": 0.02})
            await attacker.send(type="GuiUpdateMessage", uuid="no-such-control",
                                updates={"value": 1.0})
            await attacker.listen(1.0)
        async with Page(port) as second:
            await second.camera()
            await second.listen(3.0)
            await second.set("Time step dt (s)", {"value": 0.005})
            await second.listen(1.0)
        return await first_state(port)

    late = run(scenario())
    assert late.value("Time step dt (s)") == pytest.approx(0.005)
    for update in late.updates:
        assert not {"update_cb", "removed"} & set(update["updates"]), update


@pytest.mark.slow  # starts `oscillators serve` (about a minute for the module)
def test_a_client_without_a_camera_message_is_checked_like_any_other(served):
    _, port = served

    async def scenario() -> Page:
        async with Page(port) as silent:  # never sends a camera message
            await silent.listen(3.0)
            await silent.set("Stiffness k (N/m)", {"value": -1.0})
            await silent.set("Time step dt (s)", {"value": math.nan})
            await silent.set("Method", {"value": "<img src=x onerror=alert(1)>"})
            await silent.listen(1.0)
        return await first_state(port)

    late = run(scenario())
    assert late.value("Stiffness k (N/m)") == pytest.approx(35.0)
    assert late.value("Method") == "rk4"
    assert math.isfinite(late.value("Time step dt (s)"))


@pytest.mark.slow  # starts `oscillators serve` (about a minute for the module)
def test_wrong_types_are_dropped_and_the_sender_shown_the_value_in_use(served):
    _, port = served

    async def scenario() -> tuple[Page, Page]:
        async with Page(port) as sender:
            await sender.camera()
            await sender.listen(3.0)
            before = sender.value("Stiffness k (N/m)")
            for bad in ("abc", None, True, [1.0], 1000.0):
                await sender.set("Stiffness k (N/m)", {"value": bad})
            await sender.set("Time step dt (s)", {"value": "0.01"})
            await sender.listen(1.5)
            assert before == pytest.approx(35.0)
            # the refused value was answered with the value in use
            restored = [update["updates"]["value"] for update in sender.updates
                        if update["uuid"] == sender.uuid("Stiffness k (N/m)")]
            assert restored and restored[-1] == pytest.approx(35.0)
            await sender.set("Stiffness k (N/m)", {"value": 50.0})  # a good one still works
            await sender.listen(1.0)
        return sender, await first_state(port)

    _, late = run(scenario())
    assert late.value("Stiffness k (N/m)") == pytest.approx(50.0)
    assert isinstance(late.value("Time step dt (s)"), float)


@pytest.mark.slow  # starts `oscillators serve` (about a minute for the module)
def test_uploads_are_capped_while_they_arrive(served):
    process, port = served
    server = psutil.Process(process.pid)

    async def scenario() -> None:
        async with Page(port) as uploader:
            await uploader.camera()
            await uploader.listen(3.0)
            button = uploader.uuid("Open a scene file…")
            before = server.memory_info().rss
            part = b"x" * 2**20
            # announced far beyond the limit: refused at once, its parts ignored
            await uploader.send(type="FileTransferStartUpload", source_component_uuid=button,
                                transfer_uuid="huge", filename="a.toml", mime_type="text/plain",
                                part_count=2000, size_bytes=2000 * 2**20)
            for index in range(50):
                await uploader.send(type="FileTransferPart", source_component_uuid=button,
                                    transfer_uuid="huge", part_index=index, content=part)
            # announced small, sent large: dropped at the first part beyond the announced size
            await uploader.send(type="FileTransferStartUpload", source_component_uuid=button,
                                transfer_uuid="liar", filename="b.toml", mime_type="text/plain",
                                part_count=200, size_bytes=1000)
            for index in range(50):
                await uploader.send(type="FileTransferPart", source_component_uuid=button,
                                    transfer_uuid="liar", part_index=index, content=part)
            await uploader.listen(2.0)
            grown = server.memory_info().rss - before
            assert grown < 60 * 2**20, f"server grew by {grown / 2**20:.0f} MB"

    run(scenario())


def test_a_stalled_upload_is_dropped_with_what_it_holds(web_app):
    web_app.gate.upload_seconds = 1.0
    states = web_app.server.gui._current_file_upload_states

    async def scenario() -> None:
        async with Page(web_app.server.get_port()) as uploader:
            await uploader.camera()
            await uploader.listen(2.0)
            button = uploader.uuid("Open a scene file…")
            await uploader.send(type="FileTransferStartUpload", source_component_uuid=button,
                                transfer_uuid="slow", filename="a.toml", mime_type="text/plain",
                                part_count=8, size_bytes=8 * 2**20)
            for index in range(3):
                await uploader.send(type="FileTransferPart", source_component_uuid=button,
                                    transfer_uuid="slow", part_index=index, content=b"x" * 2**20)
            await uploader.listen(0.5)
            assert "slow" in states  # arriving: held
            await uploader.listen(2.5)  # the client stays connected and sends nothing more
            assert "slow" not in states  # dropped, with its parts

    run(scenario())
    assert web_app.gate.refused >= 1


def test_a_share_request_and_types_the_app_does_not_take_are_dropped_unread(web_app, capfd):
    """viser's page can ask the server for a public share tunnel (a process that reaches the
    network); the app takes no such request, nor any message type it does not handle."""
    shared: list[str] = []
    web_app.server.request_share_url = lambda *_, **__: shared.append("share")
    web_app.server.disconnect_share_url = lambda *_, **__: shared.append("disconnect")

    async def scenario() -> None:
        async with Page(web_app.server.get_port()) as page:
            await page.camera()
            await page.listen(2.0)
            await page.send(type="ShareUrlRequest")
            await page.send(type="ShareUrlDisconnect")
            await page.send(type="CommandTriggerMessage", uuid="anything")
            await page.send(type="GuiFormSubmitMessage", uuid=page.uuid("Stiffness k (N/m)"))
            await page.set("Stiffness k (N/m)", {"value": 50.0})  # the page still works
            await page.listen(1.5)

    async def nonsense() -> None:
        async with Page(web_app.server.get_port()) as page:
            await page.camera()
            await page.send(type="NoSuchMessage", payload=1)
            await page.connection.send("a text frame")
            await page.listen(1.0)

    run(scenario())
    assert shared == []
    assert "Share URL" not in capfd.readouterr().out
    assert web_app.runner.simulation.model.stiffness == pytest.approx(50.0)
    run(nonsense())
    dropped = web_app.gate.dropped
    for kind in ("ShareUrlRequest", "ShareUrlDisconnect", "GuiFormSubmitMessage",
                 "NoSuchMessage", "not a viser message"):
        assert dropped.get(kind) == 1, (kind, dropped)
    # a keyboard command passes the gate (the Run folder's keys), and viser runs only the
    # commands the server registered: one naming anything else does nothing
    assert "CommandTriggerMessage" not in dropped
    assert web_app.runner.simulation.model.stiffness == pytest.approx(50.0)


def test_a_page_over_the_message_rate_is_throttled_then_disconnected(web_app):
    gate = web_app.gate
    gate.flood_seconds = 1.0

    async def scenario() -> bool:
        async with Page(web_app.server.get_port()) as flood:
            await flood.camera()
            await flood.listen(1.0)
            end = time.monotonic() + 3.0
            try:
                while time.monotonic() < end:
                    for _ in range(50):
                        await flood.camera()
                    await asyncio.sleep(0.01)
                await flood.listen(1.0)
            except websockets.ConnectionClosed:
                return True
            return flood.connection.close_code is not None

    assert run(scenario())
    assert gate.dropped.get("over the rate", 0) > 1000
    assert gate.disconnected == 1


def test_gizmo_positions_beyond_reach_or_not_finite_are_refused(web_app):
    """A drag of the selection's gizmo to (1e300, -1e300), (-1e300, 1e300) or NaN moves nothing
    (the energy stays finite); a drag within reach still moves the particle."""
    particle = 3 * web_app.runner.simulation.model.nx + 5
    web_app.set_selection(np.array([particle]))
    assert wait_for(lambda: web_app._gizmo is not None)
    rest = tuple(float(v) for v in web_app.runner.simulation.positions[particle])

    async def drag(position: tuple) -> None:
        async with Page(web_app.server.get_port()) as page:
            await page.camera()
            await page.listen(1.0)
            gizmo = {"name": "/selection_gizmo", "owner": ""}
            await page.send(type="TransformControlsDragStartMessage", **gizmo)
            await page.send(type="TransformControlsUpdateMessage", wxyz=(1.0, 0.0, 0.0, 0.0),
                            position=position, **gizmo)
            await page.send(type="TransformControlsDragEndMessage", **gizmo)
            await page.listen(1.0)

    for position in ((1e300, -1e300, 0.0), (-1e300, 1e300, 0.0), (math.nan, 0.0, 0.0)):
        run(drag(position))
        web_app.runner.post(lambda simulation: None).result(timeout=10)
        positions = web_app.runner.simulation.positions
        assert np.isfinite(positions).all()
        assert tuple(positions[particle]) == pytest.approx(rest), position
        assert math.isfinite(web_app.runner.simulation.energy().total)
    run(drag((rest[0] + 0.3, rest[1], 0.0)))
    web_app.runner.post(lambda simulation: None).result(timeout=10)
    assert web_app.runner.simulation.positions[particle][0] == pytest.approx(rest[0] + 0.3)


def test_a_vector_value_outside_its_bounds_is_set_back_on_every_page(web_app):
    vector = web_app.server.gui.add_vector2("Bounded pair", (1, 2), min=(0, 0), max=(10, 5),
                                            step=1)

    async def scenario() -> tuple[Page, Page]:
        async with Page(web_app.server.get_port()) as sender, \
                Page(web_app.server.get_port()) as watcher:
            await sender.camera()
            await watcher.camera()
            await sender.listen(1.5)
            await watcher.listen(0.5)
            await sender.set("Bounded pair", {"value": [999, 999]})
            await sender.set("Bounded pair", {"value": [3, -1]})
            await sender.listen(1.0)
            await watcher.listen(0.5)
            await sender.set("Bounded pair", {"value": [4, 5]})  # within bounds: taken
            await sender.listen(1.0)
            await watcher.listen(0.5)
            return sender, watcher

    sender, watcher = run(scenario())
    assert tuple(vector.value) == (4, 5)
    restored = [tuple(update["updates"]["value"]) for update in sender.updates
                if update["uuid"] == sender.uuid("Bounded pair")]
    assert restored and restored[0] == (1, 2), restored  # the sender is shown the value in use
    assert tuple(watcher.value("Bounded pair")) == (4, 5)
    assert (999, 999) not in [tuple(update["updates"].get("value", ())) for update in
                              watcher.updates]
