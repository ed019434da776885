"""The page's "Lessons" folder: pick a lesson (``app.lessons``), open its scene with its settings,
and read what to look at and the questions for students.

*Open* builds the lesson's preset with its settings and runs it instead of the current scene, as
the Scene folder's *Build scene* does (the page's own pacing, the other folders shown again); the
text below the button is the lesson's (``Lesson.page_text``), with the terminal command that
starts it and the page of ``docs/lessons`` that holds the answers.  A lesson is chosen by its
title, one of the menu's; nothing a page sends names a file.
"""

from __future__ import annotations

import threading

import viser

import sim
from app.lessons import LESSONS, Lesson
from app.web.host import Folder, PanelHost
from app.web.inputs import InputRefused, as_html, choice, from_user, ok_html
from app.web.scene_files import MAX_PAGE_PARTICLES
from app.web.widgets import ERRORS, say

TITLES = {lesson.title: lesson for lesson in LESSONS}
"""The menu's entries: each lesson by its title."""


class LessonsFolder(Folder):
    name = "lessons"

    def __init__(self, host: PanelHost) -> None:
        self.host = host
        self._open_lock = threading.Lock()
        gui = host.server.gui
        first = LESSONS[0]
        self._shown = first
        """The lesson the menu and text show (a refused title puts it back)."""
        with gui.add_folder("Lessons", expand_by_default=False):
            self.lesson = gui.add_dropdown("Lesson", list(TITLES), initial_value=first.title)
            self.open_button = gui.add_button(
                "Open lesson", icon=viser.Icon.SCHOOL,
                hint="run this lesson's scene with its settings instead of the current one",
            )
            self.message = gui.add_html("")
            self.text = gui.add_markdown(self._text(first))

        @self.lesson.on_update
        @from_user
        def _(_: viser.GuiEvent) -> None:
            try:
                chosen = TITLES[choice(self.lesson.value, "lesson", list(TITLES))]
            except InputRefused as error:
                self.lesson.value = self._shown.title  # the menu shows the lesson in use
                say(self.message, error)
                return
            self._shown = chosen
            self.text.content = self._text(chosen)
            say(self.message, None)

        @self.open_button.on_click
        @from_user
        def _(_: viser.GuiEvent) -> None:
            with self._open_lock:
                self._open()

    @staticmethod
    def _text(lesson: Lesson) -> str:
        return (f"{lesson.page_text()}\n\nIn a terminal: `{lesson.start}`  \n"
                f"Answers: `docs/lessons/{lesson.key}.md`")

    def _open(self) -> None:
        try:
            chosen = TITLES[choice(self.lesson.value, "lesson", list(TITLES))]
            self._shown = chosen
            self.message.content = as_html(f"opening {chosen.preset}…")
            scene = sim.scenes.build(chosen.preset, **chosen.settings)
            if scene.model.n_particles > MAX_PAGE_PARTICLES:
                raise InputRefused(f"{chosen.preset} has {scene.model.n_particles:,} particles; "
                                   f"the page builds up to {MAX_PAGE_PARTICLES:,}")
            self.host.replace_scene(scene, source=f"lesson {chosen.key}")
        except ERRORS as error:
            self.lesson.value = self._shown.title
            say(self.message, error, "could not open the lesson")
            return
        self.text.content = self._text(chosen)
        self.message.content = ok_html(f"opened {chosen.title}")
