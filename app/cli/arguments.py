"""The command line's shared argument parsing: the parser class whose errors are one line,
argparse types for numbers, the scene arguments every scene command takes (SCENE, --integrator,
--dt, --precision, --threads, --set key=value) and the Scene / Simulation they name.

Units are SI throughout: seconds for --dt and --duration, the scene's own units for --set.
"""

from __future__ import annotations

import argparse
import math
import shlex
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from app.cli import argparse_adapter
from app.cli.commands import EPILOG, OneLineErrorParser  # noqa: F401 - the commands' shared parts
from sim.integrators.registry import ALL_INTEGRATORS
from sim.model import parameters
from sim.storage.files import check_target

"""The examples under ``oscillators --help`` and ``oscillators run --help``."""


def ascii_float(text: str) -> float:
    """``float(text)`` for text in ASCII only: Python's ``float`` also reads other scripts'
    digits ("３" as 3), which a command line should say rather than guess (ValueError)."""
    if not text.isascii():
        raise ValueError(f"{text!r} is not written in ASCII digits (0-9, '.', 'e', '-')")
    return float(text)


def ascii_int(text: str) -> int:
    """``int(text)`` for text in ASCII only (``ascii_float``)."""
    if not text.isascii():
        raise ValueError(f"{text!r} is not written in ASCII digits (0-9)")
    return int(text)


def _number(text: str) -> float:
    try:
        return ascii_float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in ASCII digits, got {text!r}") from None


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0 (a time step, a duration, a scale)."""
    value = _number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive, finite number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1 (a count of steps, frames, particles)."""
    return bounded_int(1, None)(text)


def bounded_int(smallest: int, largest: int | None) -> Callable[[str], int]:
    """argparse type factory: a whole number in [smallest, largest] (largest None: no bound)."""

    def parse(text: str) -> int:
        try:
            value = ascii_int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a whole number in ASCII digits, got {text!r}") from None
        if value < smallest or (largest is not None and value > largest):
            span = f"at least {smallest}" if largest is None else f"from {smallest} to {largest}"
            raise argparse.ArgumentTypeError(f"must be {span}, got {text!r}")
        return value

    return parse


def parse_overrides(pairs: Sequence[str] | None) -> dict[str, Any]:
    """``["nx=40", "gravity=9.81", "linear=true", "gravity=0,-9.81"]`` -> keyword arguments."""
    overrides: dict[str, Any] = {}
    for pair in pairs or []:
        if "=" not in pair:
            raise ValueError(f"--set takes key=value, got {pair!r}")
        key, text = (part.strip() for part in pair.split("=", 1))
        if key in ("driver", "sources", "barriers"):  # key=value lists, ";" between (sim.model.forcing)
            overrides[key] = None if text.lower() in ("none", "off", "") else text
        elif key in ("boundary", "sponge_sides"):
            overrides[key] = text
        else:
            overrides[key] = _parse_value(text)
    return overrides


def _parse_value(text: str) -> Any:
    lowered = text.lower()
    if lowered in ("true", "yes", "on"):
        return True
    if lowered in ("false", "no", "off"):
        return False
    if not text.isascii():
        raise ValueError(f"--set: {text!r} is not written in ASCII (numbers take the digits 0-9)")
    if "," in text:
        return tuple(float(part) for part in text.split(","))
    try:
        number = float(text)
    except ValueError:
        return text
    return int(number) if number.is_integer() and "." not in text and "e" not in lowered else number


class IntegratorChoices:
    """The registered integrators' names (``sim.integrators.ALL_INTEGRATORS``), read when
    argparse checks or lists them, so the command line never keeps its own list."""

    def __contains__(self, name: object) -> bool:
        return name in ALL_INTEGRATORS

    def __iter__(self) -> Iterator[str]:
        return iter(tuple(ALL_INTEGRATORS))

    def __len__(self) -> int:
        return len(ALL_INTEGRATORS)


