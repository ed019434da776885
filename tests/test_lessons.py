"""The lessons: their pages in docs/lessons are theirs, each opens a scene that builds, every
command they give is one the CLI takes, and the page's Lessons folder opens a lesson and shows its
text, refusing a title it does not list."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

import sim
from app.cli import build_parser
from app.lessons import LESSONS, lesson
from tests.test_web_safety import press, send, settle

DOCS = Path(__file__).resolve().parent.parent / "docs" / "lessons"


def test_the_docs_pages_are_the_lessons():
    assert sorted(path.name for path in DOCS.glob("*.md")) == sorted(
        f"{each.key}.md" for each in LESSONS)
    for each in LESSONS:
        assert (DOCS / f"{each.key}.md").read_text(encoding="utf-8") == each.markdown(), (
            f"docs/lessons/{each.key}.md is out of date: python -m app.lessons docs/lessons")


@pytest.mark.parametrize("each", LESSONS, ids=[each.key for each in LESSONS])
def test_a_lesson_builds_and_its_commands_are_the_clis(each):
    scene = sim.scenes.build(each.preset, **each.settings)
    assert scene.model.n_particles > 0
    assert len(each.questions) == len(each.answers) == 3
    parser = build_parser()
    for command in (each.start, *(answer.command for answer in each.answers)):
        words = shlex.split(command)
        assert words[0] == "oscillators", command
        parser.parse_args(words[1:])  # exits (SystemExit) on anything the CLI does not take


def test_oscillators_lessons_lists_and_prints_them(capsys):
    from app.cli import main

    assert main(["lessons"]) == 0
    listing = capsys.readouterr().out
    assert all(each.start in listing and each.title in listing for each in LESSONS)
    assert main(["lessons", "fpu-recurrence"]) == 0
    assert capsys.readouterr().out == lesson("fpu-recurrence").markdown()
    assert main(["lessons", "no-such-lesson"]) == 2
    assert "fpu-recurrence" in capsys.readouterr().err


def test_the_lessons_folder_opens_a_lesson_and_refuses_other_titles(web_app):
    folder = web_app.panel.folders["lessons"]
    fpu = lesson("fpu-recurrence")
    send(folder.lesson, fpu.title)
    assert fpu.questions[1] in folder.text.content
    press(folder.open_button)
    settle(web_app)
    simulation = web_app.runner.simulation
    assert simulation.scene.name == "fput" and simulation.model.nx == 32
    assert web_app.scene_source == "lesson fpu-recurrence"
    assert "opened" in folder.message.content

    send(folder.lesson, "../../etc/passwd")
    assert "refused" in folder.message.content
    assert folder.lesson.value == fpu.title  # the menu shows the lesson in use again
    folder.lesson.value = "../../etc/passwd"  # a press that comes with a title not listed
    press(folder.open_button)
    settle(web_app)
    assert "could not open the lesson" in folder.message.content
    assert web_app.runner.simulation is simulation  # nothing else was opened
