"""A class on the wire: N websocket clients watching ``oscillators serve interference --play``.

It starts the server as a separate process (the command a teacher types, on the preset saved as
a scene file that lasts ``LONG_RUN`` seconds: the page pauses a run at its scene's duration),
then for each client count opens that many websocket clients speaking viser's protocol as a
browser does (msgpack windows, see ``benchmarks/web_speed.py``) and, after a warm-up, counts for
each client the bytes received per second and the lattice frames per second (windows that update
``/lattice/particles``).  Meanwhile it samples the server's resident memory and reads the
simulation's step counter from the page's status line (so one sees whether the simulation slows
down with more clients).  ``--slow K`` adds K clients that read like a page on a 1 Mbit/s link,
``--stalled K`` K clients that stop reading after two seconds (the server's log then says it
disconnected them), ``--drawing K`` K clients that take 0.25 s to "draw" each picture (a page
without graphics acceleration), ``--browsers K`` K real Chromium pages (bytes received only).

One more page stays connected from the first phase to the last and is not counted: the server
pauses the run when its last page leaves (nobody watches), so without it every phase after the
first would watch a paused run.

Every client acknowledges each picture as viser's page does once it has drawn it (the server
asks for a local-storage value after each picture; the page's reply is what lets the next
picture go to that page, ``app/web/pacing.py``); stalled clients never do.

    .venv/bin/python benchmarks/web_load.py                        # 1 and 20 clients, 15 s each
    .venv/bin/python benchmarks/web_load.py --clients 1 20 30 --seconds 20 --slow 2 --stalled 1
    .venv/bin/python benchmarks/web_load.py --clients 20 --drawing 2
    .venv/bin/python benchmarks/web_load.py --clients 19 --browsers 1   # 20 pages, one a browser
"""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import msgspec
import psutil
import viser
import websockets
import zstandard

ROOT = Path(__file__).resolve().parent.parent
PARTICLES_NODE = "/lattice/particles"
STEP = re.compile(r"step (\d+)")
SLOW_BYTES_PER_SECOND = 125_000
"""How fast a ``--slow`` client reads (1 Mbit/s)."""
CHROMIUM = "/usr/bin/chromium"
STALL_AFTER = 2.0
"""Seconds after which a ``--stalled`` client stops reading."""
DRAWING_SECONDS = 0.25
"""Seconds a ``--drawing`` client takes before it acknowledges a picture."""


@dataclass
class Client:
    kind: str = "normal"
    bytes: int = 0
    frames: int = 0
    frame_bytes: int = 0
    steps: list[tuple[float, int]] = field(default_factory=list)


def decode_window(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    """The messages of one viser websocket window (see viser.infra._infra for the layout)."""
    inner_size = int.from_bytes(raw[:8], "little")
    compressed_size = int.from_bytes(raw[8:16], "little")
    payload = decompressor.decompress(raw[16 : 16 + compressed_size], max_output_size=inner_size)
    return msgspec.msgpack.decode(payload)["messages"]


def acknowledgements(messages: list[dict]) -> list[bytes]:
    """viser's page's replies to the server's requests for local-storage values in a window (it
    sends them when it applies the window, in its render loop)."""
    return [msgspec.msgpack.encode({"type": "LocalStorageGetItemResponseMessage", "value": None,
                                    "error": None, "request_uuid": message["request_uuid"]})
            for message in messages if message.get("type") == "LocalStorageGetItemRequestMessage"]


def status_step(messages: list[dict]) -> int | None:
    for message in messages:
        for value in (message.get("updates") or {}).values():
            if isinstance(value, str) and "steps/s" in value:
                found = STEP.search(value)
                if found:
                    return int(found.group(1))
    return None


async def run_client(url: str, client: Client, warm_up: float, seconds: float) -> None:
    decompressor = zstandard.ZstdDecompressor()
    started = time.perf_counter()
    counting_from = started + warm_up
    ends = counting_from + seconds
    try:
        stalled = client.kind == "stalled"
        async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],
                                      max_size=None, open_timeout=60,
                                      max_queue=1 if stalled else 16) as connection:
            if stalled:  # a small receive buffer: the server sees the stall in seconds
                sock = connection.transport.get_extra_info("socket")
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
            while (now := time.perf_counter()) < ends:
                if client.kind == "stalled" and now - started > STALL_AFTER:
                    await asyncio.sleep(ends - now)  # read nothing more
                    return
                try:
                    raw = await asyncio.wait_for(connection.recv(), timeout=ends - now)
                except TimeoutError:
                    return
                messages = decode_window(raw, decompressor)
                if client.kind == "slow":
                    await asyncio.sleep(len(raw) / SLOW_BYTES_PER_SECOND)
                for request in acknowledgements(messages):
                    if client.kind == "drawing":
                        await asyncio.sleep(DRAWING_SECONDS)
                    await connection.send(request)
                step = status_step(messages)
                if step is not None:
                    client.steps.append((time.perf_counter(), step))
                if time.perf_counter() < counting_from:
                    continue
                client.bytes += len(raw)
                if any(message.get("name") == PARTICLES_NODE
                       and "_data" in (message.get("updates") or {}) for message in messages):
                    client.frames += 1
                    client.frame_bytes += len(raw)
    except websockets.exceptions.ConnectionClosed:
        pass


