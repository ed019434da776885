"""In a real (headless) Chromium: the Dispersion folder's plot is drawn (its branches' colours and
the chosen wave's point on the canvas), and Launch this wave sets the lattice moving."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from app.web.folders.dispersion import COLOURS
from tests.helpers import free_port, open_page, wait_for
from tests.test_web_plots_browser import chart

pytestmark = pytest.mark.browser


POINT = """() => {
    const charts = Object.values((window.__viserTestpoints || {}).uplots || {}).map(u => u.chart);
    const u = charts.find(c => c.series.some(s => s.label === "chosen wave"));
    const column = u.series.findIndex(s => s.label === "chosen wave");
    const i = Array.from(u.data[column]).findIndex(v => Number.isFinite(v));
    const ratio = window.devicePixelRatio || 1;
    return [u.bbox.left / ratio + u.valToPos(u.data[0][i], "x"),
            u.bbox.top / ratio + u.valToPos(u.data[column][i], "y")];
}"""
"""Where (CSS px from the canvas' top-left corner) the chosen wave's point is drawn."""


def colour_pixels(pixels: np.ndarray, colour: str) -> int:
    rgb = np.array([int(colour[k:k + 2], 16) for k in (1, 3, 5)])
    return int((np.abs(pixels - rgb).max(axis=2) < 40).sum())


@pytest.fixture
def grid_app(tmp_path):
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=24, ny=16), integrator="verlet",
                                dt=0.02),
                 port=free_port(), scenes_dir=tmp_path / "scenes",
                 recordings_dir=tmp_path / "recordings")
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None, timeout=120)
    yield app
    app.stop()


@pytest.mark.slow  # 20-36 s on the 2-core machine (a page, a compiled run, a packet)
def test_the_dispersion_plot_is_drawn_and_a_launched_wave_moves_the_lattice(grid_app, browser):
    from PIL import Image

    app = grid_app
    page = browser.new_page(viewport={"width": 1366, "height": 900})
    open_page(page, app.url)
    page.get_by_text("Dispersion", exact=True).first.click()  # open the folder
    assert wait_for(lambda: chart(page, "chosen wave") is not None, timeout=30)
    drawn = chart(page, "chosen wave")
    assert {"x", "y", "x continuum", "x by verlet"} <= set(drawn["labels"])
    time.sleep(1.0)  # the chart paints
    canvas = page.locator(".uplot-container", has_text="chosen wave").locator("canvas").first
    canvas.scroll_into_view_if_needed()
    pixels = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("RGB")).astype(int)
    assert colour_pixels(pixels, COLOURS[0]) > 200 and colour_pixels(pixels, COLOURS[1]) > 200
    # the chosen wave's point (a series of one value, NaN elsewhere) is drawn where it belongs
    x, y = page.evaluate(POINT)
    near = pixels[int(y) - 3:int(y) + 4, int(x) - 3:int(x) + 4]
    assert near.size and near.max(axis=2).min() < 60, near.max(axis=2)

    try:
        import sim.scenes.packet  # noqa: F401
    except ImportError:
        pytest.skip("sim.scenes.packet (the wave packet launcher) is not in this build")
    simulation = app.runner.simulation
    assert not np.any(simulation.velocities)  # the preset starts at rest
    page.get_by_role("button", name="Launch this wave").click()
    assert wait_for(lambda: "launched a packet" in app.panel.dispersion.message.content,
                    timeout=30)
    launched = app.runner.post(lambda s: s.positions.copy()).result(timeout=10)
    assert np.abs(app.runner.post(lambda s: s.velocities.copy()).result(10)).max() > 0
    start_time = simulation.time
    app.runner.play()
    assert wait_for(lambda: simulation.time > start_time + 1.0, timeout=60)
    app.runner.pause()
    moved = np.abs(app.runner.post(lambda s: s.positions.copy()).result(10) - launched).max()
    assert moved > 1e-4 * simulation.model.spacing
