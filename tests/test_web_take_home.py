"""What a student takes home from the page, without a browser: the recording just made (read back
with rerun's API) and its read-me, the movie made as a page job (progress, one at a time, cancel,
ended by the server's stop), and the camera that frames the lattice in the part of the view the
panel leaves.  Buttons are pressed the way viser runs them (``tests.test_web_safety.press``)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import sim
from app.web.colour_bar import (
    BAR_ASPECT,
    OVERLAY_HEIGHT,
    PHONE_BAR_WIDTH,
    PHONE_FONTS,
    bar_pose,
    bar_width,
)
from app.web.view import NARROW, PANEL_WIDTH, PHONE_PANEL_SHARE, camera_fit, laptop_fit
from tests.helpers import wait_for
from tests.test_web_safety import PageClient, press


def test_download_recording_hands_over_the_rrd_and_its_readme(web_app):
    from rerun.chunk import RrdReader

    folder = web_app.panel.recording
    press(folder.record_button, PageClient())
    assert wait_for(lambda: web_app.recordings.active)
    web_app.runner.play()
    steps = web_app.runner.simulation.step_count
    assert wait_for(lambda: web_app.runner.simulation.step_count > steps + 200)
    web_app.runner.pause()
    client = PageClient()
    press(folder.download_button, client)  # the running recording is closed, then sent
    (name, content), (readme_name, readme) = client.downloads
    assert name.endswith(".rrd") and readme_name == name[:-4] + "-readme.md"
    assert b"# grid" in readme and b"time step dt" in readme
    assert not web_app.recordings.active and folder.record_button.label == "Start recording"
    path = web_app.recordings.directory / "downloaded.rrd"
    path.write_bytes(content)
    chunks = RrdReader(path).stream().to_chunks()
    frames = {int(s) for c in chunks if c.entity_path == "/lattice/particles" and not c.is_static
              for s in c.to_record_batch().column("step").to_pylist()}
    assert len(frames) > 10


def test_download_recording_without_one_says_what_to_do(web_app):
    client = PageClient()
    press(web_app.panel.recording.download_button, client)
    assert not client.downloads
    assert "Start recording" in web_app.panel.recording.record_text.content


def test_movie_job_shows_progress_refuses_a_second_and_cancels(web_app):
    folder = web_app.panel.recording
    jobs = web_app.recordings.jobs
    web_app.replace_scene(sim.scenes.build("grid", nx=60, ny=40), source="test")  # a slow movie
    first = PageClient()
    press(folder.movie_button, first)
    assert wait_for(lambda: jobs.running and jobs.done > 0)
    assert folder.movie_button.label == "Cancel the movie"
    assert wait_for(lambda: "frames" in folder.movie_text.content and "%" in folder.movie_text.content)
    # a second request from another page while the movie is made: refused in words
    assert "is being made" in _second_request_refusal(web_app)
    press(folder.movie_button, first)  # the button now cancels
    assert wait_for(lambda: not jobs.running)
    assert jobs.outcome == "cancelled" and not first.downloads
    assert "cancelled" in folder.movie_text.content
    assert folder.movie_button.label == "Download a movie"


def _second_request_refusal(web_app) -> str:
    from app.web.jobs import JobBusy

    try:
        web_app.recordings.jobs.start("movie", lambda report: None, lambda result, error: None)
    except JobBusy as refusal:
        return str(refusal)
    return ""


def test_the_servers_stop_ends_a_movie_being_made(web_app):
    jobs = web_app.recordings.jobs
    web_app.replace_scene(sim.scenes.build("grid", nx=60, ny=40), source="test")
    press(web_app.panel.recording.movie_button, PageClient())
    assert wait_for(lambda: jobs.running and jobs.done > 0)
    started = time.monotonic()
    web_app.recordings.shutdown()  # what the server's SIGTERM runs (WebApp.stop)
    assert not jobs.running and time.monotonic() - started < 10
    assert jobs.outcome == "cancelled"


@pytest.mark.parametrize("size", [(1366, 768), (414, 896)])
@pytest.mark.parametrize("scene", ["grid", "interference", "chain"])
def test_camera_fits_lattice_and_colour_bar_in_the_free_part(scene, size):
    """Project the walls' corners (and on a phone the in-scene colour bar under them) through
    the fitted camera (looking straight down): all inside the part of the view the panel (and
    on a laptop the floating colour bar) leaves, and the lattice spans most of it."""
    model = sim.scenes.build(scene).model
    fov = math.radians(75)
    aspect = size[0] / size[1]
    a = model.spacing
    width = (model.nx + 1) * a
    lowest = -(model.ny + 1) * a / 2
    if size[0] >= NARROW:
        position, look_at, _ = laptop_fit(model, fov, *size)
        right, bottom = PANEL_WIDTH / size[0], OVERLAY_HEIGHT / size[1]
    else:
        right, bottom = 0.0, PHONE_PANEL_SHARE
        position, look_at, _ = camera_fit(model, fov, aspect, bottom=bottom)
        lowest = -(model.ny - 1) * a / 2 - 1.5 * a - bar_width(model) * BAR_ASPECT
        assert lowest < bar_pose(model)[0][1] - bar_pose(model)[2] / 2 + 1e-9
        width = max(width, bar_width(model))
    assert position[:2] == look_at[:2]
    half_h = position[2] * math.tan(fov / 2)
    half_w = half_h * aspect
    xs = np.array([-width / 2, width / 2])
    ys = np.array([(model.ny + 1) * a / 2, lowest])
    u = (xs - position[0]) / half_w / 2 + 0.5  # 0 left edge of the view, 1 right edge
    v = 0.5 - (ys - position[1]) / half_h / 2  # 0 top, 1 bottom
    assert u.min() >= 0 and u.max() <= 1 - right + 1e-9
    assert v.min() >= 0 and v.max() <= 1 - bottom + 1e-9
    spans = ((u.max() - u.min()) / (1 - right), (v.max() - v.min()) / (1 - bottom))
    assert max(spans) > 0.85


def test_the_pages_movie_as_one_html_file_starts_at_the_runs_time(web_app):
    """"Download a movie" as an HTML page: one file, labelled from the run's own time."""
    import json
    import re

    from app.web.folders.recording import MOVIE_FORMATS

    folder = web_app.panel.recording
    jobs = web_app.recordings.jobs
    web_app.runner.play()
    assert wait_for(lambda: web_app.runner.simulation.time > 1.0)
    web_app.runner.pause()
    started_at = web_app.runner.simulation.time
    folder.movie_format.value = MOVIE_FORMATS[1]
    client = PageClient()
    press(folder.movie_button, client)
    assert wait_for(lambda: client.downloads, timeout=300)
    assert wait_for(lambda: not jobs.running, timeout=30)  # the job ends just after sending
    assert jobs.outcome != "cancelled"
    (name, content), = client.downloads
    assert name.endswith(".html")
    page = content.decode()
    data = json.loads(re.search(r"const CO = (\{.*?\});", page).group(1))
    assert abs(data["start"] - started_at) < 1e-6 and data["times"][0] == 0.0
    assert "__VISER_EMBED_DATA__" in page and "About this run" in page


