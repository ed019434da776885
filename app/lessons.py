"""The lessons: each one a scene to open, what to look at, three questions for students and the
answers the product measures, with the command that measures each.

``LESSONS`` is the one list.  The page's *Lessons* folder (``app.web.folders.lessons``) opens a
lesson's preset with its settings and shows its text, ``oscillators lessons`` prints them, and
``docs/lessons/KEY.md`` is each lesson's ``markdown`` (``python -m app.lessons docs/lessons``
writes them; a test keeps them equal).
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any


@dataclasses.dataclass(frozen=True)
class Answer:
    """What a question's answer is, in words with the measured figures, and the command that
    measures it (its output has those figures)."""

    text: str
    command: str


@dataclasses.dataclass(frozen=True)
class Lesson:
    """One lesson.  ``preset`` and ``settings`` (scene parameters): what the page opens, with the
    preset's own integrator and dt; ``start``: the one command that starts it from a terminal;
    ``look``: what to look at; ``questions`` and their ``answers``, three each."""

    key: str
    title: str
    preset: str
    start: str
    look: str
    questions: tuple[str, str, str]
    answers: tuple[Answer, Answer, Answer]
    settings: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def markdown(self) -> str:
        """The lesson as a page of ``docs/lessons``."""
        lines = [f"# Lesson: {self.title}", "", "## Start it", "",
                 f"On the page: the *Lessons* folder, *{self.title}*, *Open*. In a terminal:",
                 "", "```sh", self.start, "```", "", "## What to look at", "", self.look, "",
                 "## Questions for students", ""]
        lines += [f"{number}. {question}" for number, question in enumerate(self.questions, 1)]
        lines += ["", "## Answers, as the product measures them", ""]
        for number, answer in enumerate(self.answers, 1):
            lines += [f"{number}. {answer.text}", "", "   ```sh", f"   {answer.command}",
                      "   ```", ""]
        return "\n".join(lines).rstrip() + "\n"

    def page_text(self) -> str:
        """What the page's Lessons folder shows: what to look at and the questions (the answers
        are for the teacher, in ``docs/lessons``)."""
        questions = "\n".join(f"{number}. {question}"
                              for number, question in enumerate(self.questions, 1))
        return f"**{self.title}**\n\n{self.look}\n\n**Questions**\n\n{questions}"


LESSONS: tuple[Lesson, ...] = (
    Lesson(
        "normal-modes", "The paper's small lattices and normal modes", "square",
        "oscillators serve square --set linear=true",
        "One of the four particles starts displaced. Press Play and watch its energy pass to the "
        "others and come back (the Energy folder), and which normal modes hold it (the Modes "
        "folder). Then open the chain (Scene, Preset chain, Build scene) and watch its middle "
        "particle.",
        ("The displaced particle of the square swings at more than one frequency. At which, and "
         "why more than one?",
         "The middle particle of the five-particle chain swings at three of the chain's five "
         "normal-mode frequencies. Which two are missing, and why?",
         "Over 20 s, how much of its energy does the simulation lose or gain?"),
        (Answer("At 0.9413 Hz and 1.629 Hz, beside the normal modes at 0.9416 Hz and 1.631 Hz: "
                "the displacement is a sum of two normal modes, and the particle moves with "
                "both.", "oscillators run square --set linear=true --probe 0,0"),
         Answer("It swings at 0.4868, 1.331 and 1.819 Hz: modes 1, 3 and 5 (0.4874, 1.332, "
                "1.819 Hz). Modes 2 and 4 have a node at the middle particle, so it never "
                "moves with them.", "oscillators run chain --set linear=true --probe 2,0"),
         Answer("The energy-balance error is -0.004 % of the energy in play over 20 s (RK4 at "
                "dt = 0.01 s).", "oscillators run chain --set linear=true --probe 2,0")),
        settings={"linear": True}),
    Lesson(
        "continuum-limit", "Waves and the continuum limit", "interference",
        "oscillators continuum string",
        "The flagship: 682 x 383 particles. Two particles of opposite edges are displaced; their "
        "waves spread as circles, as on a membrane, although every particle only feels four "
        "springs. In the terminal command, the same string is built of 4 to 1024 particles and "
        "compared with the wave equation.",
        ("How does the difference between the lattice and the wave equation fall as the string "
         "is made of more particles?",
         "How fast do long waves travel on a chain of springs k = 35 N/m, masses 1 kg, 1 m "
         "apart, and how does that compare with a √(k/m)?",
         "Do short waves travel as fast as long ones?"),
        (Answer("As a², a the spacing: the error is 0.98 with 4 particles, 0.34 with 16, 0.034 "
                "with 64, 0.0022 with 256 and 0.00014 with 1024 (measured order 2.00).",
                "oscillators continuum string"),
         Answer("5.9144 m/s, measured by following a pulse; a √(k/m) = 5.9161 m/s "
                "(-0.028 %).", "oscillators dispersion"),
         Answer("No: at q a / pi = 0.75 the lattice's waves have omega = 10.936 rad/s where the "
                "continuum would have 13.951 rad/s. The lattice's dispersion relation "
                "ω = 2 √(k/m) |sin(q a / 2)| bends below the straight line, so short "
                "waves lag.", "oscillators dispersion"))),
    Lesson(
        "interference-and-slits", "Interference and slits", "double-slit",
        "oscillators serve double-slit",
        "A plane wave on a pre-tensioned membrane (the particles move out of the plane) meets a "
        "barrier with two slits. Watch the waves spread from each slit and the bright and dark "
        "fringes build up on the screen line (the Screen folder plots the time-averaged "
        "intensity).",
        ("Where on the screen, 119 m beyond the barrier, are the first bright fringes beside the "
         "central one?",
         "Is the wavelength the wave speed over the frequency, c / f?",
         "How does the screen change with one slit instead of two?"),
        (Answer("At +-53.4 m measured, against +-54.8 m from the fringe condition d q_y = 2 pi "
                "with the lattice's own wavelength.", "oscillators slits double-slit"),
         Answer("No: the lattice's dispersion makes it 7.803 m where c / f gives 8.017 m.",
                "oscillators slits double-slit"),
         Answer("One broad bright band in the middle, its first dark minima at +-55.4 m "
                "measured (+-54.8 m from the slit's width and the lattice's wavelength): no "
                "fringes of two slits.", "oscillators slits single-slit"))),
    Lesson(
        "dispersion-and-packets", "Dispersion, packets and the group speed", "grid",
        "oscillators run grid --set nx=160 --set ny=160 --set linear=true --packet 0.5,0",
        "Open the Dispersion folder: it draws the lattice's bands omega(q). Pick a wave on them "
        "and press Launch this wave: a packet of that one wave vector crosses the lattice, and "
        "the folder measures its group and phase speeds beside the theory.",
        ("A packet of wave vector q = 0.5 rad/m: does its envelope travel at the speed of its "
         "crests?",
         "How close are the measured speeds to the dispersion relation's d omega / d q and "
         "omega / q?",
         "On the ionic chain (masses 4 kg and 1 kg alternating), which frequencies cannot "
         "travel at all?"),
        (Answer("No: the envelope (group speed) moves at 5.7315 m/s and the crests (phase speed) "
                "at 5.8546 m/s.", "oscillators run grid --set nx=160 --set ny=160 --set "
                "linear=true --packet 0.5,0"),
         Answer("Group speed 5.7315 m/s against 5.7322 m/s from theory (-0.011 %); phase speed "
                "5.8546 m/s, equal to theory to the digits printed.",
                "oscillators run grid --set nx=160 --set ny=160 --set linear=true --packet 0.5,0"),
         Answer("Between 4.184 and 8.367 rad/s measured, the band gap √(2k/M) = 4.183 to "
                "√(2k/m) = 8.367 rad/s of theory.", "oscillators dispersion")),
        settings={"nx": 160, "ny": 160, "linear": True}),
    Lesson(
        "resonance-and-band-gap", "Resonance and the band gap", "resonance",
        "oscillators serve resonance",
        "A chain of 12 particles with light drag is driven at its end at the frequency of its "
        "third normal mode: a standing wave with three antinodes builds up. In the Sources "
        "folder change the drive's frequency and watch the amplitude fall away from the mode.",
        ("At which drive frequency does the chain answer most?",
         "How well does a sum over the normal modes predict the steady amplitude?",
         "An ionic chain (4 kg and 1 kg) driven inside its band gap: what does the driven "
         "particle do?"),
        (Answer("At 0.6598 Hz the steady amplitude is 0.090 m, the largest of the four "
                "frequencies tried, next to mode 3 at 0.6678 Hz.",
                "oscillators response resonance --set linear=true --frequencies "
                "1.7528,1.6754,1.5578,0.6598"),
         Answer("To 0.3 % at the resonance (0.0900 m measured, 0.0903 m from the modes) and to "
                "a few per cent at 1.56 and 1.68 Hz.",
                "oscillators response resonance --set linear=true --frequencies "
                "1.7528,1.6754,1.5578,0.6598"),
         Answer("It moves against the force (lag 180 degrees) with an amplitude that falls "
                "across the gap: 0.0144 m at 0.8 Hz, 0.0059 m at 1.0 Hz, 0.0031 m at 1.2 Hz, "
                "against 0.0239 m at 0.4 Hz in the acoustic band. No wave carries the drive's "
                "energy away.", "oscillators response bandgap --frequencies 0.4,0.8,1.0,1.2,1.5 "
                "--periods 20"))),
    Lesson(
        "hearing-the-lattice", "Hearing the lattice", "chain",
        "oscillators run chain --set linear=true --probe 2,0 --sound chain.wav",
        "Select the middle particle of the chain (Selection folder), add it as a probe (Probes "
        "folder) and press Hear the probes: its motion is played sped up into hearing. The "
        "spectrum beside it marks the normal modes.",
        ("What pitch does the lowest mode sound at, and by how much is the motion sped up?",
         "How many notes do you hear, and which modes are they?",
         "How much simulated time does 3 s of sound need?"),
        (Answer("x500: the lowest mode's 0.4874 Hz sounds as 243.7 Hz.",
                "oscillators run chain --set linear=true --probe 2,0 --sound chain.wav"),
         Answer("Three: modes 1, 3 and 5 at 0.4874, 1.332 and 1.819 Hz (243.7, 666 and 909.5 Hz "
                "heard), a chord; modes 2 and 4 are silent at the middle particle.",
                "oscillators run chain --set linear=true --probe 2,0 --sound chain.wav"),
         Answer("1500 s: 3 s of sound at x500.",
                "oscillators run chain --set linear=true --probe 2,0 --sound chain.wav")),
        settings={"linear": True}),
    Lesson(
        "fpu-recurrence", "The Fermi-Pasta-Ulam-Tsingou recurrence", "fput",
        "oscillators run fput --modes 4",
        "A chain of 32 particles whose springs pull with k (s + 0.25 s²), with all the energy "
        "in its lowest mode. The Modes folder plots the shares of modes 1 to 4 over time: "
        "mode 1 gives its energy to the others and, unlike what Fermi expected, takes it back. "
        "The page starts at a speed that shows the first return within about a minute.",
        ("How low does mode 1's share fall, and when?",
         "When does the energy come back into mode 1, and how much of it?",
         "Is the return a trick of the integrator: how well is the energy kept?"),
        (Answer("To 0.085 at 104.0 periods of mode 1 (a period is 66.02 s).",
                "oscillators run fput --modes 4"),
         Answer("98.1 % of it is back in mode 1 at 153.4 periods (t = 10,128 s), as Fermi, "
                "Pasta, Ulam and Tsingou saw in 1955.", "oscillators run fput --modes 4"),
         Answer("The energy-balance error over the run is below 0.001 % of the energy in play "
                "(-3.2e-07 J of 0.0747 J; Verlet at dt = 0.05 s).",
                "oscillators run fput --modes 4"))),
    Lesson(
        "speed-and-accuracy", "Speed against accuracy", "grid",
        "oscillators accuracy grid --set linear=true",
        "Every integrator trades speed for accuracy. The Accuracy folder shows the energy-"
        "balance error of the run live, and Choose for me sets the cheapest integrator and dt "
        "that meet a tolerance. Switch the Method (Integrator folder) and the time step and "
        "watch the error.",
        ("How does each integrator's error fall when the time step is halved?",
         "Which integrator and step reach 1 % error over the grid's 20 s at the least cost?",
         "What does the same accuracy cost with RK4?"),
        (Answer("By 2^order: measured orders Heun 2.00, Verlet 2.00, Ralston 3.02, RK4 3.99, "
                "Yoshida 4.00, Blanes-Moan 4.24 (theory 2, 2, 3, 4, 4, 4).",
                "oscillators accuracy grid --set linear=true"),
         Answer("Blanes-Moan at dt = 0.125 s: 160 steps, field error 0.6 %, energy error "
                "0.01 %, verified by a run.", "oscillators choose grid --tolerance 0.01"),
         Answer("RK4 needs dt = 0.0116 s, 1720 steps (field error 0.015 %), about ten times "
                "the steps.", "oscillators choose grid --tolerance 0.01")),
        settings={"linear": True}),
)
"""Every lesson, in the order a course would take them."""


def lesson(key: str) -> Lesson:
    """The lesson named ``key`` (ValueError naming the lessons when there is none)."""
    for candidate in LESSONS:
        if candidate.key == key:
            return candidate
    raise ValueError(f"no lesson {key!r}; the lessons: {', '.join(x.key for x in LESSONS)}")


def write_pages(folder: Path) -> list[Path]:
    """Write every lesson's ``markdown`` to ``folder/KEY.md``; returns the paths."""
    paths = []
    for each in LESSONS:
        path = folder / f"{each.key}.md"
        path.write_text(each.markdown(), encoding="utf-8")
        paths.append(path)
    return paths


if __name__ == "__main__":  # python -m app.lessons docs/lessons
    for written in write_pages(Path(sys.argv[1])):
        print(written)
