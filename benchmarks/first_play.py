"""Seconds from a click on Play to the first moving frame in a real page, per scene.

For each case it starts ``oscillators serve SCENE`` as a process of its own (as a user does, its
background warming of the other presets included), opens Debian's headless Chromium at 1366x768
through Playwright, waits until the server has been up ``--uptime`` seconds, clicks Play and
times, in the page: until the status line says the kernel is being prepared (if it does), and
until it shows a step count above 0 (the status line is refreshed every 0.5 s, so this is at most
0.5 s after the first moving frame).  The case ``grid+gravity+damping`` ticks the Physics
folder's Gravity and Damping boxes first and clicks Play at once (a combination the served scene
did not have).

numba's cache is ``--cache DIR`` (NUMBA_CACHE_DIR), by default a new empty folder: a cold cache,
as on a fresh machine.  Warm: ``oscillators warm`` into a folder, then ``--cache`` that folder.
``--cache default`` leaves numba's cache where it is (beside the sources).

``--without-browser`` runs the app in this process instead (its background warming started as
``serve`` starts it), presses Play as a page's click arrives, and times until the frame pump has
drawn a frame with a step above 0: the server's share of the wait, without the page's.

    .venv/bin/python benchmarks/first_play.py                                  # cold cache
    NUMBA_CACHE_DIR=/tmp/nc .venv/bin/oscillators warm --toggles
    .venv/bin/python benchmarks/first_play.py --cache /tmp/nc                  # warm cache
    .venv/bin/python benchmarks/first_play.py --uptime 0 grid+gravity+damping  # at once
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.helpers import CHROMIUM, CHROMIUM_ARGS, free_port, wait_for_reload  # noqa: E402

CASES = {
    "grid": ("grid", False),
    "catenary": ("catenary", False),  # the preset has gravity and dashpots
    "double-slit": ("double-slit", False),
    "interference": ("interference", False),
    "grid+gravity+damping": ("grid", True),
}
"""The cases by name; any other preset's name (``oscillators scenes``) is a case as it is."""
STATUS = re.compile(r"t = ([0-9.]+) s, step (\d+)")
PREPARING = "Preparing the kernel"


def cache_state(cache: str) -> str:
    """"cold" for an empty (or missing) cache folder, else "warm" ("as is" beside the sources)."""
    if cache == "default":
        return "as is"
    folder = Path(cache)
    return "warm" if folder.is_dir() and any(folder.iterdir()) else "cold"


def page_status(page) -> tuple[int | None, bool]:
    """(the step the status line shows, whether it says the kernel is being prepared)."""
    text = page.evaluate("document.body.innerText")
    found = STATUS.search(text)
    return (int(found.group(2)) if found else None), PREPARING in text


def start_server(scene: str, cache: str, port: int, log) -> tuple[subprocess.Popen, float]:
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    if cache != "default":
        environment["NUMBA_CACHE_DIR"] = cache
    environment.pop("OSCILLATORS_NO_WARM", None)
    started = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "serve", scene, "--port", str(port)],
        cwd=tempfile.mkdtemp(prefix="first-play-"), env=environment, stdout=log, stderr=log)
    return process, started


def measure(browser, case: str, cache: str, uptime: float, timeout: float) -> dict:
    scene, toggle = CASES.get(case, (case, False))
    port = free_port()
    with tempfile.TemporaryFile("w+") as log:
        server, started = start_server(scene, cache, port, log)
        try:
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.set_default_timeout(timeout * 1000)
            deadline = time.monotonic() + timeout
            while True:
                try:
                    page.goto(f"http://127.0.0.1:{port}", timeout=5_000)
                    break
                except Exception:
                    if time.monotonic() > deadline or server.poll() is not None:
                        log.seek(0)
                        raise RuntimeError(f"the server did not answer:\n{log.read()}") from None
                    time.sleep(0.5)
            wait_for_reload(page, page.url, timeout * 1000)  # in software: at half resolution
            page.get_by_text("Connected").wait_for(timeout=timeout * 1000)
            page.get_by_role("button", name="Play").wait_for(timeout=timeout * 1000)
            loaded = time.monotonic() - started
            time.sleep(max(0.0, uptime - (time.monotonic() - started)))
            before = page_status(page)
            if toggle:
                page.get_by_label("Gravity", exact=True).check()
                page.get_by_label("Damping", exact=True).check()
            clicked = time.monotonic()
            page.get_by_role("button", name="Play").click()
            said = None
            while time.monotonic() - clicked < timeout:
                step, preparing = page_status(page)
                if preparing and said is None:
                    said = time.monotonic() - clicked
                if step:
                    moving = time.monotonic() - clicked
                    break
                time.sleep(0.03)
            else:
                moving = float("nan")
            page.close()
            return dict(case=case, loaded=loaded, up=clicked - started,
                        preparing_before=before[1], said=said, moving=moving)
        finally:
            server.terminate()
            try:
                server.wait(10)
            except subprocess.TimeoutExpired:
                server.kill()


