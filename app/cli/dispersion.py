"""``oscillators dispersion``: the continuum limit, the wave speed and the dispersion relation
measured on long chains (``app.study.dispersion``), as a table or JSON and an optional picture;
with a SCENE, that scene's band structure and its integrator's numerical dispersion
(``app.study.bands``).
"""

from __future__ import annotations

import argparse
import math

from app.cli.arguments import IntegratorChoices, bounded_int, positive_float, scene_from_arguments
from app.cli.commands import summary
from app.cli.limits import check_plan
from app.cli.study_output import (
    add_output_arguments,
    advance,
    check_plot_path,
    emit,
    progress_bar,
    write_picture,
)
from sim.integrators.registry import most_accurate

DISPERSION_PARTICLES = (4, 6000)
"""Range of --particles: the wave-speed chain has 3x as many, at most ``sim.model.MAX_SIDE``."""

DISPERSION_SAMPLES = 2000
"""Samples of each spectrum (200 s every 0.1 s), to estimate the run time."""

DESCRIPTION = """\
The continuum limit.  A long chain (one row, unstressed, linearised springs, fixed ends) is given
a random displacement along the chain, integrated, and the space-time spectrum of its displacement
is taken (sine transform in space, windowed FFT in time).  The frequency measured for each
wavenumber q is compared with the discrete relation omega = 2 sqrt(k/m) |sin(q a / 2)| and the
continuum line omega = c q, c = a sqrt(k/m).  The wave speed is also measured directly by tracking
the front of a wide pulse.  For the ionic chain (masses M and m alternating) the acoustic and
optical branches and the gap between sqrt(2k/M) and sqrt(2k/m) are measured.

With --diagonal-stiffness K2 > 0 the lattice is an elastic solid instead (nearest springs k,
diagonal springs K2; isotropic at K2 = k/2): the P and S wave speeds are measured on the
elastic-solid scene and compared with sqrt((lambda + 2 mu)/rho) and sqrt(mu/rho), and both
in-plane branches along an axis are measured against the dispersion relation.

With a SCENE (a preset name or a scene file) nothing is run: the scene's band structure is
computed (omega(q) of every branch along Gamma-X-M-Gamma: x, y, z for nearest springs, S and P
with diagonal springs, acoustic and optical branches of the ionic checkerboard), with the
continuum lines omega = c |q| and what the scene's integrator at its dt makes of each frequency;
--plot draws them.
"""

EPILOG = """\
examples:
  oscillators dispersion --plot docs/images/dispersion.png
  oscillators dispersion --particles 2000 --json
  oscillators dispersion --diagonal-stiffness 17.5
  oscillators dispersion ionic --plot ionic-bands.png
  oscillators dispersion elastic-solid --integrator rk4 --dt 0.05 --plot bands.png
"""


def _stiffness_or_zero(text: str) -> float:
    """argparse type: 0 or a positive finite stiffness (N/m)."""
    return 0.0 if text.strip() in ("0", "0.0") else positive_float(text)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``dispersion`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "dispersion", help=summary("dispersion"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("scene", nargs="?", default=None,
                        help="preset name or .toml/.zip scene file: draw its band structure "
                        "instead of running the chain study")
    parser.add_argument("--integrator", choices=IntegratorChoices(),
                        help="with a SCENE: the integrator whose numerical dispersion is drawn "
                        "(default: the scene's)")
    parser.add_argument("--dt", type=positive_float,
                        help="with a SCENE: its time step in s (default: the scene's)")
    parser.add_argument("--set", dest="overrides", action="append", metavar="KEY=VALUE",
                        help="with a SCENE: override a scene parameter (as in `oscillators run`)")
    parser.add_argument("--particles", type=bounded_int(*DISPERSION_PARTICLES), default=400,
                        help="particles in the chain (default 400; from {} to {})".format(
                            *DISPERSION_PARTICLES))
    parser.add_argument("--stiffness", type=positive_float, default=35.0,
                        help="k in N/m (default 35)")
    parser.add_argument("--mass", type=positive_float, default=1.0, help="m in kg (default 1)")
    parser.add_argument("--heavy", type=positive_float, default=4.0,
                        help="heavy mass M of the ionic chain in kg (default 4)")
    parser.add_argument("--diagonal-stiffness", type=_stiffness_or_zero, default=0.0,
                        help="k2 of diagonal springs in N/m (default 0: chains); > 0 measures "
                        "the elastic solid's P and S waves and its two branches")
    add_output_arguments(parser)
    parser.set_defaults(handler=command_dispersion)


def command_dispersion(arguments: argparse.Namespace) -> int:
    from app.study import dispersion

    check_plot_path(arguments)
    if arguments.scene is not None:
        return _scene_bands(arguments)
    for option in ("integrator", "dt", "overrides"):
        if getattr(arguments, option):
            raise ValueError(f"--{option.replace('overrides', 'set')} applies to a SCENE's bands; "
                             "the chain study runs the most accurate integrator")
    if arguments.diagonal_stiffness > 0:
        return _elastic_solid(arguments)
    lightest = min(arguments.mass, arguments.heavy)
    steps = DISPERSION_SAMPLES * math.ceil(2 * math.sqrt(arguments.stiffness / lightest))
    particles = arguments.particles
    integrator = most_accurate()  # the chains are run with the most accurate integrator
    check_plan([(steps, particles, integrator), (steps, particles, integrator),
                (steps, max(3 * particles, 1200), integrator)], "dispersion")
    with progress_bar(None, arguments.quiet) as bar:
        study = dispersion.dispersion_study(
            particles=arguments.particles, stiffness=arguments.stiffness, mass=arguments.mass,
            heavy=arguments.heavy, progress=advance(bar),
        )
    if arguments.plot:
        write_picture(arguments.plot, dispersion.plot_dispersion, study)
    emit(arguments, study.as_dict(), dispersion.format_report(study))
    return 0


def _scene_bands(arguments: argparse.Namespace) -> int:
    """The band structure of the named scene (``app.study.bands``), nothing run."""
    import sim
    from app.study import bands

    if arguments.diagonal_stiffness > 0:
        raise ValueError("--diagonal-stiffness belongs to the chain study; give the scene's "
                         "diagonal springs with --set diagonal_stiffness=K2")
    scene = scene_from_arguments(arguments)
    simulation = sim.Simulation(scene, integrator=arguments.integrator, dt=arguments.dt)
    picture = bands.band_picture(simulation)
    if arguments.plot:
        write_picture(arguments.plot, bands.plot_bands, picture)
    emit(arguments, picture.as_dict(), bands.format_report(picture))
    return 0


def _elastic_solid(arguments: argparse.Namespace) -> int:
    """The elastic solid's P and S speeds and its two branches (``app.study.elastic``)."""
    import sim
    from app.study import elastic

    if arguments.plot:
        raise ValueError("--plot draws the chains' study; the elastic solid is reported as text")
    scene = sim.scenes.build("elastic-solid", stiffness=arguments.stiffness, mass=arguments.mass,
                             diagonal_stiffness=arguments.diagonal_stiffness)
    rows = arguments.particles
    with progress_bar(None, arguments.quiet) as bar:
        speeds = elastic.measure_speeds(scene, progress=advance(bar))
        branches = elastic.measure_branches(rows, arguments.stiffness,
                                            arguments.diagonal_stiffness, arguments.mass,
                                            progress=advance(bar))
    data = dict(speeds, branches=elastic.branch_checkpoints(branches))
    emit(arguments, data, elastic.format_report(speeds, branches))
    return 0
