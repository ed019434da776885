"""Large lattices go to the pages as pictures: each particle at its place in the picture, one
encoding per picture whatever the number of pages, each page paced by its own replies, and
small lattices still drawn as spheres."""

from __future__ import annotations

import asyncio
import io
import time

import msgspec
import numpy as np
import pytest
import viser
import websockets
import zstandard
from PIL import Image

import sim
from app.web import frames, pacing
from app.web.app import WebApp
from tests.helpers import free_port, wait_for


def test_each_particle_is_its_own_pixel_with_row_zero_at_the_bottom():
    model = sim.scenes.build("grid", nx=5, ny=3).model
    colours = np.zeros((model.n_particles, 3), np.uint8)
    column, row = 4, 0  # the bottom-right particle (its rest site has the largest x, least y)
    particle = row * model.nx + column
    assert model.rest_positions[particle, 0] == model.rest_positions[:, 0].max()
    assert model.rest_positions[particle, 1] == model.rest_positions[:, 1].min()
    colours[particle] = (255, 0, 0)
    picture = frames.field_picture(model, colours)
    assert picture.shape == (3, 5, 3)
    lit = np.argwhere(picture.any(axis=2))
    assert lit.tolist() == [[2, 4]]  # the bottom-right pixel


def _field(wavelength: float) -> np.ndarray:
    """A flagship-sized picture (383 x 682) of interfering waves of about ``wavelength`` pixels,
    coloured with the page's magnitude map."""
    from app import colours

    y, x = np.mgrid[0:383, 0:682].astype(float)
    k = 2 * np.pi / wavelength
    field = sum(np.cos(k * (x * np.cos(a) + y * np.sin(a)) + 3 * a) for a in np.linspace(0, 3, 9))
    values = np.abs(field).ravel()
    return colours.MAGNITUDE.map(values, float(np.percentile(values, 99.5))).reshape(383, 682, 3)


def test_fine_grained_pictures_step_down_in_quality_to_keep_five_a_second_in_the_budget():
    fine, smooth = _field(3.0), _field(200.0)
    assert len(frames.encode(fine, *frames.PICTURE_STEPS[0])) > frames.PICTURE_BYTES  # too big
    step, sizes = 0, []
    for _ in range(len(frames.PICTURE_STEPS) + 2):
        sizes.append(len(frames.encode(fine, *frames.PICTURE_STEPS[step])))
        step = frames.next_step(step, sizes[-1])
    assert step > 0
    assert sizes[-1] < 0.6 * sizes[0]
    assert sizes[-1] <= frames.PICTURE_BYTES or step == len(frames.PICTURE_STEPS) - 1
    assert pacing.BYTES_PER_SECOND / frames.PICTURE_BYTES >= 5
    for _ in range(len(frames.PICTURE_STEPS) + 2):  # the waves thin out again: back to the best
        step = frames.next_step(step, len(frames.encode(smooth, *frames.PICTURE_STEPS[step])))
    assert step == 0


def test_each_picture_step_is_smaller_than_the_one_before():
    """Stepping down always saves bytes: the ladder's order is by size on a fine field."""
    fine = _field(3.0)
    sizes = [len(frames.encode(fine, *encoding)) for encoding in frames.PICTURE_STEPS]
    assert all(later < earlier for earlier, later in zip(sizes, sizes[1:], strict=False)), sizes


WINDOW = 12.0
"""Seconds the pages listen: long enough for a few pictures on a busy machine."""


def test_a_large_lattice_is_one_picture_encoded_once_for_every_page(tmp_path, monkeypatch):
    encoded: list[bytes] = []
    original = frames.encode

    def counting(*arguments, **keywords):
        data = original(*arguments, **keywords)
        encoded.append(data)
        return data

    monkeypatch.setattr(frames, "encode", counting)
    scene = sim.scenes.build("interference", nx=260, ny=200)
    assert scene.model.n_particles >= frames.IMAGE_LIMIT
    app = WebApp(sim.Simulation(scene), port=free_port(), play=True,
                 scenes_dir=tmp_path / "s", recordings_dir=tmp_path / "r")
    app.start()
    url = f"ws://127.0.0.1:{app.server.get_port()}"

    async def page(received: list[bytes], seconds: float, acknowledge: bool = True) -> None:
        """A page speaking viser's protocol: it keeps the pictures it is sent and, like viser's
        page once it has drawn them, replies to the server's requests (unless told not to)."""
        decompressor = zstandard.ZstdDecompressor()
        async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],
                                      max_size=None) as connection:
            ends = time.monotonic() + seconds
            while time.monotonic() < ends:
                try:
                    raw = await asyncio.wait_for(connection.recv(), ends - time.monotonic())
                except TimeoutError:
                    return
                for message in decoded(raw, decompressor):
                    if message.get("name") == "/lattice/particles":
                        # the node is made with a 1x1 placeholder, then given the picture
                        data = (message.get("updates") or {}).get("_data")
                        if data is not None:
                            received.append(bytes(data))
                    if acknowledge and message.get("type") == "LocalStorageGetItemRequestMessage":
                        await connection.send(acknowledgement(message))

    async def pages() -> list[list[bytes]]:
        received: list[list[bytes]] = [[], [], [], []]
        await asyncio.gather(*(page(pictures, WINDOW) for pictures in received[:3]),
                             page(received[3], WINDOW, acknowledge=False))
        return received

    try:
        assert wait_for(lambda: app.view._image is not None, timeout=120)
        assert wait_for(lambda: app.runner.simulation.step_count > 20, timeout=300)
        received = asyncio.run(pages())
        image = app.view._image
        assert not app.gate.dropped, app.gate.dropped  # the pages' replies reach the pacer
        assert app.view._points is None and app.view._spheres is None
    finally:
        app.stop()
    assert len(encoded) == image.sent  # every picture sent was encoded once, for every page
    for pictures in received[:3]:
        assert len(pictures) >= 3
        assert set(pictures) <= set(encoded)
    shown = np.asarray(Image.open(io.BytesIO(received[0][-1])))
    assert shown.shape == (200, 260, 3)
    # a page that never says it has drawn a picture gets one per ACK_TIMEOUT and slows no other
    silent = len(received[3])
    assert silent <= WINDOW / pacing.ACK_TIMEOUT + 2
    # (how many more the others get depends on how fast the machine makes frames:
    # benchmarks/web_load.py measures the rates)
    assert min(len(pictures) for pictures in received[:3]) >= silent


