"""Jobs stop when asked: a page movie and a page choice stop within a second of Cancel (on the
job objects the page uses, no browser), a page choice too long for the page is refused at once
with an estimate that says how long it would take, and SIGTERM during `oscillators movie` ends
it with one line on stderr, exit 143 and no ``.partial`` file left."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import sim
from app.movie import render_movie
from app.web.choosing import PageChoice, PageProgress
from app.web.jobs import PageJobs

ROOT = Path(__file__).resolve().parents[1]


def LONG_CHOICE() -> sim.Scene:  # noqa: N802 - a constant that is built when used
    """A 40x30 grid over 100 s: its field reference alone is planned to take a minute or so."""
    return dataclasses.replace(sim.scenes.build("grid", nx=40, ny=30), duration=100.0)


class Text:
    """A stand-in for a folder's HTML widget: keeps every line shown."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    @property
    def content(self) -> str:
        return self.lines[-1] if self.lines else ""

    @content.setter
    def content(self, value: str) -> None:
        self.lines.append(value)


def _wait(condition, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.01)
    return condition()


def _time_to_stop(cancel, running) -> float:
    started = time.monotonic()
    assert cancel()
    assert _wait(lambda: not running(), 30)
    return time.monotonic() - started


@pytest.mark.slow  # renders a movie to cancel it
def test_a_page_movie_of_a_long_scene_stops_within_a_second_of_cancel(tmp_path) -> None:
    # 1e7 s in at most 30 frames: a million RK4 steps of the grid between two frames
    scene = dataclasses.replace(sim.scenes.build("grid"), duration=1e7)
    jobs = PageJobs()
    ended = threading.Event()
    jobs.start("movie", lambda report: render_movie(
        scene, tmp_path / "movie.mp4", progress=False, max_frames=30, size=(320, 180),
        on_frame=report), lambda result, error: ended.set())
    assert _wait(lambda: jobs.done >= 1, 600), jobs.status()  # the first frame is out
    time.sleep(0.5)  # well inside the steps to the second frame
    assert jobs.running and jobs.done == 1
    assert _time_to_stop(jobs.cancel, lambda: jobs.running) < 1.0
    assert ended.is_set() and jobs.outcome == "cancelled"
    assert list(tmp_path.iterdir()) == []  # the .partial file is removed


@pytest.mark.slow
def test_a_page_choice_stops_within_a_second_of_cancel() -> None:
    scene = LONG_CHOICE()
    choice = PageChoice()
    text = Text()
    outcome: list[BaseException | object] = []

    def work() -> None:
        try:
            outcome.append(choice.run(scene, 0.01, text))
        except BaseException as error:  # noqa: BLE001 - checked below
            outcome.append(error)

    thread = threading.Thread(target=work, daemon=True)
    thread.start()
    assert _wait(lambda: "reference" in text.content, 600), text.lines[-3:]
    time.sleep(0.5)  # inside a run
    assert choice.running
    assert _time_to_stop(choice.cancel, thread.is_alive) < 1.0
    assert type(outcome[0]).__name__ == "ChoiceCancelled" and not choice.running
    assert any("left" in line for line in text.lines)


def test_a_page_choice_of_a_1e12_s_scene_ends_at_once_and_says_nothing_met() -> None:
    scene = dataclasses.replace(sim.scenes.build("grid"), duration=1e12)
    text = Text()
    started = time.monotonic()
    choice = PageChoice().run(scene, 0.01, text)
    assert time.monotonic() - started < 60
    assert choice.answer is None  # every affordable step blows up over 1e12 s


def test_a_page_choice_planned_over_an_hour_says_how_long_and_stops_at_once() -> None:
    progress = PageProgress(Text())
    progress.planned(1800.0)
    with pytest.raises(ValueError, match=r"planned to take about 5\.5 h of computing"):
        progress.planned(18000.0)


def test_the_estimate_counts_down_and_says_when_a_run_is_over_its_plan(monkeypatch) -> None:
    clock = [100.0]
    monkeypatch.setattr(time, "monotonic", lambda: clock[0])
    progress = PageProgress(Text())
    progress.planned(10.0)
    progress.finished(2.0, "verify rk4")
    clock[0] += 3.0  # 3 s into a run planned with the rest
    assert "about 5 s left" in progress.line()
    clock[0] += 20.0
    assert "15 s over the planned time" in progress.line()


@pytest.mark.slow
def test_sigterm_during_a_movie_ends_with_one_line_and_no_partial_file(tmp_path) -> None:
    output = tmp_path / "grid.mp4"
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "movie", "grid", "--duration", "3000", "-o",
         str(output), "--quiet"], cwd=tmp_path, env=environment, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    try:
        assert _wait(lambda: any(tmp_path.iterdir()) or process.poll() is not None, 600)
        time.sleep(2.0)  # frames are being made
        assert process.poll() is None, process.communicate()
        started = time.monotonic()
        process.send_signal(signal.SIGTERM)
        stdout, stderr = process.communicate(timeout=60)
        stopped = time.monotonic() - started
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 128 + signal.SIGTERM, stderr
    assert stderr.strip().splitlines() == [f"movie stopped by SIGTERM: nothing written to {output}"]
    assert list(tmp_path.iterdir()) == []
    assert stopped < 30.0


@pytest.mark.slow
def test_the_pages_measure_button_cancels_its_measurement_within_a_second(tmp_path) -> None:
    from app.web.app import WebApp
    from tests.helpers import free_port
    from tests.test_web_safety import press

    scene = LONG_CHOICE()
    app = WebApp(sim.Simulation(scene), port=free_port(), scenes_dir=tmp_path / "scenes",
                 recordings_dir=tmp_path / "recordings")
    app.start()
    try:
        study = app.panel.study
        pressing = threading.Thread(target=press, args=(study.button,), daemon=True)
        pressing.start()
        assert _wait(lambda: "reference" in study.text.content, 600), study.text.content
        assert study.button.label == "Cancel the measurement"
        time.sleep(0.5)
        assert _time_to_stop(lambda: press(study.button) or True, pressing.is_alive) < 1.0
        assert "measurement cancelled" in study.text.content
        assert study.button.label == "Measure on this scene"
    finally:
        app.stop()
