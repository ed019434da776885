"""``oscillators reflection``: how much of a wave the absorbing walls send back, against
wavelength, for several sponge widths with a fixed-wall control (``app.study.reflection``), as a
table or JSON and a picture saved by default.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

from app.cli.arguments import bounded_int, positive_float
from app.cli.commands import summary
from app.cli.limits import check_plan
from app.cli.study_output import add_output_arguments, advance, default_plot, emit, progress_bar, save_picture

DESCRIPTION = """\
How much of a wave the absorbing walls (boundary=absorbing) send back, against wavelength.  A
long linearised chain (k = 35 N/m, m = 1 kg, a = 1 m) of 2 (distance + width) particles has a
sponge `width` particles deep at each end.  A Gaussian wave packet (envelope width = one
wavelength, at rest) in the middle splits into two halves that run into the layers at the group
velocity c_g = a sqrt(k/m) cos(q a / 2).  At t = 2 distance / c_g whatever the layers sent back has
returned to the middle: the reflected fraction is the energy (kinetic + springs) left between
the layers then, divided by the starting energy.  RK4, dt = 0.05 s.

The fixed-wall column is the control: the same chain without a sponge reflects everything, less
what RK4 damps numerically (mostly the shortest waves).

The layer is a perfectly matched layer of the lattice: it relaxes the springs' stretch and the
forces along the wall's normal at the rate strength sqrt(k/m) d^2 (d: depth into the layer, 0 at
its inner edge, 1 at the wall), integrated exactly, so a wave of any wavelength enters it
without reflecting.  Without --angle both incidences are measured: along the chain (0 degrees)
and at 45 degrees (out-of-plane waves on a strip half a wave wide).
"""

EPILOG = """\
examples:
  oscillators reflection                                  # the default layer and one 30 deep, 0 and 45 deg
  oscillators reflection --plot docs/images/reflection.png
  oscillators reflection --widths 30 --wavelengths 10,40,80 --distance 300 --json
  oscillators reflection --widths 30 --strength 2.0      # a stronger layer
  oscillators reflection --widths 30 --angle 45           # waves arriving at 45 degrees only

Python: from app.study.reflection import reflection_study
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``reflection`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "reflection", help=summary("reflection"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--widths", type=_whole_numbers, default=None, metavar="W,W,...",
        help="layer widths in particles (default: the default layer's width, "
        "sim.model.boundaries.DEFAULT_LAYER_WIDTH, and 30)",
    )
    parser.add_argument(
        "--wavelengths", type=_numbers, default=None, metavar="L,L,...",
        help="wavelengths in spacings a, from 2.5 (default 5,10,20,30,40,60,80)",
    )
    parser.add_argument(
        "--strength", type=positive_float, default=None, metavar="S",
        help="sponge_strength: peak rate in units of sqrt(k/m) (default: the default "
             "layer's, sim.model.boundaries.DEFAULT_LAYER_STRENGTH)",
    )
    parser.add_argument(
        "--distance", type=bounded_int(10, 20_000), default=300,
        help="particles from the packet's centre to each layer (default 300; at least 3 "
        "wavelengths)",
    )
    parser.add_argument("--no-control", action="store_true",
                        help="skip the fixed-wall control runs")
    parser.add_argument(
        "--angle", type=float, choices=(0.0, 45.0), default=None,
        help="incidence in degrees from the walls' normal: 0 (the chain) or 45 (out-of-plane "
        "waves on a strip half a wave wide; slower); default both",
    )
    add_output_arguments(parser, picture="reflection.png")
    parser.set_defaults(handler=command_reflection)


def _comma_separated(convert: Callable[[str], float], accepted: Callable[[float], bool],
                     kind: str, example: str, rule: str) -> Callable[[str], list]:
    """argparse type factory: ``kind`` (converted by ``convert``) separated by commas, each
    ``accepted``; ``rule`` says which are, in the message of a refused list."""

    def parse(text: str) -> list:
        try:
            values = [convert(part) for part in text.split(",") if part.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"takes {kind} separated by commas, e.g. {example}, got {text!r}") from None
        if not values or not all(accepted(value) for value in values):
            raise argparse.ArgumentTypeError(f"takes {rule}, got {text!r}")
        return values

    return parse


_numbers = _comma_separated(float, lambda value: math.isfinite(value) and value > 0,
                            "numbers", "5,10,20", "positive numbers")
"""argparse type of --wavelengths: positive numbers separated by commas."""

_whole_numbers = _comma_separated(int, lambda value: value >= 1,
                                  "whole numbers", "20,30,40", "whole numbers >= 1")
"""argparse type of --widths: whole numbers >= 1 separated by commas."""


def command_reflection(arguments: argparse.Namespace) -> int:
    from app.study import reflection
    from sim.model.boundaries import DEFAULT_LAYER_STRENGTH

    default_plot(arguments, "reflection.png")
    widths = arguments.widths or list(reflection.DEFAULT_WIDTHS)
    wavelengths = arguments.wavelengths or list(reflection.DEFAULT_WAVELENGTHS)
    strength = arguments.strength or DEFAULT_LAYER_STRENGTH
    control = not arguments.no_control
    angles = [0.0, 45.0] if arguments.angle is None else [arguments.angle]
    reflection.check_plan(widths, wavelengths, arguments.distance)
    check_plan([run for angle in angles for run in reflection.planned_runs(
        widths, wavelengths, arguments.distance, control, angle)], "reflection")
    runs = len(angles) * len(wavelengths) * (len(widths) + int(control))
    with progress_bar(runs, arguments.quiet) as bar:
        studies = [reflection.reflection_study(
            widths, wavelengths, strength, arguments.distance, control, progress=advance(bar),
            angle=angle) for angle in angles]
    data = (studies[0].as_dict() if len(studies) == 1
            else dict(angles=[study.as_dict() for study in studies]))
    save_picture(arguments, data, reflection.plot_reflection, studies)
    text = "\n\n".join(reflection.format_report(study) for study in studies)
    worst = max(float(study.fractions.max()) for study in studies)
    emit(arguments, data, f"{text}\n\nworst reflection measured: {100 * worst:.3g} %")
    return 0