def measure_in_process(case: str, cache: str, uptime: float, timeout: float) -> dict:
    """The server's share: Play pressed in this process, until a moving frame is drawn."""
    if cache != "default":
        os.environ["NUMBA_CACHE_DIR"] = cache  # before numba is imported
    os.environ.pop("OSCILLATORS_NO_WARM", None)
    import sim
    from app.cli.warm import start_background, stop_background
    from app.web.app import WebApp
    from sim.runtime.optimisation import use_numba_default
    from tests.helpers import wait_for
    from tests.test_web_safety import press

    scene, toggle = CASES.get(case, (case, False))
    use_numba_default()  # as ``oscillators serve`` does: the level its kernels are compiled at
    started = time.monotonic()
    app = WebApp(sim.Simulation(sim.scenes.build(scene)), port=free_port(),
                 scenes_dir=tempfile.mkdtemp(), recordings_dir=tempfile.mkdtemp())
    app.start()
    warming = start_background(scene)
    try:
        time.sleep(max(0.0, uptime - (time.monotonic() - started)))
        drawn = app._drawn
        before = drawn is not None and drawn.preparing is not None
        clicked = time.monotonic()
        if toggle:
            press(app.panel.physics.gravity_on)
            press(app.panel.physics.damping_on)
        press(app.panel.run.play_button)
        said = None

        def moving() -> bool:
            nonlocal said
            frame = app._drawn
            if frame is not None and frame.preparing is not None and said is None:
                said = time.monotonic() - clicked
            return frame is not None and frame.step > 0

        moved = wait_for(moving, timeout)
        return dict(case=case, loaded=0.0, up=clicked - started, preparing_before=before,
                    said=said, moving=time.monotonic() - clicked if moved else float("nan"))
    finally:
        stop_background(warming)
        app.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("cases", nargs="*", default=list(CASES)[:4], metavar="CASE",
                        help=f"of {', '.join(CASES)}, or any other preset "
                        "(default: the first four)")
    parser.add_argument("--cache", help="numba's cache folder (default: a new empty one; "
                        "'default': numba's cache beside the sources)")
    parser.add_argument("--uptime", type=float, default=60.0,
                        help="seconds the server is up before the click (default 60)")
    parser.add_argument("--timeout", type=float, default=600.0)
    parser.add_argument("--without-browser", action="store_true",
                        help="the server's share only: the app in this process, Play pressed "
                        "as a page's click arrives")
    arguments = parser.parse_args()
    if arguments.without_browser:
        print(f"{'case':<22} {'cache':<5} {'click at':>9} {'says preparing':>15} "
              f"{'first moving':>13}  (server only)")
        for case in arguments.cases:
            cache = arguments.cache or tempfile.mkdtemp(prefix="numba-cold-")
            state = cache_state(cache)
            result = measure_in_process(case, cache, arguments.uptime, arguments.timeout)
            said = ("before the click" if result["preparing_before"] else
                    "-" if result["said"] is None else f"{result['said']:.2f} s")
            print(f"{case:<22} {state:<5} {result['up']:8.1f}s "
                  f"{said:>15} {result['moving']:12.2f}s", flush=True)
        os._exit(0)  # the app is stopped; skip the libraries' thread teardown at exit
    from playwright.sync_api import sync_playwright

    print(f"{'case':<22} {'cache':<5} {'page up':>8} {'click at':>9} {'says preparing':>15} "
          f"{'first moving':>13}")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        for case in arguments.cases:
            cache = arguments.cache or tempfile.mkdtemp(prefix="numba-cold-")
            state = cache_state(cache)
            result = measure(browser, case, cache, arguments.uptime, arguments.timeout)
            said = ("before the click" if result["preparing_before"] else
                    "-" if result["said"] is None else f"{result['said']:.2f} s")
            print(f"{case:<22} {state:<5} "
                  f"{result['loaded']:7.1f}s {result['up']:8.1f}s {said:>15} "
                  f"{result['moving']:12.2f}s", flush=True)
        browser.close()


if __name__ == "__main__":
    main()
