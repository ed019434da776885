"""In a real (headless) Chromium: Hear the probes puts a player in the Probes folder that the
browser decodes, as long as the sound the server made, and Stop probing takes it away."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from sim.theory.modes import excited_state
from tests.helpers import free_port, open_page, wait_for

pytestmark = [pytest.mark.browser, pytest.mark.slow]  # a page load: about 20 s

DURATION = """() => new Promise(resolve => {
    const audio = document.querySelector("audio");
    if (!audio) { resolve(null); return; }
    if (audio.readyState >= 1) { resolve(audio.duration); return; }
    audio.addEventListener("loadedmetadata", () => resolve(audio.duration), {once: true});
    audio.addEventListener("error", () => resolve(-1), {once: true});
    audio.load();
})"""
"""The page's audio player's duration (s) once the browser has read the WAV; -1 if it cannot."""


def test_the_page_plays_a_probe_and_stop_probing_removes_the_player(tmp_path, browser):
    model = sim.scenes.build("chain", linear=True).model
    positions, velocities = excited_state(model, 1, 1, 0, 0.05)
    scene = sim.Scene(name="chain", model=model, initial_positions=positions,
                      initial_velocities=velocities, integrator="exact", dt=0.1, duration=400.0)
    app = WebApp(sim.Simulation(scene), port=free_port(), scenes_dir=tmp_path,
                 recordings_dir=tmp_path)
    app.start()
    try:
        assert wait_for(lambda: app.view.last_positions is not None)
        page = browser.new_page(viewport={"width": 1366, "height": 768})
        open_page(page, app.url)
        probes = app.panel.probes
        app.set_selection(np.array([2]))
        page.get_by_text("Probes", exact=True).click()  # open the folder
        page.get_by_role("button", name="Probe the selection").click()
        assert wait_for(lambda: probes.series is not None)
        probes.component.value = "x"
        app.panel.run.speed.value = "as fast as it can"
        app.runner.steps_per_frame = 5  # a frame every 0.5 s: mode 1 is 0.49 Hz
        app.runner.play()
        assert wait_for(lambda: (probes.series.last_time or 0) > 100, timeout=60)
        app.runner.pause()
        page.get_by_role("button", name="Hear the probes").click()
        page.locator("audio").wait_for(timeout=10_000)
        assert page.get_by_text("sounds as").count() == 1
        seconds = float(probes.player.content.split(" s of sound")[0].rsplit("; ", 1)[1])
        assert page.evaluate(DURATION) == pytest.approx(seconds, abs=0.01)
        page.get_by_role("button", name="Stop probing").click()
        page.locator("audio").wait_for(state="detached", timeout=10_000)
    finally:
        app.stop()
