"""``oscillators response``: the resonance curve of a driven scene, the steady amplitude and lag
against drive frequency (``app.study.response``), as a table or JSON and a picture saved by
default; the planned runs are checked against the limits of ``app.cli.limits`` first.
"""

from __future__ import annotations

import argparse
import math

from app.cli.arguments import add_scene_arguments, bounded_int, scene_from_arguments
from app.cli.commands import summary
from app.cli.limits import check_plan
from app.cli.study_output import (
    add_output_arguments,
    advance,
    default_plot,
    emit,
    progress_bar,
    save_picture,
    scene_picture,
)

DESCRIPTION = """\
Resonance curve of a driven scene.  For each drive frequency the scene is run from rest with its
driver's frequency replaced, through the driver's start and ramp and a settle time in which the
transient dies out; then the probed particle's displacement along the drive is fitted over a few
drive periods by least squares with a cos(wt) + b sin(wt) + c.  The table gives the steady
amplitude sqrt(a^2 + b^2), the lag behind the drive (90 degrees at an isolated resonance) and
the settle time used; the picture shows the amplitude against frequency with the lattice's
normal modes as labelled vertical lines.  For a force driver the modes also predict the steady
response of the linearised lattice (sum over modes of F0 c_j / (omega_j^2 - omega^2 + i beta_j
omega)): it is drawn as a curve under the measured points and listed in the column "modes" (not
with absorbing walls, whose damping the modes do not diagonalise).  For one particle it is the
analytic F0 / (m sqrt((omega_0^2 - omega^2)^2 + (beta omega)^2)).

Settle time: by default estimated for each frequency from the damping of the normal modes the
driver excites (drag, dashpots and the sponge), long enough for their transient to fall to
1/1000 of the steady amplitude.  An undamped lattice never settles and is refused: add drag
(--set drag=0.1) or absorbing walls.  A point whose amplitude differs by more than 1 % between
the two halves of its fit window is marked "not settled".

Default frequencies: 40 evenly spaced from half the lowest mode's frequency to the highest, plus
each mode's frequency and its two half-power points, so that narrow peaks are not missed.

The scene must have a driver: presets resonance and bandgap have one; any other scene gets one
with --set driver=column=0,row=0,direction=x,amplitude=0.02,kind=force,ramp=5 (its frequency is
replaced).  The resonance preset has full springs: at its amplitudes (about 0.1 m) the springs to
the walls above and below stiffen the longitudinal motion (a hardening, cubic force), so its peaks
lean to higher frequencies than the modes; --set linear=true gives the linearised lattice, whose
peaks sit on the lines.
"""

EPILOG = """\
examples:
  oscillators response                                  # the resonance preset, 76 frequencies
  oscillators response resonance --set linear=true --plot docs/images/response_resonance.png
  oscillators response resonance --frequencies 0.6:0.75:30 --probe 6,0
  oscillators response single --set drag=0.5 --set linear=true \\
      --set driver=column=0,row=0,amplitude=0.01,kind=force --frequencies 0.3:2:40
  oscillators response bandgap --frequencies 0.2:1.6:57 --settle 300 --periods 20

Python: from app.study.response import response_curve  (returns the data; .as_dict() for JSON)
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``response`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "response", help=summary("response"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser, default_scene="resonance")
    parser.add_argument(
        "--frequencies", type=_frequencies, metavar="F0:F1:N",
        help="N evenly spaced drive frequencies from F0 to F1 Hz, or a list F,F,F (default: "
        "around the normal modes, with each mode's peak resolved)",
    )
    parser.add_argument(
        "--probe", type=_column_row, metavar="I,J",
        help="measure at the particle in column I, row J, from 0 (default: the driven one)",
    )
    parser.add_argument(
        "--settle", type=_seconds, metavar="SECONDS",
        help="seconds run after the driver's ramp before measuring (default: estimated for "
        "each frequency from the damping)",
    )
    parser.add_argument(
        "--periods", type=bounded_int(2, 1000), default=4,
        help="drive periods in the fit window (default 4)",
    )
    add_output_arguments(parser, picture="SCENE-response.png")
    parser.set_defaults(handler=command_response)


def _frequencies(text: str):
    """argparse type of --frequencies: F0:F1:N or F,F,F (Hz)."""
    from app.study.response import parse_frequencies

    try:
        return parse_frequencies(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def _column_row(text: str) -> tuple[int, int]:
    """argparse type of --probe: two whole numbers I,J >= 0."""
    try:
        column, row = (int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"takes column,row (two whole numbers from 0), got {text!r}") from None
    if column < 0 or row < 0:
        raise argparse.ArgumentTypeError(f"column and row count from 0, got {text!r}")
    return column, row


def _seconds(text: str) -> float:
    """argparse type of --settle: a finite number of seconds >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds >= 0, got {text!r}")
    return value


def command_response(arguments: argparse.Namespace) -> int:
    from app.study import response, response_report

    scene = scene_from_arguments(arguments)
    default_plot(arguments, scene_picture(scene, "response"))
    dt = arguments.dt or scene.dt
    checked = response.plan(scene, arguments.frequencies, arguments.probe, arguments.settle, dt)
    steps = response.planned_steps(scene.model.driver, checked.frequencies, checked.settles,
                                   arguments.periods, dt)
    integrator = arguments.integrator or scene.integrator
    check_plan([(count, scene.model.n_particles, integrator) for count in steps], "response")
    with progress_bar(len(checked.frequencies), arguments.quiet) as bar:
        curve = response.response_curve(
            scene, checked.frequencies, arguments.probe, arguments.settle, arguments.periods,
            integrator=arguments.integrator, dt=arguments.dt, precision=arguments.precision,
            threads=arguments.threads, progress=advance(bar), prepared=checked,
        )
    data = curve.as_dict()
    save_picture(arguments, data, response_report.plot_response, curve)
    emit(arguments, data, response_report.format_report(curve))
    return 0
