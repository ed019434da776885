"""A class in a real (headless) Chromium: the teacher page (opened with the teacher link) changes
the run and the student page (opened with the student link: both pages run on this machine,
whose plain pages are teachers) sees it; the student page shows the shared controls disabled, and
what it sends anyway changes nothing."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator

import pytest

import sim
from app.web.app import WebApp
from tests.helpers import VIEWPORT, free_port, wait_for
from tests.helpers import open_page as open_app_page

SCREENSHOT = os.environ.get("CLASS_SCREENSHOT")
"""If set, the student page's screenshot is saved there (to look at it)."""

# two pages on one server take over a minute; the roles' server side runs by default
# (test_web_roles.py)
pytestmark = [pytest.mark.browser, pytest.mark.slow]


@pytest.fixture
def class_app(tmp_path) -> Iterator[WebApp]:
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings",
                 class_mode=True)
    app.start()
    yield app
    app.stop()


def open_page(browser, address: str):
    page = browser.new_page(viewport=VIEWPORT)
    page.set_default_timeout(120_000)  # two software-rendered pages on a busy machine
    open_app_page(page, address)
    assert wait_for(lambda: page.locator("canvas").count() > 0, timeout=60)
    return page


def test_the_student_sees_the_teachers_change_and_cannot_make_one(class_app, browser):  # noqa: F811
    app = class_app
    teacher = open_page(browser, app.roles.teacher_link(app.url))
    assert wait_for(lambda: len(app.server.get_clients()) == 1)
    student = open_page(browser, app.roles.student_link(app.url))
    assert wait_for(lambda: len(app.server.get_clients()) == 2)
    assert len(app.roles.teachers) == 1 and len(app.roles.students) == 1

    # the student's copies of the shared controls are disabled, the teacher's are not
    student_play = student.get_by_role("button", name="Play")
    assert wait_for(student_play.is_disabled, timeout=60)
    assert wait_for(student.get_by_label("Gravity", exact=True).is_disabled, timeout=60)
    assert teacher.get_by_role("button", name="Play").is_enabled()
    assert teacher.get_by_label("Gravity", exact=True).is_enabled()

    teacher.get_by_label("Gravity", exact=True).check()
    assert wait_for(lambda: app.runner.simulation.model.has_gravity)
    assert wait_for(lambda: student.get_by_label("Gravity", exact=True).is_checked(), timeout=60)

    student_play.click(force=True)  # a disabled button: the page sends nothing
    time.sleep(0.5)
    assert not app.runner.playing and app.runner.simulation.step_count == 0

    teacher.get_by_role("button", name="Play").click()
    assert wait_for(lambda: app.runner.simulation.step_count > 20)
    student.get_by_text("Student view").wait_for(timeout=60_000)
    assert wait_for(student.get_by_role("button", name="Pause").is_disabled)  # after the change too
    if SCREENSHOT:
        time.sleep(1.0)
        student.screenshot(path=SCREENSHOT)
