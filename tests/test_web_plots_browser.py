"""In a real (headless) Chromium: the Energy plot draws its lines in a scene under gravity (whose
value axis changes while it sags) and looks at the time the data span, and Reset empties the
Accuracy plot in the page."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from tests.helpers import free_port, open_page, wait_for

pytestmark = pytest.mark.browser

CHARTS = """() => Object.values((window.__viserTestpoints || {}).uplots || {}).map(({chart}) => ({
    labels: chart.series.map(s => s.label),
    x: [chart.scales.x.min, chart.scales.x.max],
    data: chart.data.map(column => Array.from(column)),
}))"""
"""Every uPlot in the page: its series' labels, its x range and its data."""


def chart(page, label: str) -> dict | None:
    return next((c for c in page.evaluate(CHARTS) if label in c["labels"]), None)


@pytest.fixture
def catenary_app(tmp_path):
    """A small lattice under gravity with dashpots (the catenary's kernel, compiled once)."""
    app = WebApp(sim.Simulation(sim.scenes.build("catenary", nx=6, ny=4)), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings")
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None, timeout=120)
    yield app
    app.stop()


def test_the_energy_plot_draws_under_gravity_and_reset_empties_the_accuracy_plot(
        catenary_app, browser):
    from PIL import Image

    app = catenary_app
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    open_page(page, app.url)
    app.runner.play()
    # the sagging lattice's energies move the value axis: the plot is rebuilt on the way
    assert wait_for(lambda: app.runner.simulation.time > 4.0, timeout=120)
    app.runner.pause()
    assert wait_for(lambda: app.panel.energy.plot.data[0].size > 100, timeout=30)
    time.sleep(1.5)  # the last data reach the page
    energy = chart(page, "kinetic")
    times = np.array(energy["data"][0])
    assert np.all(np.isfinite(np.array(energy["data"], dtype=float)))
    assert "gravity's potential" in energy["labels"]
    low, high = energy["x"]
    span = times[-1] - times[0]
    assert low is not None and high is not None, energy["x"]
    assert low <= times[0] + 0.05 * span and high >= times[-1] - 0.05 * span, (low, high, times)
    # its lines are drawn: the gravity line's colour and the total's (app.colours.ENERGY_COLOURS)
    from app.colours import ENERGY_COLOURS

    page.get_by_text("Energy", exact=True).scroll_into_view_if_needed()
    canvas = page.locator(".uplot-container", has_text="kinetic").locator("canvas").first
    pixels = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("RGB")).astype(int)
    gravity = (np.abs(pixels - ENERGY_COLOURS["gravity"]).max(axis=2) < 40).sum()
    total = (np.abs(pixels - ENERGY_COLOURS["total"]).max(axis=2) < 40).sum()
    assert gravity > 50 and total > 50, (gravity, total)

    assert len(chart(page, "energy-balance error")["data"][0]) > 10
    page.get_by_role("button", name="Reset").click()
    assert wait_for(lambda: app.runner.simulation.time == 0.0, timeout=10)
    assert wait_for(lambda: (c := chart(page, "energy-balance error")) is not None
                    and len(c["data"][0]) == 0, timeout=10)
    assert app.panel.accuracy.plot.data[0].size == 0
    assert chart(page, "kinetic")["data"][0] == []
