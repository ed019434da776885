"""``oscillators stability``: the largest stable time step of every integrator, found by
bisection on real runs of extreme cases (or of one scene), next to the theoretical limit
(``app.study.stability``).
"""

from __future__ import annotations

import argparse

from app.cli.arguments import bounded_int, positive_float, scene_from_arguments
from app.cli.cluster import add_cluster_arguments, executor_from
from app.cli.commands import summary
from app.cli.study_output import (
    add_output_arguments,
    advance,
    check_plot_path,
    emit,
    progress_bar,
    write_picture,
)
from sim.integrators.registry import ALL_INTEGRATORS

STABILITY_STEPS = (10, 100_000)
"""Smallest and largest --steps of a stability trial."""

STABILITY_PRECISION = (1e-6, 1.0)
"""Range of --precision: below 1e-6 the bisection would stall at float resolution."""

DESCRIPTION = """\
The largest stable time step of each integrator, found by bisection on real runs, next to the
theoretical limit (Simulation.stable_dt(): velocity Verlet omega_max dt = 2, RK4 2 sqrt 2; explicit
Euler and Heun are unstable at every dt without damping and stable only with enough damping).

A run is unstable when it raises sim.BlowUpError, its energy runs away (x100), or its energy grows
at every checkpoint (the slow, steady growth of Euler and Heun).  A tiny random perturbation
(1e-6 spacing) excites every mode, so the fastest mode is always present.  The cases are the
extremes: very stiff springs, mass ratios up to 1e6 (one heavy particle among light
ones and the reverse), near-zero pre-tension, strong and over-damping, strong gravity, large
drags (particles crossing their neighbours, through the zero-length spring singularity; a NaN
that is not reported as a BlowUpError is flagged), 1x1, 1x1000 and 682x383 lattices.
"""

EPILOG = """\
examples:
  oscillators stability                               # every case (682x383 included: minutes)
  oscillators stability --cases grid stiff heavy-among-light --plot stability.png
  oscillators stability grid --set damping=5          # one scene of your own
  oscillators stability --list                        # the cases and what they contain
  oscillators stability catenary --whole-run --integrators verlet   # the limit a run meets
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``stability`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "stability", help=summary("stability"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "scene", nargs="?", default=None,
        help="preset or .toml file to study alone (default: the built-in extreme cases)",
    )
    parser.add_argument(
        "--set", dest="overrides", action="append", metavar="KEY=VALUE",
        help="override a parameter of SCENE (as in `oscillators run`); repeatable",
    )
    parser.add_argument("--cases", nargs="+", metavar="CASE",
                        help="only these built-in cases (see --list)")
    parser.add_argument("--list", action="store_true", help="list the built-in cases and exit")
    parser.add_argument("--integrators", nargs="+", metavar="NAME", default=None,
                        choices=ALL_INTEGRATORS,
                        help="integrators to study (default: every compiled one, each on the "
                        "cases it applies to)")
    parser.add_argument(
        "--steps", type=bounded_int(*STABILITY_STEPS), default=400,
        help="steps per trial run (default 400; fewer on lattices above 100,000 particles)",
    )
    parser.add_argument(
        "--precision", type=_precision, default=0.005,
        help="relative width at which the bisection stops (default 0.005; from 1e-6 to 1)",
    )
    parser.add_argument(
        "--whole-run", action="store_true",
        help="judge each dt by SCENE's own run over its whole duration, unperturbed, as "
        "`oscillators run SCENE --dt DT` does (unstable: the run stops, exit 3): the limit a user "
        "meets, which large motion (a sag, big displacements) can put below the theory's",
    )
    add_output_arguments(parser)
    add_cluster_arguments(parser)
    parser.set_defaults(handler=command_stability)


def _precision(text: str) -> float:
    """argparse type of --precision: within STABILITY_PRECISION (0 would bisect forever)."""
    value = positive_float(text)
    low, high = STABILITY_PRECISION
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be from {low:g} to {high:g}, got {text!r}")
    return value


def command_stability(arguments: argparse.Namespace) -> int:
    from app.study import stability

    if arguments.list:
        for case in stability.default_cases():
            print(f"{case.name:22s} {case.description}")
        return 0
    check_plot_path(arguments)
    if arguments.whole_run and arguments.scene is None:
        raise ValueError("--whole-run needs a SCENE (the built-in cases have no run of their own)")
    if arguments.scene is not None:
        scene = scene_from_arguments(arguments)
        cases = [stability.Case(scene.name, "the scene given on the command line", scene)]
    else:
        cases = stability.default_cases(arguments.cases)
    integrators = arguments.integrators or None
    with executor_from(arguments) as executor, progress_bar(None, arguments.quiet) as bar:
        study = stability.stability_study(
            cases, integrators=integrators, steps=arguments.steps,
            precision=arguments.precision, progress=advance(bar), executor=executor,
            whole_run=arguments.whole_run,
        )
    if arguments.plot:
        write_picture(arguments.plot, stability.plot_stability, study)
    emit(arguments, study.as_dict(), stability.format_report(study))
    return 0