def add_scene_arguments(parser: argparse.ArgumentParser, default_scene: str | None = None) -> None:
    """SCENE (preset name or scene file), --integrator, --dt, --precision, --threads,
    --set key=value."""
    if default_scene is None:
        parser.add_argument(
            "scene", help="preset name (see `oscillators scenes`) or a .toml or .zip scene file"
        )
    else:
        parser.add_argument(
            "scene", nargs="?", default=default_scene,
            help=f"preset name or a .toml or .zip scene file (default: {default_scene})",
        )
    parser.add_argument(
        "--integrator", choices=IntegratorChoices(),
        help="time integrator (default: the scene's)",
    )
    parser.add_argument("--dt", type=positive_float,
                        help="time step in seconds (default: the scene's)")
    parser.add_argument(
        "--precision", choices=("float64", "float32"),
        help="floating-point precision of the state and the kernels (default: the scene's, "
        "float64); float32 is faster, energies are still summed in float64",
    )
    parser.add_argument(
        "--threads", type=positive_int, default=1,
        help="threads the compiled sweeps run on, as row blocks (default: 1)",
    )
    parser.add_argument(
        "--set", dest="overrides", action="append", metavar="KEY=VALUE",
        help="override a scene parameter: " + ", ".join(
            row.name + (f" ({row.unit})" if row.bounds else "") for row in parameters.rows())
        + "; gravity takes g or gx,gy[,gz]; repeatable",
    )


def add_length_arguments(parser: argparse.ArgumentParser, steps_help: str) -> None:
    """--steps N or --duration SECONDS (one of them): how long a command runs the scene."""
    length = parser.add_mutually_exclusive_group()
    length.add_argument("--steps", type=positive_int, help=steps_help)
    length.add_argument("--duration", type=positive_float,
                        help="simulated seconds instead of --steps")


def scene_from_arguments(arguments: argparse.Namespace):
    """Build the Scene named by the parsed arguments (preset + overrides, or a file)."""
    from sim.scenes import building as scenes
    from sim.scenes import scene_files

    overrides = parse_overrides(arguments.overrides)
    if arguments.scene.endswith((".toml", ".zip")):
        scene = scene_files.load_file(arguments.scene)
        if overrides:
            raise ValueError("--set applies to presets; edit the scene file instead")
    else:
        scene = scenes.build(arguments.scene, **overrides)
    return scene


def simulation_from_arguments(arguments: argparse.Namespace):
    """The Simulation of the scene, integrator, dt, precision and threads the arguments name."""
    from sim import Simulation

    scene = scene_from_arguments(arguments)
    return Simulation(
        scene, integrator=arguments.integrator, dt=arguments.dt,
        precision=getattr(arguments, "precision", None), threads=getattr(arguments, "threads", 1),
    )


def check_output_file(output: Path, force: bool, suffix: str) -> None:
    """Refuse a directory, an existing file unless ``force``, and a folder that does not exist
    (checked before anything runs, see ``sim.storage.files.check_target``); ``suffix`` (".rrd", ".mp4")
    is the ending the message suggests."""
    check_target(output, force)
    if output.is_dir():  # check_target says so too; kept for the suffix in the message
        raise ValueError(f"{output} is a directory; give a file name ending in {suffix}")


def command_from_arguments(parser: Any, arguments: Any, program: str = "oscillators") -> str:
    """The command line that reproduces parsed ``arguments`` of a subcommand's ``parser``: its
    positionals and every option whose value differs from its default (whatever process parsed
    them: a shell, a test, the web app)."""
    words = [program, parser.prog.split()[-1]]
    options: list[str] = []
    for action in argparse_adapter.actions(parser):
        if argparse_adapter.is_help(action) or action.dest in ("help", "handler"):
            continue
        value = getattr(arguments, action.dest, None)
        if not action.option_strings:
            words.append(str(value))
            continue
        if value is None or value == action.default or value is False:
            continue
        flag = action.option_strings[-1]
        if value is True:
            options.append(flag)
        elif isinstance(value, list):
            for item in value:
                options += [flag, str(item)]
        else:
            options += [flag, str(value)]
    return shlex.join(words + options)
