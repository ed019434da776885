"""Can one student slow the class?  The teacher's picture rate and the simulation's speed in
``serve --class``, undisturbed and while a student page floods the server with refused clicks.

The server runs in this process (``WebApp`` with ``class_mode``, playing, a 1e6 s run); the
pages are separate processes speaking viser's protocol (``tests/page_client.py``).  A page
connects first (so the first-page teacher role is taken); then a teacher page (the teacher
link's websocket) counts the pictures it receives (windows that move the lattice) for
``--seconds`` while this process reads how far the simulation's time advanced and how much CPU
time the server used.  Then the same while a student page sends ``--rate`` presses a second of
the *Single step* button (refused: a student may not drive), and again after the flood.  On a
machine with few cores the flooding process itself takes CPU from the server: the server's
own CPU time shows what the flood costs it.

    .venv/bin/python benchmarks/class_flood.py                     # grid 60x40, 15 s each
    .venv/bin/python benchmarks/class_flood.py --nx 200 --ny 120 --seconds 20 --rate 1000
"""

from __future__ import annotations

import argparse
import asyncio
import dataclasses
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.page_client import Page, decode_window  # noqa: E402

BUTTON = "Single step"


async def count_pictures(port: int, seconds: float, path: str) -> int:
    """Windows that move the lattice, received by one page over ``seconds``."""
    async with Page(port, path) as page:
        await page.camera()
        await page.listen(2.0)  # the page's first state
        pictures, end = 0, time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                raw = await asyncio.wait_for(page.connection.recv(), left)
            except TimeoutError:
                break
            messages = decode_window(raw, page.decompressor)
            pictures += any(message.get("type") == "SceneNodeUpdateMessage"
                            for message in messages)
        return pictures


async def flood(port: int, seconds: float, rate: float) -> dict:
    """Press ``BUTTON`` ``rate`` times a second for ``seconds``, reconnecting when dropped."""
    import websockets

    sent = connections = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        connections += 1
        try:
            async with Page(port) as page:
                await page.camera()
                await page.listen(1.0)
                reader = asyncio.ensure_future(page.listen(end - time.monotonic()))
                button, started = page.uuid(BUTTON), time.monotonic()
                while time.monotonic() < end:
                    due = int((time.monotonic() - started) * rate)
                    while sent < due + 0 and time.monotonic() < end:
                        await page.send(type="GuiUpdateMessage", uuid=button,
                                        updates={"value": True})
                        sent += 1
                        due = int((time.monotonic() - started) * rate)
                    await asyncio.sleep(0.005)
                reader.cancel()
        except websockets.ConnectionClosed:
            continue
    return {"sent": sent, "connections": connections}


def child(role: str, port: int, seconds: float, rate: float, path: str = "") -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, __file__, "--role", role, "--port", str(port), "--seconds",
         str(seconds), "--rate", str(rate), "--path", path], stdout=subprocess.PIPE, text=True)


def phase(app, port: int, seconds: float, rate: float | None) -> dict:
    path = f"/teacher/{app.roles.token}"  # the teacher link's websocket
    flooder = child("student", port, seconds + 4.0, rate) if rate else None
    if flooder:
        time.sleep(2.0)  # connected and flooding
    teacher = child("teacher", port, seconds, 0, path)
    time.sleep(2.0)  # the teacher's first state
    start_time, start_wall = app.runner.simulation.time, time.perf_counter()
    start_cpu = time.process_time()  # the server's threads: this process
    pictures = json.loads(teacher.communicate()[0])["pictures"]
    wall = time.perf_counter() - start_wall
    result = {"pictures_per_s": pictures / seconds,
              "sim_s_per_s": (app.runner.simulation.time - start_time) / wall,
              "cpu": (time.process_time() - start_cpu) / wall}
    if flooder:
        result.update(json.loads(flooder.communicate()[0]))
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nx", type=int, default=60)
    parser.add_argument("--ny", type=int, default=40)
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--rate", type=float, default=1000.0, help="student presses a second")
    parser.add_argument("--role", choices=("teacher", "student"), help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--path", default="", help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.role == "teacher":
        print(json.dumps({"pictures": asyncio.run(count_pictures(
            arguments.port, arguments.seconds, arguments.path))}))
        return
    if arguments.role == "student":
        print(json.dumps(asyncio.run(flood(arguments.port, arguments.seconds, arguments.rate))))
        return

    import sim
    from app.web.app import WebApp
    from tests.helpers import free_port, wait_for

    folder = Path(tempfile.mkdtemp(prefix="class-flood-"))
    scene = dataclasses.replace(sim.scenes.build("grid", nx=arguments.nx, ny=arguments.ny),
                                duration=1e6)  # plays throughout (a run pauses at its end)
    app = WebApp(sim.Simulation(scene),
                 port=free_port(), play=True, class_mode=True, scenes_dir=folder / "scenes",
                 recordings_dir=folder / "recordings")
    app.start()
    try:
        assert wait_for(lambda: app.view.last_positions is not None, timeout=300)
        port = app.server.get_port()
        # the first page to connect is the teacher: keep one connected for the whole run
        keeper = child("teacher", port, 4 * arguments.seconds + 60, 0)
        time.sleep(3.0)
        quiet = phase(app, port, arguments.seconds, None)
        flooded = phase(app, port, arguments.seconds, arguments.rate)
        after = phase(app, port, arguments.seconds, None)
        keeper.kill()
    finally:
        app.stop()
    print(f"grid {arguments.nx}x{arguments.ny}, --class, {arguments.seconds:g} s per phase")
    for name, result in (("undisturbed", quiet), (f"student flooding {arguments.rate:g}/s",
                                                  flooded), ("after the flood", after)):
        extra = (f"; the student sent {result['sent']:,} presses over {result['connections']} "
                 "connection(s)") if "sent" in result else ""
        print(f"{name:28s} teacher {result['pictures_per_s']:.2f} pictures/s "
              f"({result['pictures_per_s'] / quiet['pictures_per_s']:.0%}), simulation "
              f"{result['sim_s_per_s']:.2f} s/s ({result['sim_s_per_s'] / quiet['sim_s_per_s']:.0%}), "
              f"server CPU {result['cpu']:.2f} s/s{extra}")
    gate = app.gate
    print(f"page gate: {sum(gate.dropped.values()):,} dropped unread ({gate.dropped}), "
          f"{gate.disconnected} disconnection(s); refused by the class roles: "
          f"{len(app.roles.refused):,}")


if __name__ == "__main__":
    main()
