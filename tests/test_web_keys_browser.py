"""Keyboard-only use of the Run folder in a real (headless) Chromium: Space plays and pauses, N
steps once, Shift+Up and Shift+Down change the speed, Shift+R resets; the folder lists the keys."""

from __future__ import annotations

import pytest

from app.web.folders.run import KEYS_TEXT
from tests.helpers import open_page, wait_for

pytestmark = pytest.mark.browser


@pytest.mark.slow  # 22 s: a page and five key presses, each awaited; the lessons test is the default one
def test_play_step_speed_and_reset_from_the_keyboard(web_app, browser):
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    open_page(page, web_app.url)
    page.get_by_text(KEYS_TEXT).wait_for(timeout=20_000)
    runner, run = web_app.runner, web_app.panel.folders["run"]

    def step() -> int:
        return runner.post(lambda simulation: simulation.step_count).result(timeout=10)

    page.keyboard.press("Space")
    assert wait_for(lambda: runner.playing, timeout=20)
    page.keyboard.press("Space")
    assert wait_for(lambda: not runner.playing, timeout=20)
    before = step()
    page.keyboard.press("n")
    assert wait_for(lambda: step() > before, timeout=20)
    speed = run.speed.value
    page.keyboard.press("Shift+ArrowUp")
    assert wait_for(lambda: run.speed.value != speed, timeout=20)
    page.keyboard.press("Shift+ArrowDown")
    assert wait_for(lambda: run.speed.value == speed, timeout=20)
    page.keyboard.press("Shift+R")
    assert wait_for(lambda: step() == 0, timeout=20)
    assert web_app.gate.refused == 0
