"""What a student sees in a real (headless) Chromium: the page before Play shows the lattice and
its colour bar; a recording made on the page downloads as a file rerun reads back; at phone size
the lattice and its colour bar are in view and not under the panel; while the flagship plays a
click the server answers comes back within half a second (a click on a folder, answered by the page
alone, is measured).  Only the first test runs by default (the others are
marked slow)."""

from __future__ import annotations

import io
import math
import time

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from tests.helpers import (
    CLICK_CLOCKS,
    draws_in_software,
    folder_click_delays,
    free_port,
    open_page,
    pause_click_delays,
    wait_for,
)

pytestmark = pytest.mark.browser



def canvas_pixels(page) -> np.ndarray:
    from PIL import Image

    shot = page.locator("canvas").first.screenshot(timeout=90_000)
    return np.asarray(Image.open(io.BytesIO(shot)).convert("RGB")).astype(int)


def page_pixels(page) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(page.screenshot()))).astype(int)[:, :, :3]


def bar_ends(pixels: np.ndarray) -> tuple[int, int]:
    """(blue, red) pixel counts: the two ends of a colour bar."""
    blue = ((pixels[:, :, 2] > 180) & (pixels[:, :, 0] < 90)).sum()
    red = ((pixels[:, :, 0] > 180) & (pixels[:, :, 2] < 90)).sum()
    return int(blue), int(red)


def client_of(app: WebApp):
    """The one page connected (the newest: a page that reloaded itself leaves its first
    connection behind)."""
    assert wait_for(lambda: len(app.server.get_clients()) == 1)
    return app.server.get_clients()[max(app.server.get_clients())]


def lattice_box(app: WebApp, client, view_width: float) -> tuple[float, float, float, float]:
    """(left, top, right, bottom) CSS pixels of the lattice's walls in ``client``'s view
    ``view_width`` CSS pixels wide (the camera looks straight down; viser reports the canvas in
    its own pixels, CSS pixels times the page's drawing resolution)."""
    camera = client.camera
    model = app.runner.simulation.model
    half_h = (camera.position[2] - 0.0) * math.tan(camera.fov / 2)
    half_w = half_h * camera.image_width / camera.image_height
    a = model.spacing
    xs = np.array([-(model.nx + 1) * a / 2, (model.nx + 1) * a / 2])
    ys = np.array([(model.ny + 1) * a / 2, -(model.ny + 1) * a / 2])
    u = ((xs - camera.position[0]) / half_w / 2 + 0.5) * camera.image_width
    v = (0.5 - (ys - camera.position[1]) / half_h / 2) * camera.image_height
    scale = view_width / camera.image_width
    return u[0] * scale, v[0] * scale, u[1] * scale, v[1] * scale


def test_page_before_play_shows_the_lattice_and_a_recording_downloads(web_app, browser, tmp_path):
    from rerun.chunk import RrdReader

    page = browser.new_page(viewport={"width": 1366, "height": 768}, accept_downloads=True)
    open_page(page, web_app.url)
    # a browser drawing in software (WebGL's renderer name, asked here) reloads the page once
    # at half its resolution; the server knows the view's size in CSS pixels either way
    assert ("fixedDpr=0.5" in page.url) == draws_in_software(page), page.url
    client = client_of(web_app)
    assert wait_for(lambda: web_app.page_views.css_size(client.client_id) == (1366, 768))
    assert not web_app.runner.playing
    time.sleep(2.0)  # the scene's nodes reach the page
    pixels = canvas_pixels(page)
    colours = {tuple(c) for c in pixels[::4, ::4].reshape(-1, 3)}
    assert len(colours) > 50  # not one colour: walls, particles, springs, colour bar
    # the colour bar floats over the view's bottom-left corner, below the lattice
    tab = page.get_by_text("Colours", exact=True).bounding_box()
    assert tab["x"] < 100 and tab["y"] > 768 / 2
    window = page_pixels(page)[round(tab["y"]):, : 450]
    assert bar_ends(window) > (100, 100)
    left, top, right, bottom = lattice_box(web_app, client_of(web_app), 1366)
    assert bottom < tab["y"] and left >= 0 and right <= 1366 - 400
    # record a little of the run, then take it home
    page.get_by_text("Recording", exact=True).click()  # open the folder
    page.get_by_role("button", name="Start recording").click()
    assert wait_for(lambda: web_app.recordings.active)
    web_app.runner.play()
    steps = web_app.runner.simulation.step_count
    assert wait_for(lambda: web_app.runner.simulation.step_count > steps + 100)
    downloads = []
    page.on("download", lambda download: downloads.append(download))
    page.get_by_role("button", name="Download recording").click()
    for _ in range(600):  # the recording and its read-me, in either order
        if len(downloads) == 2:
            break
        page.wait_for_timeout(100)
    names = sorted((d.suggested_filename for d in downloads), key=lambda n: n.endswith(".md"))
    assert len(names) == 2 and names[0].endswith(".rrd"), names
    assert names[1] == names[0].removesuffix(".rrd") + "-readme.md", names
    for download in downloads:  # both finished before the page goes (a browser closed
        download.save_as(tmp_path / download.suggested_filename)  # mid-download may hang)
    page.context.close()
    chunks = RrdReader(tmp_path / names[0]).stream().to_chunks()
    assert any(c.entity_path == "/lattice/particles" and not c.is_static for c in chunks)
    assert "grid" in (tmp_path / names[1]).read_text()  # the read-me names the scene