def decoded(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    """The messages of one viser websocket window."""
    size = int.from_bytes(raw[:8], "little")
    compressed = int.from_bytes(raw[8:16], "little")
    payload = decompressor.decompress(raw[16:16 + compressed], max_output_size=size)
    return msgspec.msgpack.decode(payload)["messages"]


def acknowledgement(request: dict) -> bytes:
    """viser's page's reply to a request for a local-storage value."""
    return msgspec.msgpack.encode({"type": "LocalStorageGetItemResponseMessage", "value": None,
                                   "error": None, "request_uuid": request["request_uuid"]})


def test_a_small_lattice_keeps_its_spheres(web_app):
    assert web_app.view._spheres is not None and web_app.view._image is None


def test_a_page_gets_the_next_picture_when_it_has_drawn_the_last():
    """The pacer sends a page one picture, then nothing until the page replies; the reply brings
    the newest picture (not every one published meanwhile); the byte budget and the View
    folder's limit hold a fast page back."""
    model = sim.scenes.build("interference", nx=260, ny=200).model
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    url = f"ws://127.0.0.1:{server.get_port()}"
    sent: list[bytes] = []

    class Node:
        def __init__(self, data: bytes) -> None:
            sent.append(data)

        def __setattr__(self, name: str, value: object) -> None:
            if name == "_data":
                sent.append(value)

        def remove(self) -> None:
            pass

    pacer = pacing.PicturePacer(server, lambda client, data: Node(data))

    async def scenario() -> list[str]:
        requests: list[str] = []
        decompressor = zstandard.ZstdDecompressor()
        async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],
                                      max_size=None) as connection:
            await connection.send(msgspec.msgpack.encode(dict(  # viser counts a page from its camera
                type="ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0), position=(0.0, 0.0, -5.0),
                fov=0.9, near=0.01, far=100.0, image_height=600, image_width=800,
                look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 1.0, 0.0))))
            assert await asyncio.to_thread(wait_for, lambda: server.get_clients(), 10)

            async def next_request() -> dict:
                while True:
                    raw = await asyncio.wait_for(connection.recv(), 10)
                    for message in decoded(raw, decompressor):
                        if message.get("type") == "LocalStorageGetItemRequestMessage":
                            return message

            pacer.publish(b"first")  # the page's node is made with it, and a request follows
            first = await next_request()
            pacer.publish(b"second")
            pacer.publish(b"third")  # no reply yet: nothing more is sent
            assert sent == [b"first"] and not pacer.wanted()
            await connection.send(acknowledgement(first))  # taken in
            again = await next_request()  # asked again: answered once the page drew a frame
            assert sent == [b"first"]
            await connection.send(acknowledgement(again))
            second = await next_request()  # the reply brought the newest picture
            assert sent == [b"first", b"third"]
            requests += [first["request_uuid"], again["request_uuid"], second["request_uuid"]]
            await connection.send(acknowledgement(second))
            confirm = await next_request()
            # it has the newest: the next is encoded while it draws a frame (once its rate allows)
            assert await asyncio.to_thread(wait_for, pacer.wanted, 5)
            pacer.budget = 1.0  # one byte a second: the next picture waits for the budget
            assert not pacer.wanted()
            await connection.send(acknowledgement(confirm))
            await asyncio.to_thread(wait_for, lambda: pacer.pages[next(iter(pacer.pages))]
                                    .acknowledged == 2, 10)
            pacer.publish(b"fourth")
            await asyncio.sleep(0.5)
            assert sent == [b"first", b"third"]
        return requests

    try:
        requests = asyncio.run(scenario())
    finally:
        pacer.remove()
        server.stop()
    assert len(set(requests)) == 3
    assert model.n_particles >= frames.IMAGE_LIMIT


def test_a_page_that_draws_slowly_gets_pictures_no_faster_than_it_draws_them():
    """A page that took 0.4 s to draw its picture waits (1 + IDLE_SHARE) times that from the
    picture sent (0.4 s by default), also when an acknowledgement comes early; a page with a
    graphics card (20 ms) is held only by the rate and the budget."""
    class Server:
        class _websock_server:  # noqa: N801 (viser's name)
            @staticmethod
            def register_handler(*_: object) -> None:
                pass

    pacer = pacing.PicturePacer(Server(), lambda client, data: None)
    slow = pacing.PageState(handle=None, sent_at=100.0, last_bytes=1_000, draw_seconds=0.4)
    fast = pacing.PageState(handle=None, sent_at=100.0, last_bytes=1_000, draw_seconds=0.02)
    assert pacer._next_allowed(slow) == pytest.approx(100.0 + (1 + pacing.IDLE_SHARE) * 0.4)
    assert pacer._next_allowed(slow) >= 100.4
    assert pacer._next_allowed(fast) == pytest.approx(100.0 + 1 / pacing.MAX_FPS)
