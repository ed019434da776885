"""The commands of ``oscillators``, their one-line summaries, and what every parser shares.

This module imports nothing of ``sim`` or of the commands: ``oscillators --help`` lists the
commands from ``COMMANDS`` alone, and a command's module (``app.cli.<name>``, with its
``register(subparsers)``) is imported only when that command is run or asked for its help, so
the command line answers at once.
"""

from __future__ import annotations

import argparse
from typing import NamedTuple, NoReturn


class Command(NamedTuple):
    """A command: its name (its module is ``app.cli.<name>``) and its line in ``--help``."""

    name: str
    summary: str


COMMANDS = (
    Command("scenes", "list the preset scenes"),
    Command("lessons", "the lessons: what to start, look at, ask and measure"),
    Command("run", "run a scene headless and print an energy summary"),
    Command("bench", "steps per second of each integrator against plain numpy and C"),
    Command("serve", "the web app: watch and play with a lattice in the browser"),
    Command("record", "run a scene headless and write a rerun .rrd recording"),
    Command("choose", "the cheapest integrator and dt that meet a tolerance (verified)"),
    Command("accuracy", "error against wall time of every integrator (work-precision)"),
    Command("stability", "largest stable dt of every integrator, measured and theoretical"),
    Command("dispersion", "wave speed and dispersion relation measured on long chains"),
    Command("continuum", "one body at several N against the exact continuum solution"),
    Command("response", "resonance curve of a driven scene: steady amplitude against frequency"),
    Command("reflection", "reflection of the absorbing walls against wavelength"),
    Command("slits", "slit experiment: intensity screen against the fringe theory"),
    Command("movie", "render a run or a recording to an MP4, WebM or GIF movie"),
    Command("warm", "compile the presets' kernels ahead (so the page never waits for them)"),
)
"""The commands, in the order ``oscillators --help`` lists them."""

_SUMMARIES = {command.name: command.summary for command in COMMANDS}


def summary(name: str) -> str:
    """The one-line summary of the command ``name`` (what its parser's ``help`` says)."""
    return _SUMMARIES[name]


EPILOG = """examples:
  oscillators scenes
  oscillators run chain --integrator verlet --dt 0.01 --steps 2000
  oscillators run grid --set nx=40 --set ny=30 --duration 20
  oscillators run catenary --duration 30            # watch it settle under gravity
  oscillators run resonance --probe 0,0             # driven at its 3rd mode: the probe finds it
  oscillators run grid --set nx=400 --set ny=1 --packet 0.5,0   # a wave packet's group speed
  oscillators run chain --set driver=column=0,frequency=0.6,amplitude=0.02,kind=force
  oscillators run grid --set nx=120 --set ny=1 --set boundary=absorbing --set sponge_width=20
  oscillators serve grid                            # the web app on http://127.0.0.1:8080
  oscillators bench --seconds 1                     # steps per second of every integrator

units are SI: metres, kilograms, seconds; stiffness in N/m, damping and drag in N s/m.

a driver (--set driver=...) takes column, row, direction (x, y, z), amplitude A (m), frequency
f (Hz), kind (force: A k sin 2 pi f t; displacement: A sin 2 pi f t), start, ramp (s) and
phase (rad); --set sources=... takes several of them separated by ";" (row=all drives a whole
column: a plane wave); --set barriers="column=45,openings=89-91 109-111" pins a column (or
row=j) except its openings (";" between barriers, docs/instruments.md);
boundary=absorbing adds a sponge sponge_width particles deep (sponge_sides=left,right,... or
auto) that takes waves out instead of reflecting them (docs/instruments.md).
"""


class OneLineErrorParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are one line on stderr (exit code 2), not the usage
    block followed by the message."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")