@pytest.mark.slow
def test_phone_size_lattice_in_view_and_not_under_the_panel(web_app, browser):
    page = browser.new_page(viewport={"width": 414, "height": 896})
    open_page(page, web_app.url)
    client = client_of(web_app)
    assert wait_for(lambda: web_app.page_views.css_size(client.client_id) == (414, 896))
    seen = {}

    def in_view() -> bool:
        """The lattice inside the view, above the panel and not a speck (the camera the page
        reported last: it reaches the fitted camera after its move there).  The panel starts
        folded to its title bar, so the lattice and the colour bar under it take the view
        above it: this 12 x 8 lattice spans about 90 % of the view's width."""
        left, top, right, bottom = lattice_box(web_app, client, 414)
        panel_top = page.get_by_text("Connected").bounding_box()["y"]
        seen.update(box=(left, top, right, bottom), panel_top=panel_top)
        return (left >= 0 and right <= 414 and top >= 0 and bottom < panel_top - 5
                and right - left > 0.8 * 414)

    # the panel starts folded to its title bar at the bottom (app.web.phone)
    play = page.get_by_role("button", name="Play")
    play.wait_for(state="hidden", timeout=30_000)
    assert wait_for(lambda: page.get_by_text("Connected").bounding_box()["y"] > 896 - 80)
    assert wait_for(in_view, timeout=30), seen
    # the colour bar lies under the lattice in this page's own scene, above the folded panel
    left, top, right, bottom = seen["box"]
    under = page_pixels(page)[round(bottom):round(seen["panel_top"]), :]
    assert bar_ends(under) > (50, 50), seen
    # one tap on its title bar opens the panel, another folds it again
    page.get_by_text("Connected").click()
    play.wait_for(state="visible", timeout=30_000)
    page.get_by_text("Connected").click()
    play.wait_for(state="hidden", timeout=30_000)
    time.sleep(1.0)
    assert web_app.clients.dropped == [] and list(web_app.server.get_clients().values()) == [client]
    assert in_view(), seen


@pytest.mark.slow
def test_phone_size_shows_the_flagship_and_its_colour_bar_above_the_panel(browser):
    """The flagship at 414x896: its lattice (grey before Play) and the colour bar under it are
    drawn above the panel, neither cut off by the far clipping plane (the fitted camera is
    1070 m away, beyond viser's default 1000 m) nor replaced by the laptop's initial camera that
    a loading page applies late."""
    app = WebApp(sim.Simulation(sim.scenes.build("interference")), port=free_port())
    app.start()
    try:
        page = browser.new_page(viewport={"width": 414, "height": 896})
        open_page(page, app.url)
        seen = {}

        def shown() -> bool:
            panel_top = round(page.get_by_text("Connected").bounding_box()["y"])
            above = page_pixels(page)[:panel_top - 30]
            grey = (np.abs(above - 128) < 14).all(axis=2).mean()
            seen.update(grey=grey, ends=bar_ends(above), panel_top=panel_top)
            return 0.2 < grey < 0.8 and bar_ends(above) > (50, 50)

        assert wait_for(shown, timeout=60), seen
    finally:
        app.stop()


@pytest.fixture
def flagship_page(browser):
    """The flagship served and shown in a 1366x768 page, its run playing for 8 s."""
    app = WebApp(sim.Simulation(sim.scenes.build("interference")), port=free_port())
    app.start()
    try:
        page = browser.new_page(viewport={"width": 1366, "height": 768})
        page.add_init_script(CLICK_CLOCKS)
        open_page(page, app.url)
        time.sleep(2.0)
        yield app, page
    finally:
        app.stop()


def play_the_flagship(app: WebApp) -> None:
    app.runner.play()
    assert wait_for(lambda: app.runner.simulation.step_count > 50, timeout=120)
    time.sleep(8.0)  # past the first seconds, when the colour scale settles
    assert app.runner.playing and app.view._image is not None


@pytest.mark.slow
def test_a_click_the_server_answers_comes_back_within_half_a_second_while_the_flagship_plays(
        flagship_page):
    """Pause pressed while the flagship plays: the page's panel shows the server's answer (the
    button reads Play) within half a second of the page taking the click, median of five.
    Measured on the shared 2-core machine (load average 5-12): 0.02-0.6 s, medians 0.04-0.07 s.
    Playwright's click itself waits until the busy page takes it, 0.3-3 s there; that time is
    reported, not held to the target."""
    app, page = flagship_page
    play_the_flagship(app)
    answers, walls = pause_click_delays(page, app.runner.play)
    assert np.median(answers) <= 0.5, (answers, walls)


@pytest.mark.slow
def test_a_folder_click_is_answered_within_half_a_second_while_the_flagship_plays(flagship_page):
    """Headless Chromium draws WebGL without a graphics card; the page gets a new picture only
    when it has drawn the previous one (``app.web.pacing``) and draws at half resolution
    (``app.web.page_views``), so a click on a folder is painted within half a second, median of
    six, as the browser itself measures it (Event Timing: from the input to the next frame
    painted after the page handled it).  Playwright's own time, which adds its checks before and
    after the click (0.5-1 s on this 2-core machine while the flagship plays), is reported."""
    app, page = flagship_page
    paused, _ = folder_click_delays(page)
    checkbox = app.panel.view.show_springs
    before = checkbox.value
    play_the_flagship(app)
    playing, walls = folder_click_delays(page)
    assert checkbox.value == before  # opening the folder changed nothing
    assert len(playing) == 6 and np.median(playing) <= 0.5, (paused, playing, walls)
