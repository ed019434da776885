"""The ripple-tank page in a real (headless) Chromium: a small double slit shows its Sources,
Barrier, Screen and Tape and stopwatch folders; a key press on the slit-width slider rebuilds the
barrier on the server; while it plays, the screen's picture arrives and the stopwatch counts
simulated time."""

from __future__ import annotations

import pytest

import sim
from app.web.app import WebApp
from tests.helpers import free_port, open_page, wait_for

pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def web_app(tmp_path):
    scene = sim.scenes.build(
        "double-slit", nx=36, ny=25, sponge_width=4,
        sources="column=6,row=all,direction=z,amplitude=0.01,frequency=0.33,ramp=3",
        barriers=[{"column": 14, "openings": [[7, 9], [15, 17]]}])
    app = WebApp(sim.Simulation(scene), port=free_port(), scenes_dir=tmp_path / "scenes",
                 recordings_dir=tmp_path / "recordings")
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None)
    yield app
    app.stop()



def test_the_double_slit_page_rebuilds_its_barrier_and_shows_the_screen(web_app, browser):
    page = browser.new_page(viewport={"width": 1366, "height": 900})
    page.set_default_timeout(60_000)  # a shared machine's software rendering is slow
    open_page(page, web_app.url)
    for title in ("Sources", "Barrier", "Screen", "Tape and stopwatch"):
        page.locator(f"text={title} >> visible=true").first.wait_for(timeout=60_000)
    assert web_app.runner.simulation.model.barriers[0].openings == ((7, 9), (15, 17))
    page.get_by_text("Slit width (particles)", exact=True).wait_for(timeout=60_000)
    thumb = page.locator('[role=slider][aria-valuemax="40"][aria-valuenow="3"]')  # its thumb
    thumb.focus()
    page.keyboard.press("ArrowRight")  # 3 -> 4 open particles per slit
    assert wait_for(lambda: web_app.runner.simulation.model.barriers[0].openings
                    == ((7, 10), (15, 18)), timeout=20)
    page.get_by_text("now barrier along column 14 (openings 7-10, 15-18)").wait_for(
        timeout=60_000)
    page.locator("text=Tape and stopwatch >> visible=true").first.click()  # open the folder
    page.get_by_role("button", name="Start stopwatch", exact=True).click()
    page.get_by_role("button", name="Play", exact=True).click()
    assert wait_for(lambda: web_app.panel.measure.stopwatch.simulated > 3.0, timeout=240)
    page.get_by_text("of simulated time (running").first.wait_for(timeout=60_000)
    assert wait_for(lambda: web_app.panel.screen.screen.whole_periods >= 1, timeout=240)
    page.get_by_text("from the lattice's dispersion", exact=False).first.wait_for(timeout=60_000)
