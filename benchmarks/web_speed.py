"""How fast the web app delivers frames to a connected client, and how fast the simulation runs
meanwhile.

For each scene it starts a ``WebApp`` (playing) on a free localhost port, connects a plain
websocket client speaking viser's protocol (no browser, so paint speed does not count), and
counts the message windows that update ``/lattice/particles``: that is frames *delivered* per
second.  Simulation steps per second come from the runner's step counter over the same
interval.  It also times start-up: from creating the app to the first scene frame arriving at
the client (numba's cache should be warm: run the script twice).

    .venv/bin/python benchmarks/web_speed.py                 # grid, 200x200, interference
    .venv/bin/python benchmarks/web_speed.py --seconds 10 --scenes grid
"""

from __future__ import annotations

import argparse
import asyncio
import json
import socket
import time

import msgspec
import viser
import websockets
import zstandard

import sim
from app.web.app import WebApp

SCENES: dict[str, tuple[str, dict]] = {
    "grid": ("grid", {}),
    "200x200": ("grid", {"nx": 200, "ny": 200}),
    "interference": ("interference", {}),
}
PARTICLES_NODE = "/lattice/particles"


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def decode_window(raw: bytes, decompressor: zstandard.ZstdDecompressor) -> list[dict]:
    """The messages of one viser websocket window (see viser.infra._infra for the layout)."""
    inner_size = int.from_bytes(raw[:8], "little")
    compressed_size = int.from_bytes(raw[8:16], "little")
    payload = decompressor.decompress(raw[16 : 16 + compressed_size], max_output_size=inner_size)
    return msgspec.msgpack.decode(payload)["messages"]


async def watch(url: str, seconds: float, app: WebApp, started: float) -> dict:
    decompressor = zstandard.ZstdDecompressor()
    frames = 0
    received_bytes = 0
    first_frame_at: float | None = None
    steps_at_start = 0
    window_start = 0.0
    async with websockets.connect(
        url, subprotocols=[f"viser-v{viser.__version__}"], max_size=None
    ) as connection:
        while True:
            raw = await asyncio.wait_for(connection.recv(), timeout=30)
            now = time.perf_counter()
            messages = decode_window(raw, decompressor)
            has_frame = any(message.get("name") == PARTICLES_NODE for message in messages)
            if not has_frame:
                continue
            if first_frame_at is None:
                first_frame_at = now
                app.runner.play()
                continue
            if window_start == 0.0:  # skip the first second (warm-up)
                if now - first_frame_at >= 1.0:
                    window_start = now
                    steps_at_start = app.runner.steps_taken
                continue
            frames += 1
            received_bytes += len(raw)
            if now - window_start >= seconds:
                elapsed = now - window_start
                return {
                    "startup_s": first_frame_at - started,
                    "frames_per_s": frames / elapsed,
                    "steps_per_s": (app.runner.steps_taken - steps_at_start) / elapsed,
                    "megabytes_per_s": received_bytes / elapsed / 1e6,
                    "steps_per_frame": app.runner.steps_per_frame,
                    "integrator": app.runner.simulation.integrator,
                }


def measure(label: str, seconds: float) -> dict:
    name, overrides = SCENES[label]
    started = time.perf_counter()
    simulation = sim.Simulation(sim.scenes.build(name, **overrides))
    app = WebApp(simulation, port=free_port()).start()
    try:
        url = f"ws://127.0.0.1:{app.server.get_port()}"
        result = asyncio.run(watch(url, seconds, app, started))
    finally:
        app.stop()
    model = simulation.model
    return {"scene": label, "particles": model.n_particles, **result}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=6.0, help="measurement per scene")
    parser.add_argument("--scenes", nargs="*", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--json", action="store_true")
    arguments = parser.parse_args()
    results = [measure(label, arguments.seconds) for label in arguments.scenes]
    if arguments.json:
        print(json.dumps(results, indent=2))
        return
    print(f"{'scene':13s} {'particles':>9s} {'start-up':>9s} {'frames/s':>9s} {'steps/s':>8s} "
          f"{'MB/s':>6s}  integrator, steps/frame")
    for r in results:
        print(f"{r['scene']:13s} {r['particles']:9d} {r['startup_s']:8.2f}s "
              f"{r['frames_per_s']:9.1f} {r['steps_per_s']:8.0f} {r['megabytes_per_s']:6.1f}  "
              f"{r['integrator']}, {r['steps_per_frame']}")


if __name__ == "__main__":
    main()
