"""The Lessons folder in a real (headless) Chromium: a teacher opens the folder, picks the FPU
lesson in its menu and presses Open lesson; the page runs the fput chain and shows the lesson's
questions, at a laptop's size and at a phone's; and the "In words" folder describes the new
lattice in a live region (aria-live) that screen readers read."""

from __future__ import annotations

import os

import pytest

from app.lessons import lesson
from tests.helpers import open_page, wait_for

pytestmark = pytest.mark.browser


@pytest.mark.parametrize("size", [(1366, 768), pytest.param((414, 896), marks=pytest.mark.slow)])
def test_a_lesson_opens_from_the_lessons_folder(web_app, browser, size):
    fpu = lesson("fpu-recurrence")
    page = browser.new_page(viewport={"width": size[0], "height": size[1]})
    open_page(page, web_app.url)
    if size[0] < 700:  # a phone's panel starts folded (app.web.phone): one tap opens it
        play = page.get_by_role("button", name="Play")
        play.wait_for(state="hidden", timeout=30_000)
        page.get_by_text("Connected").click()
        play.wait_for(state="visible", timeout=30_000)
    page.get_by_text("Lessons", exact=True).first.click()  # open the folder
    page.get_by_label("Lesson", exact=True).click()
    page.get_by_role("option", name=fpu.title, exact=True).click()
    page.get_by_text(fpu.questions[1]).wait_for(timeout=20_000)
    page.get_by_role("button", name="Open lesson").click()
    assert wait_for(lambda: web_app.runner.simulation.scene.name == "fput", timeout=60)
    page.get_by_text(f"opened {fpu.title}").wait_for(timeout=20_000)
    shots = os.environ.get("OSCILLATORS_SCREENSHOTS")
    if shots:  # for a person to look at: OSCILLATORS_SCREENSHOTS=/tmp/shots pytest ...
        page.screenshot(path=os.path.join(shots, f"lessons-{size[0]}x{size[1]}.png"))
    # the lattice in words, in a live region a screen reader reads out (the "In words" folder)
    region = page.locator('[aria-live="polite"]', has_text="particles")
    region.first.wait_for(timeout=20_000)
    assert "32 × 1 particles" in region.first.inner_text()
    assert web_app.gate.refused == 0