async def sample_memory(process: psutil.Process, stop: asyncio.Event, peak: list[int]) -> None:
    while not stop.is_set():
        rss = process.memory_info().rss
        for child in process.children(recursive=True):
            rss += child.memory_info().rss
        peak[0] = max(peak[0], rss)
        try:
            await asyncio.wait_for(stop.wait(), timeout=0.25)
        except TimeoutError:
            pass


async def run_browsers(url: str, clients: list[Client], warm_up: float, seconds: float) -> None:
    """Real Chromium pages (Debian's ``/usr/bin/chromium`` through Playwright): bytes of every
    websocket frame they receive while counting."""
    if not clients:
        return
    from playwright.async_api import async_playwright

    page_url = url.replace("ws://", "http://")
    async with async_playwright() as playwright:
        browser = await playwright.chromium.launch(
            executable_path=CHROMIUM, args=["--headless", "--no-sandbox", "--disable-gpu",
                                            "--enable-unsafe-swiftshader"])
        counting = [False]

        def follow(client: Client, websocket: Any) -> None:
            def received(payload: bytes | str) -> None:
                if counting[0]:
                    client.bytes += len(payload)
            websocket.on("framereceived", received)

        for client in clients:
            page = await browser.new_page(viewport={"width": 1280, "height": 800})
            page.on("websocket", lambda websocket, client=client: follow(client, websocket))
            await page.goto(page_url)
        await asyncio.sleep(warm_up)
        counting[0] = True
        await asyncio.sleep(seconds)
        counting[0] = False
        await browser.close()


async def phase(url: str, process: psutil.Process, count: int, slow: int, stalled: int,
                browsers: int, warm_up: float, seconds: float,
                drawing: int = 0) -> tuple[list[Client], int]:
    kinds = ["normal"] * count + ["slow"] * slow + ["stalled"] * stalled + ["drawing"] * drawing
    clients = [Client(kind=kind) for kind in kinds]
    pages = [Client(kind="Chromium") for _ in range(browsers)]
    stop = asyncio.Event()
    peak = [0]
    sampler = asyncio.create_task(sample_memory(process, stop, peak))
    await asyncio.gather(run_browsers(url, pages, warm_up, seconds),
                         *(run_client(url, c, warm_up, seconds) for c in clients))
    stop.set()
    await sampler
    return clients + pages, peak[0]


def steps_per_second(clients: list[Client]) -> float:
    for client in clients:
        if client.kind == "normal" and len(client.steps) >= 2:
            (t0, s0), (t1, s1) = client.steps[0], client.steps[-1]
            if t1 > t0:
                return (s1 - s0) / (t1 - t0)
    return float("nan")


def report(count: int, clients: list[Client], rss: int, seconds: float) -> None:
    normal = [c for c in clients if c.kind == "normal"]
    rates = sorted(c.bytes / seconds / 1e6 for c in normal)
    frame_rates = sorted(c.frame_bytes / seconds / 1e3 for c in normal)
    fps = sorted(c.frames / seconds for c in normal)
    print(f"{count:3d} clients: per client MB/s median {statistics.median(rates):.3f} "
          f"(min {rates[0]:.3f}, max {rates[-1]:.3f}); picture kB/s min {frame_rates[0]:.0f}; "
          f"pictures/s median {statistics.median(fps):.1f} (min {fps[0]:.1f}); "
          f"all clients {sum(c.bytes for c in clients) / seconds / 1e6:.2f} MB/s; "
          f"server RSS peak {rss / 1e6:.0f} MB; simulation {steps_per_second(clients):.0f} steps/s")
    for kind in ("slow", "drawing", "stalled", "Chromium"):
        for c in (c for c in clients if c.kind == kind):
            frames = f", {c.frames / seconds:.1f} pictures/s" if kind != "Chromium" else ""
            print(f"    a {kind} client: {c.bytes / seconds / 1e3:.0f} kB/s{frames}")


