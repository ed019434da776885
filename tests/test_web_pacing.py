"""How the page paces the run: the speed (real time or slow motion) sets the runner's frame rate
from dt and the steps per frame, the status line says the rate, a scene pauses at its duration
unless asked to go on, and the last page leaving pauses the run unless a recording is on."""

from __future__ import annotations

import pytest

from tests.helpers import wait_for
from tests.test_web_safety import PageClient, press, send


@pytest.mark.parametrize("speed, factor", [("x1", 1.0), ("x1/2", 0.5), ("x1/4", 0.25)])
def test_speed_sets_simulated_seconds_per_wall_second(web_app, speed, factor):
    folder = web_app.panel.run
    send(folder.speed, speed, PageClient())
    runner = web_app.runner
    frames_per_second = runner.max_fps
    assert frames_per_second * runner.steps_per_frame * runner.simulation.dt == pytest.approx(factor)
    runner.play()
    assert wait_for(lambda: "rate" in folder.status.content and "running" in folder.status.content)
    assert f"({speed}" in folder.status.content


def test_scene_pauses_at_its_duration_unless_asked_to_go_on(web_app):
    runner = web_app.runner
    duration = runner.simulation.scene.duration
    steps = round((duration - 0.05) / runner.simulation.dt)
    runner.post(lambda simulation: simulation.step(steps)).result(timeout=30)
    folder = web_app.panel.run
    press(folder.play_button, PageClient())
    assert wait_for(lambda: not runner.playing and runner.simulation.time >= duration - 1e-9)
    stopped_at = runner.simulation.time
    assert stopped_at < duration + 0.2  # within a few frames of it
    assert wait_for(lambda: "duration" in folder.end_html.content)
    press(folder.play_button, PageClient())  # go on
    assert wait_for(lambda: runner.simulation.time > stopped_at + 0.5)
    assert runner.playing


def test_last_page_leaving_pauses_unless_recording(web_app):
    runner = web_app.runner
    runner.play()
    web_app.client_left(12345)  # no page is connected in this test
    assert runner.playing  # a few seconds for a page that reloads itself to come back
    assert wait_for(lambda: not runner.playing)
    press(web_app.panel.recording.record_button, PageClient())
    assert wait_for(lambda: web_app.recordings.active)
    runner.play()
    web_app.client_left(12345)
    assert runner.playing
    web_app.recordings.stop()


def test_probe_spectrum_axis_fits_its_peaks():
    """A 1.2 Hz oscillation sampled at 100 frames a second: the spectrum drawn stops near the
    peak (not at the 50 Hz Nyquist frequency), and keeps the peak."""
    import numpy as np

    from app.web.folders.probes import shown_band

    times = np.arange(0, 40, 0.01)
    values = 0.01 * np.sin(2 * np.pi * 1.2 * times)
    amplitudes = np.abs(np.fft.rfft(values)) * 2 / times.size
    frequencies = np.fft.rfftfreq(times.size, 0.01)
    shown, column = shown_band(frequencies, [amplitudes])
    assert 1.2 < shown[-1] < 3.0
    assert shown[np.argmax(column)] == pytest.approx(1.2, abs=0.05)
