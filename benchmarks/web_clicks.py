"""How fast a real page answers a click while the flagship plays.

Starts the web app on ``interference`` (682x383 particles) in this process, opens Debian's
headless Chromium at 1366x768 through Playwright and clicks the *View* folder's title
``--clicks`` times (it opens and closes in the page alone), first on the paused page, then while
the run plays, and *Pause* (``--clicks`` / 2 times) until the button reads *Play* again (a round
trip through the server).  Each click is timed twice: in the page, as a reader sees it (the
folder: the browser's own Event Timing, from the input to the next frame painted after the page
handled it; *Pause*: from the click to the frame that shows *Play*), and by
Playwright (from its click until it sees the answer, which adds its own checks: two animation
frames before clicking, then polling, all sharing the 2 cores).  It counts the page's long
tasks (PerformanceObserver ``longtask``: main-thread work of 50 ms or more, which is what a
click waits behind) in each phase, and the pictures the page shows while it plays (texture
uploads of the picture's size, counted in the page).  ``--trace FILE`` writes a Chrome trace of
the playing phase (open it in chrome://tracing or ui.perfetto.dev).

    .venv/bin/python benchmarks/web_clicks.py                       # 8 clicks paused, 8 playing
    .venv/bin/python benchmarks/web_clicks.py --rate 4 --clicks 12 --trace /tmp/trace.json
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import sim  # noqa: E402
from app.web.app import WebApp  # noqa: E402
from tests.helpers import (  # noqa: E402
    CHROMIUM,
    CHROMIUM_ARGS,
    CLICK_CLOCKS,
    folder_click_delays,
    free_port,
    open_page,
    pause_click_delays,
    wait_for,
)

LONG_TASKS = """
window.__long = [];
new PerformanceObserver(list => {
  for (const entry of list.getEntries()) window.__long.push([entry.startTime, entry.duration]);
}).observe({entryTypes: ["longtask"]});
"""
PICTURES_SHOWN = """
window.__pictures = [];
for (const context of [WebGLRenderingContext, WebGL2RenderingContext]) {
  for (const name of ["texImage2D", "texSubImage2D"]) {
    const upload = context.prototype[name];
    context.prototype[name] = function (...args) {
      const source = args[args.length - 1];
      if (source && source.width >= 300 && source.height >= 200)
        window.__pictures.push(performance.now());
      return upload.apply(this, args);
    };
  }
}
"""
"""Counts the pictures the page shows: each new picture of the lattice is one texture upload
of the picture's size (a page-side counter; the colour bar is not in the 3-D scene)."""


def pictures_per_second(page, since_ms: float) -> float:
    """Pictures the page uploaded to its 3-D view per second since ``since_ms``."""
    count, now = page.evaluate(
        f"[window.__pictures.filter(t => t >= {since_ms}).length, performance.now()]")
    return count / max(1e-3, (now - since_ms) / 1e3)


def busy_share(page, since_ms: float) -> tuple[float, int, float]:
    """(share of the time since ``since_ms`` the page's thread spent in long tasks, their
    number, the longest in seconds)."""
    tasks = page.evaluate(f"window.__long.filter(t => t[0] >= {since_ms})")
    now = page.evaluate("performance.now()")
    busy = sum(d for _, d in tasks)
    return busy / max(1.0, now - since_ms), len(tasks), max((d for _, d in tasks), default=0) / 1e3


def summary(name: str, delays: list[float]) -> str:
    return (f"{name}: median {statistics.median(delays):.2f} s, max {max(delays):.2f} s "
            f"({', '.join(f'{d:.2f}' for d in delays)})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clicks", type=int, default=8)
    parser.add_argument("--rate", type=float, default=None,
                        help="pictures per second (the View folder's choice; default: the app's)")
    parser.add_argument("--pause", type=float, default=0.7, help="seconds between clicks")
    parser.add_argument("--warm-up", type=float, default=8.0)
    parser.add_argument("--query", default="",
                        help="added to the page's address (e.g. ?fixedDpr=1: full resolution "
                        "in software)")
    parser.add_argument("--trace", type=Path, default=None)
    arguments = parser.parse_args()
    from playwright.sync_api import sync_playwright

    # a run that outlasts the measurement (the page pauses a run at its scene's duration, which
    # the flagship's 150 s reach in about 30 s on an idle machine)
    scene = dataclasses.replace(sim.scenes.build("interference"), duration=1e6)
    app = WebApp(sim.Simulation(scene), port=free_port())
    if arguments.rate is not None:
        app.view.settings.picture_rate = arguments.rate
    app.start()
    print(f"load average at start: {os.getloadavg()[0]:.2f}")
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1366, "height": 768})
            page.add_init_script(LONG_TASKS + PICTURES_SHOWN + CLICK_CLOCKS)
            open_page(page, app.url + arguments.query)
            time.sleep(3.0)
            since = page.evaluate("performance.now()")
            paused, paused_walls = folder_click_delays(page, arguments.clicks, arguments.pause,
                                                       60_000)
            paused_busy = busy_share(page, since)
            app.runner.play()
            assert wait_for(lambda: app.runner.simulation.step_count > 50, timeout=120)
            time.sleep(arguments.warm_up)
            if arguments.trace:
                browser.start_tracing(page=page, path=str(arguments.trace), screenshots=False)
            since = page.evaluate("performance.now()")
            steps = app.runner.simulation.step_count
            started = time.perf_counter()
            playing, playing_walls = folder_click_delays(page, arguments.clicks, arguments.pause,
                                                         60_000)
            elapsed = time.perf_counter() - started
            playing_busy = busy_share(page, since)
            shown = pictures_per_second(page, since)
            if arguments.trace:
                browser.stop_tracing()
            rate = (app.runner.simulation.step_count - steps) / elapsed
            pauses, pause_walls = pause_click_delays(page, app.runner.play, arguments.clicks // 2,
                                                     arguments.pause)
            pictures = app.view._image.sent if app.view._image is not None else 0
            browser.close()
    finally:
        app.stop()
    print("answered, as the page paints it:")
    print(summary("  folder paused ", paused))
    print(summary("  folder playing", playing))
    print(summary("  Pause playing ", pauses))
    print("answered, as Playwright sees it:")
    print(summary("  folder paused ", paused_walls))
    print(summary("  folder playing", playing_walls))
    print(summary("  Pause playing ", pause_walls))
    for name, (share, count, longest) in (("paused ", paused_busy), ("playing", playing_busy)):
        print(f"{name}: page thread in long tasks {100 * share:.0f} % of the time, {count} tasks, "
              f"longest {longest:.2f} s")
    print(f"pictures shown in the page while clicking: {shown:.1f} per second")
    print(f"simulation while clicking: {rate:.0f} steps/s; pictures sent in all: {pictures}; "
          f"load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