LONG_RUN = 1e6
"""Simulated seconds the served scene lasts: the page pauses a run at its scene's duration (the
flagship's 150 s take about 30 s on an idle 2-core machine), so the scene is served from a
scene file of the preset with this duration, and the clients never watch a paused run."""


def long_scene(scene: str, folder: Path) -> Path:
    """The preset ``scene`` as a scene file in ``folder`` lasting ``LONG_RUN`` seconds."""
    import dataclasses

    import sim
    from sim.scenes import scene_files

    built = dataclasses.replace(sim.scenes.build(scene), duration=LONG_RUN)
    return scene_files.save(built, folder / f"{scene}.toml")


def start_server(port: int, scene: str, log: Path) -> subprocess.Popen:
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    served = str(long_scene(scene, log.parent))
    with log.open("w") as output:
        process = subprocess.Popen(
            [sys.executable, "-m", "app.cli", "serve", served, "--play", "--port", str(port)],
            cwd=ROOT, env=environment, stdout=output, stderr=subprocess.STDOUT, text=True,
        )
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and process.poll() is None:
        if "serving on" in log.read_text():
            return process
        time.sleep(0.2)
    raise RuntimeError(f"the server did not start:\n{log.read_text()}")


async def keep_watching(url: str, stop: asyncio.Event) -> None:
    """A page that stays connected between phases (not counted), so that the run is never left
    without a page (which pauses it)."""
    decompressor = zstandard.ZstdDecompressor()
    async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],
                                  max_size=None, open_timeout=60) as connection:
        while not stop.is_set():
            try:
                raw = await asyncio.wait_for(connection.recv(), timeout=0.5)
            except TimeoutError:
                continue
            for request in acknowledgements(decode_window(raw, decompressor)):
                await connection.send(request)


async def all_phases(url: str, process: psutil.Process, arguments: argparse.Namespace,
                     log: Path) -> None:
    stop = asyncio.Event()
    keeper = asyncio.create_task(keep_watching(url, stop))
    try:
        for count in arguments.clients:
            clients, rss = await phase(url, process, count, arguments.slow, arguments.stalled,
                                       arguments.browsers, arguments.warm_up, arguments.seconds,
                                       arguments.drawing)
            report(count, clients, rss, arguments.seconds)
            dropped = [line for line in log.read_text().splitlines() if "disconnected page" in line]
            print(f"    server log: {len(dropped)} page(s) disconnected for not reading so far")
    finally:
        stop.set()
        await keeper


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clients", type=int, nargs="*", default=[1, 20])
    parser.add_argument("--seconds", type=float, default=15.0, help="measured per client count")
    parser.add_argument("--warm-up", type=float, default=5.0, help="seconds before counting")
    parser.add_argument("--slow", type=int, default=0, help="clients reading at 1 Mbit/s")
    parser.add_argument("--stalled", type=int, default=0, help="clients that stop reading")
    parser.add_argument("--drawing", type=int, default=0,
                        help=f"clients that take {DRAWING_SECONDS} s to draw each picture")
    parser.add_argument("--browsers", type=int, default=0,
                        help="real Chromium pages (/usr/bin/chromium) besides the clients")
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--port", type=int, default=8765)
    arguments = parser.parse_args()
    log = Path(tempfile.mkdtemp()) / "server.log"
    server = start_server(arguments.port, arguments.scene, log)
    try:
        process = psutil.Process(server.pid)
        url = f"ws://127.0.0.1:{arguments.port}"
        print(f"serve {arguments.scene} --play, {os.cpu_count()} cores; server RSS at start "
              f"{process.memory_info().rss / 1e6:.0f} MB; one more page stays connected "
              "throughout (not counted)")
        asyncio.run(all_phases(url, process, arguments, log))
    finally:
        server.terminate()
        server.wait(30)


if __name__ == "__main__":
    main()
