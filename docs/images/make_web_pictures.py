"""Take the README's pictures of the web page from the product, in a real (headless) Chromium at a
laptop's size (1366x768 CSS pixels):

* ``web_before_play.png``: ``oscillators serve grid`` as it opens, before Play;
* ``web_interference.png``: ``oscillators serve interference`` after 25 s of play (wall time);
* ``web_dispersion.png``: the Dispersion folder of ``oscillators serve ionic`` (the panel only).

Each is saved as a full-colour PNG.  Run from the repository root (about a minute)::

    .venv/bin/python docs/images/make_web_pictures.py [--only web_before_play]
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))

import sim  # noqa: E402
from app.web.app import WebApp  # noqa: E402
from tests.helpers import CHROMIUM, CHROMIUM_ARGS, free_port, wait_for  # noqa: E402

PICTURES = {"web_before_play": ("grid", 0.0), "web_interference": ("interference", 25.0),
            "web_dispersion": ("ionic", 0.0)}
"""Picture name -> (preset, seconds of play before the screenshot)."""
FOLDERS = {"web_dispersion": ("Dispersion", "chosen wave", "Launch this wave")}
"""Pictures of one folder of the panel: name -> (folder, a label of the plot it shows, its last
button: the picture goes from above the plot to below that button)."""


def take(name: str, preset: str, play: float, browser) -> Path:
    from PIL import Image

    app = WebApp(sim.Simulation(sim.scenes.build(preset)), port=free_port())
    app.start()
    try:
        height = 1300 if name in FOLDERS else 768  # a folder's picture: room for all of it
        page = browser.new_page(viewport={"width": 1366, "height": height})
        page.goto(app.url)
        page.get_by_text("Connected").wait_for(timeout=60_000)
        # the notice that the browser draws without a graphics card is not the product's
        close = page.locator(".mantine-Notification-closeButton")
        time.sleep(3.0)
        for button in close.all():
            button.click()
        if play:
            app.runner.play()
            assert wait_for(lambda: app.runner.simulation.step_count > 0, timeout=60)
            time.sleep(play)
            app.runner.pause()
        clip = None
        if name in FOLDERS:
            folder, label, last = FOLDERS[name]
            page.get_by_text(folder, exact=True).first.click()
            plot = page.locator(".uplot-container", has_text=label).first
            plot.wait_for(timeout=30_000)
            button = page.get_by_role("button", name=last)
            button.scroll_into_view_if_needed()
            time.sleep(1.0)
            box, end = plot.bounding_box(), button.bounding_box()
            top = max(box["y"] - 140, 0)
            clip = {"x": box["x"] - 12, "y": top, "width": box["width"] + 24,
                    "height": min(end["y"] + end["height"] + 60, height) - top}
        time.sleep(3.0)
        shot = Image.open(io.BytesIO(page.screenshot(clip=clip))).convert("RGB")
        path = HERE / f"{name}.png"
        shot.save(path, optimize=True)  # full colour: 256 colours band the colour bar
        return path
    finally:
        app.stop()


def main() -> None:
    from playwright.sync_api import sync_playwright

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="*", choices=list(PICTURES), default=list(PICTURES))
    arguments = parser.parse_args()
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            for name in arguments.only:
                preset, play = PICTURES[name]
                print(take(name, preset, play, browser))
        finally:
            browser.close()


if __name__ == "__main__":
    main()
