"""The ``oscillators`` command: one entry point with subcommands.

    oscillators scenes                      list the presets and their parameters
    oscillators run SCENE --steps N         headless run with progress and an energy summary
    oscillators bench                       kernel speed against plain numpy (interference scene)
    oscillators serve [SCENE]               the web app (viser)
    oscillators record SCENE                a rerun .rrd recording
    oscillators choose SCENE --tolerance T  the cheapest integrator and step meeting T, verified
    oscillators accuracy / stability        the speed/accuracy study and stability map
    oscillators response / reflection       a driven scene's resonance curve; the absorbing
                                            walls' reflection against wavelength
    oscillators movie SCENE -o FILE         an MP4, WebM or GIF movie of a run or a recording
    oscillators continuum [string|membrane] one body at several N against the wave equation
    oscillators slits [SCENE]               a slit scene's intensity screen against theory
    oscillators warm [PRESET ...]           compile the presets' kernels ahead, with progress

Parameters of any scene can be overridden with ``--set key=value`` (repeatable), e.g.
``--set nx=40 --set gravity=9.81 --set damping=0.5``; a driver with
``--set driver=column=0,frequency=0.6,kind=force`` and absorbing walls with
``--set boundary=absorbing``.

Each command is one module of this package with ``register(subparsers)``, which adds its parser
and sets its ``handler``; ``app.cli.commands.COMMANDS`` lists them with their one line, in the
order ``--help`` shows them, so a new command is one module and one entry there.  A command's
module is imported only when it runs or shows its help.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from app.cli.commands import COMMANDS, EPILOG, OneLineErrorParser


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``oscillators`` parser: every command of ``COMMANDS`` with its full parser
    (``command`` None), or only ``command``'s full parser and the others by their one line,
    which is all ``--help`` and that command need (their modules are not imported)."""
    parser = OneLineErrorParser(
        prog="oscillators",
        description="Coupled oscillators: watch waves emerge from a lattice of masses and springs.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for entry in COMMANDS:
        if command is None or entry.name == command:
            importlib.import_module(f"app.cli.{entry.name}").register(subparsers)
        else:
            subparsers.add_parser(entry.name, help=entry.summary)
    return parser


def _command_named(argv: Sequence[str]) -> str:
    """The command ``argv`` names (its first word that is not an option), "" if none."""
    names = {entry.name for entry in COMMANDS}
    for word in argv:
        if not word.startswith("-"):
            return word if word in names else ""
    return ""


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default: the process's), run the command; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(_command_named(argv))
    arguments = parser.parse_args(argv)
    if not getattr(arguments, "handler", None):
        parser.print_help()
        return 0
    from sim import ModelError, SceneError
    from sim.model.schema import printable
    from sim.runtime.optimisation import use_numba_default

    if getattr(arguments, "reads_cached_kernels", False):
        # its kernels are compiled in a child process (or by `warm`) and read from numba's
        # cache, at numba's default level (sim.runtime.optimisation)
        use_numba_default()
    try:
        return int(arguments.handler(arguments) or 0)
    except (ModelError, SceneError, ValueError) as error:
        print(printable(f"error: {error}", keep=""), file=sys.stderr)
        return 2
    except OSError as error:  # unwritable output, missing directory, disk full
        print(f"error: {error.strerror or error}: {error.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return 2
    except MemoryError:
        print("error: not enough memory for this lattice; try a smaller nx/ny", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
