"""The web app in a real (headless) Chromium driven by Playwright.

Each test starts a ``WebApp`` on a free localhost port and stops it (and the browser) at the end.
All of them are marked slow (``pytest -m ''``; the page tests in the default suite drive
Chromium already).  Clicks on particles are aimed by projecting world points with the client's
camera (which the server knows): the camera looks straight down -z.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from tests.helpers import VIEWPORT, free_port, wait_for
from tests.helpers import open_page as open_app_page

pytestmark = pytest.mark.browser


@pytest.fixture
def web_app() -> Iterator[WebApp]:
    """An 11x7 grid (odd sizes: the middle particle sits at the origin), paused."""
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port())
    app.start()
    yield app
    app.stop()



def open_page(browser, app: WebApp):
    page = browser.new_page(viewport=VIEWPORT)
    open_app_page(page, app.url)
    # the 3-D view's canvas (viser also keeps an empty 0x0 one for drawing selection rectangles)
    page.locator("canvas:not([width='0'])").first.wait_for(timeout=20_000)
    return page


def choose(page, label: str, option: str) -> None:
    """Pick ``option`` in the viser dropdown labelled ``label`` (a Mantine combobox)."""
    page.get_by_label(label, exact=True).click()
    page.get_by_role("option", name=option, exact=True).click()


def to_screen(page, app: WebApp, xy: np.ndarray) -> tuple[float, float]:
    """Pixel position of the world point (x, y, 0) in the (only) client's view, whose camera
    looks straight down -z from above the point it is centred on (the lattice framed beside the
    panel, so not necessarily the origin)."""
    client = next(iter(app.server.get_clients().values()))
    camera = client.camera
    box = page.locator("canvas").first.bounding_box()
    centre_x, centre_y, height = camera.position
    half_height = height * math.tan(camera.fov / 2)
    half_width = half_height * box["width"] / box["height"]
    return (
        box["x"] + ((xy[0] - centre_x) / half_width + 1) / 2 * box["width"],
        box["y"] + (1 - (xy[1] - centre_y) / half_height) / 2 * box["height"],
    )


@pytest.mark.slow  # the page tests in the default suite drive Chromium already
def test_page_loads_and_a_gui_change_reaches_the_simulation(web_app, browser):
    page = open_page(browser, web_app)
    assert wait_for(lambda: len(web_app.server.get_clients()) == 1)
    assert page.locator("canvas").count() >= 1
    assert wait_for(lambda: web_app.frames_delivered > 0)
    choose(page, "Method", "verlet")
    page.get_by_label("Gravity", exact=True).check()
    assert wait_for(lambda: web_app.runner.simulation.integrator == "verlet")
    assert wait_for(lambda: web_app.runner.simulation.model.gravity[1] == pytest.approx(-9.81))


@pytest.mark.slow
def test_click_selects_and_gizmo_drag_displaces_the_particle(web_app, browser):
    page = open_page(browser, web_app)
    assert wait_for(lambda: web_app.view.last_positions is not None)
    particle = 2 * 11 + 3
    start = web_app.runner.simulation.peek_positions()[particle]
    page.mouse.click(*to_screen(page, web_app, start))
    assert wait_for(lambda: web_app.view.selection.tolist() == [particle])
    page.get_by_text(f"Selected particle {particle}").wait_for(timeout=10_000)
    time.sleep(1.0)  # let the gizmo reach the page
    # grab the gizmo's x arrow near its tip and pull it to the right
    grab_x, grab_y = to_screen(page, web_app, start + np.array([1.3, 0.0]))
    page.mouse.move(grab_x, grab_y)
    page.mouse.down()
    for step in range(1, 11):
        page.mouse.move(grab_x + 8 * step, grab_y, steps=2)
        time.sleep(0.05)
    page.mouse.up()
    target_x = start[0] + 0.5
    assert wait_for(lambda: web_app.runner.simulation.peek_positions()[particle][0] > target_x)
    moved = web_app.runner.simulation.peek_positions()
    assert moved[particle][1] == pytest.approx(start[1], abs=1e-6)
    assert wait_for(lambda: not web_app.runner.pins)  # released at the end of the drag


@pytest.mark.slow
def test_unstable_dt_shows_the_warning_and_pauses_finite(web_app, browser):
    page = open_page(browser, web_app)
    stable = web_app.runner.simulation.stable_dt()
    dt_box = page.get_by_label("Time step dt (s)", exact=True)
    dt_box.fill(f"{5 * stable:.4f}")
    dt_box.press("Enter")
    assert wait_for(lambda: web_app.runner.simulation.dt > stable)
    page.get_by_text("exceeds the stability limit").wait_for(timeout=10_000)
    page.get_by_role("button", name="Play").click()
    page.get_by_text("Stopped:").wait_for(timeout=20_000)
    assert not web_app.runner.playing
    assert np.isfinite(web_app.runner.simulation.peek_positions()).all()
    assert "stability limit" in (web_app.runner.error or "")


@pytest.mark.slow
def test_two_clients_share_the_lattice(web_app, browser):
    first = open_page(browser, web_app)
    second = open_page(browser, web_app)
    assert wait_for(lambda: len(web_app.server.get_clients()) == 2)
    first.get_by_label("Gravity", exact=True).check()
    assert wait_for(lambda: web_app.runner.simulation.model.has_gravity)
    second.get_by_role("button", name="Play").click()
    assert wait_for(lambda: web_app.runner.simulation.step_count > 20)
    assert wait_for(lambda: second.get_by_label("Gravity", exact=True).is_checked(), timeout=10)
    first.close()
    assert wait_for(lambda: len(web_app.server.get_clients()) == 1)
    steps = web_app.runner.simulation.step_count
    assert wait_for(lambda: web_app.runner.simulation.step_count > steps + 10)


@pytest.mark.slow  # the server side of the same checks runs by default (test_web_safety.py)
def test_paths_typed_into_the_page_touch_no_file_on_the_server(browser, tmp_path):
    """Hostile input in every box and every button pressed: nothing outside the scenes and
    recordings directories is created, and no scene outside the scenes directory is opened."""
    scenes, recordings = tmp_path / "scenes", tmp_path / "recordings"
    scenes.mkdir()
    secret = tmp_path / "secret.toml"
    sim.scenes.scene_files.save(sim.scenes.build("single"), secret)
    secret.write_text(secret.read_text().replace('name = "single"', 'name = "canary"'))
    (scenes / "link.toml").symlink_to(secret)
    cwd_before = set(os.listdir("."))
    hostile = ["../escape/x", str(tmp_path / "absolute" / "x.toml"), "/dev/zero"]
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=6, ny=4)), port=free_port(),
                 scenes_dir=scenes, recordings_dir=recordings)
    app.start()
    try:
        page = open_page(browser, app)
        for folder in ("Scene", "View", "Recording"):  # open the closed folders
            page.get_by_text(folder, exact=True).first.click()
        boxes = page.locator("input[type=text], input:not([type]), textarea")
        for text in hostile:
            for index in range(boxes.count()):
                box = boxes.nth(index)
                if box.is_visible() and box.is_enabled() and box.is_editable():
                    box.fill(text)
                    box.press("Enter")
            for name in ("Build scene", "Download this scene", "Open", "Refresh list",
                         "Start recording", "Stop recording", "Single step", "Reset"):
                button = page.get_by_role("button", name=name, exact=True)
                if button.count() and button.first.is_enabled():
                    button.first.click()
        page.locator("input[type=file]").set_input_files(
            files=[{"name": "../escape.toml", "mimeType": "text/plain",
                    "buffer": secret.read_bytes()}])
        assert wait_for(lambda: "escape.toml" in app.panel.scene.message.content)
        assert app.runner.simulation.scene.name != "canary" or "upload" in app.scene_source
        time.sleep(0.5)
    finally:
        app.stop()
    assert not (tmp_path / "escape").exists() and not (tmp_path / "absolute").exists()
    assert not Path("../escape").exists()
    assert set(os.listdir(".")) == cwd_before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["recordings", "scenes", "secret.toml"]
    assert sorted(p.name for p in scenes.iterdir()) == ["link.toml"]
    assert all(p.suffix == ".rrd" for p in recordings.glob("*"))
    assert "link.toml" not in app.scene_files.names()


@pytest.mark.slow
def test_the_drive_and_walls_controls_work_from_a_real_page(browser):
    app = WebApp(sim.Simulation(sim.scenes.build("resonance")), port=free_port())
    app.start()
    try:
        page = open_page(browser, app)
        assert app.runner.simulation.model.driver is not None
        stop = page.get_by_role("button", name="Stop driving", exact=True)
        if not stop.is_visible():
            page.get_by_text("Drive", exact=True).first.click()  # open the folder
        stop.click()
        assert wait_for(lambda: app.runner.simulation.model.driver is None)
        if not page.get_by_label("Walls", exact=True).is_visible():
            page.get_by_text("Scene", exact=True).first.click()  # open the folder
        choose(page, "Walls", "free")
        page.get_by_role("button", name="Apply walls", exact=True).click()
        assert wait_for(lambda: app.runner.simulation.model.boundary == "free")
    finally:
        app.stop()
