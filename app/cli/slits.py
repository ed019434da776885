"""``oscillators slits``: a slit experiment measured on its intensity screen, the fringes set
beside the far-field theory with the lattice's own wavelength (``app.study.slits``), as a table
or JSON and a picture of the screen saved by default.
"""

from __future__ import annotations

import argparse

from app.cli.arguments import add_scene_arguments, positive_float, positive_int, scene_from_arguments
from app.cli.commands import summary
from app.cli.study_output import (
    add_output_arguments,
    default_plot,
    emit,
    save_picture,
    scene_picture,
)

DESCRIPTION = """\
Run a scene with a slit barrier (presets double-slit and single-slit, or any scene with a
column barrier with one or two openings and a source) and record its intensity screen: the
time-averaged squared displacement <u^2> along one column, averaged over the last 4 whole
periods of the drive.  Beside it, the far-field theory: two slits' maxima at d sin(theta) = m
lambda, one slit's minima at w sin(theta) = m lambda (w: the gap between the pinned particles
either side), theta from the slits' centre, with the lattice's own waves at the driving
frequency (from its dispersion relation: d q_y = 2 pi m, q the wave vector whose ray points at
theta, which leans off the ray on a lattice; the continuum wavelength c / f is printed too).
The measured maxima lie a few per cent inside the lines: each slit's wave weakens away from
the axis, which pulls the bright fringes toward it (docs/instruments.md, "Sources and slits").
"""

EPILOG = """\
examples:
  oscillators slits double-slit                     # table + pictures/double-slit-screen.png
  oscillators slits single-slit --screen 150 --json
  oscillators slits double-slit --set sources="column=22,row=all,direction=z,frequency=0.4,amplitude=0.01"

Python: from app.study.slits import measure
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``slits`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "slits", help=summary("slits"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser, default_scene="double-slit")
    parser.add_argument("--screen", type=positive_int, metavar="COLUMN",
                        help="column of the screen (default: 5 inside the right wall's layer)")
    parser.add_argument("--duration", type=positive_float,
                        help="simulated seconds (default: the scene's)")
    add_output_arguments(parser, picture="SCENE-screen.png")
    parser.set_defaults(handler=command_slits)


def command_slits(arguments: argparse.Namespace) -> int:
    from app.study import slits
    from sim.scenes.ripple_tank import SlitError

    scene = scene_from_arguments(arguments)
    default_plot(arguments, scene_picture(scene, "screen"))
    if arguments.screen is not None and arguments.screen >= scene.model.nx:
        raise ValueError(f"--screen {arguments.screen} is outside the lattice's "
                         f"{scene.model.nx} columns")
    try:
        measurement = slits.measure(scene, column=arguments.screen, duration=arguments.duration,
                                    integrator=arguments.integrator, dt=arguments.dt)
    except SlitError as error:
        raise ValueError(str(error)) from None
    data = measurement.as_dict()
    save_picture(arguments, data, slits.plot, measurement)
    emit(arguments, data, slits.format_report(measurement))
    return 0
