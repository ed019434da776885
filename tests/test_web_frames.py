"""Large lattices go to the pages as pictures: each particle at its place in the picture, one
encoding per picture whatever the number of pages, the frame rate within the byte budget, and
small lattices still drawn as spheres."""

from __future__ import annotations

import asyncio
import io
import time

import msgspec
import numpy as np
import viser
import websockets
import zstandard
from PIL import Image

import sim
from app.web import frames
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


def test_the_frame_rate_keeps_to_the_byte_budget():
    assert frames.frame_rate(25_000) * 25_000 <= frames.BYTES_PER_SECOND
    assert frames.frame_rate(1_000) == frames.MAX_FPS
    assert frames.frame_rate(10**7) == frames.MIN_FPS


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

    async def page(received: list[bytes], seconds: float) -> None:
        decompressor = zstandard.ZstdDecompressor()
        async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],
                                      max_size=None) as connection:
            ends = time.monotonic() + seconds
            while time.monotonic() < ends:
                try:
                    raw = await asyncio.wait_for(connection.recv(), ends - time.monotonic())
                except TimeoutError:
                    return
                size = int.from_bytes(raw[:8], "little")
                compressed = int.from_bytes(raw[8:16], "little")
                payload = decompressor.decompress(raw[16:16 + compressed], max_output_size=size)
                for message in msgspec.msgpack.decode(payload)["messages"]:
                    if message.get("name") == "/lattice/particles":
                        data = (message.get("updates") or message.get("props") or {}).get("_data")
                        if data is not None:
                            received.append(bytes(data))

    async def pages() -> list[list[bytes]]:
        received: list[list[bytes]] = [[], [], []]
        await asyncio.gather(*(page(pictures, 8.0) for pictures in received))
        return received

    try:
        assert wait_for(lambda: app.view._image is not None, timeout=120)
        assert wait_for(lambda: app.view._image.sent >= 2, timeout=120)
        received = asyncio.run(pages())
        image = app.view._image
        assert app.view._points is None and app.view._spheres is None
    finally:
        app.stop()
    assert len(encoded) == image.sent - 1  # the first picture is encoded by viser's add_image
    for pictures in received:
        assert len(pictures) >= 2
        later = pictures[1:]  # the first is the one in the scene when the page connected
        assert set(later) <= set(encoded)
    shown = np.asarray(Image.open(io.BytesIO(received[0][-1])))
    assert shown.shape == (200, 260, 3)


def test_a_small_lattice_keeps_its_spheres(web_app):
    assert web_app.view._spheres is not None and web_app.view._image is None


def test_pictures_come_no_faster_than_the_page_asks():
    """Each picture keeps a page drawing for a moment, so by default a large lattice sends about
    one a second (a page without a graphics card stays answering); the View folder's choice
    raises it, within the byte budget."""
    model = sim.scenes.build("interference", nx=260, ny=200).model
    server = viser.ViserServer(port=free_port(), verbose=False)
    try:
        image = frames.FieldImage(server, model, np.zeros((model.n_particles, 3), np.uint8))
        image.last_bytes = 1_000  # small pictures: the byte budget alone would allow MAX_FPS
        assert image.fps == frames.DEFAULT_FPS == 1.0
        image.show(np.zeros((model.n_particles, 3), np.uint8), force=True)
        assert not image.due_now()
        image.max_fps = frames.MAX_FPS
        image.last_bytes = 1_000
        assert image.fps == frames.MAX_FPS
    finally:
        server.stop()