@pytest.mark.parametrize("preset", sorted(sim.scenes.presets.PRESETS))
def test_a_phone_shows_every_presets_colour_bar_text_at_least_11_pixels(preset):
    """The in-scene bar's picture as wide as a phone (414x896) draws it: its smallest text at
    least 11 CSS px, and the bar in the part of the view above the panel."""
    from app.web.view import VIEW_FOV

    model = sim.scenes.build(preset).model
    width, height = 414, 896
    position, _, _ = camera_fit(model, VIEW_FOV, width / height, bottom=PHONE_PANEL_SHARE)
    half_w = position[2] * math.tan(VIEW_FOV / 2) * width / height
    centre, bar, bar_height = bar_pose(model)
    shown = bar / (2 * half_w) * width  # CSS px
    assert min(PHONE_FONTS) * shown / PHONE_BAR_WIDTH >= 11.0, shown
    half_h = position[2] * math.tan(VIEW_FOV / 2)
    low = 0.5 - (centre[1] - bar_height / 2 - position[1]) / half_h / 2
    assert low <= 1 - PHONE_PANEL_SHARE + 1e-9
def test_a_page_recording_on_a_full_disk_says_so_on_the_page_within_a_second(web_app,
                                                                              monkeypatch):
    import shutil

    folder = web_app.panel.recording
    press(folder.record_button, PageClient())
    assert wait_for(lambda: web_app.recordings.active)
    web_app.runner.play()
    assert wait_for(lambda: "recording to" in folder.record_text.content)
    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage",
                        lambda path: real(path)._replace(free=100_000))  # another writer filled it
    filled = time.monotonic()
    assert wait_for(lambda: "recording stopped" in folder.record_text.content, timeout=5)
    assert time.monotonic() - filled < 1.5
    assert "disk nearly full" in folder.record_text.content
    assert not web_app.recordings.active and folder.record_button.label == "Start recording"
    web_app.runner.pause()
