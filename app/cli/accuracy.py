"""``oscillators accuracy``: speed against accuracy of every integrator on a scene (the
work-precision study of ``app.study.accuracy``), as a table or JSON and a picture saved by
default; the planned runs are checked against the limits of ``app.cli.limits`` first.
"""

from __future__ import annotations

import argparse

from app.cli.arguments import add_scene_arguments, positive_float, scene_from_arguments
from app.cli.choose import format_choice
from app.cli.cluster import add_cluster_arguments, executor_from
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
from app.study.accuracy_reference import REFINEMENT
from sim.integrators.registry import ALL_INTEGRATORS, most_accurate, names
from sim.runtime.errors import MEASURES

LARGE_LATTICE = 20_000
"""Above this many particles the sweep runs in float64 only unless --precisions says otherwise."""

DESCRIPTION = """\
Speed against accuracy.  Runs each integrator over a range of time steps on a scene, from its
initial state to time T, and measures against a reference solution:

  error      largest particle position error at T / size of the initial disturbance
  energy     relative drift of the energy balance (kinetic + potential + dissipated)
  phase      phase error (rad) of the dominant normal mode
  wall time  of the stepping alone (compilation excluded; short runs repeated, fastest kept)

Reference: the exact normal-mode solution when the springs are linearised (--set linear=true,
lattices up to ~1500 particles); otherwise RK4 at (smallest dt)/4, whose own error is estimated
by Richardson extrapolation against (smallest dt)/2 and printed.

dt/limit is dt over the integrator's stability limit (Verlet: omega_max dt = 2, RK4: 2 sqrt 2;
explicit Euler and Heun have none without damping: their energy grows at every dt).  The measured
convergence order is the slope of log(error) against log(dt).  For each integrator the dt that
should just meet the tolerance is also predicted from its measured order, run, and marked with *.
Without --dts, the smallest default steps are left out on a large lattice to keep the sweep's
estimated cost within 30 s.

The recommendation is the answer of `oscillators choose SCENE --tolerance TOL` (the same code):
the cheapest integrator and dt whose errors over the scene's whole duration meet the tolerance,
verified by running it: both the field error (the largest distance from a reference over the
run's sample times, relative to the largest reference field) and the energy error (the largest
energy-balance error over the same times), or the one --error names (the other still shown).
"""

EPILOG = """\
examples:
  oscillators accuracy grid --set linear=true           # exact reference, default steps
  oscillators accuracy grid --until 5 --tolerance 1e-4 --plot docs/images/work_precision.png
  oscillators accuracy chain --integrators verlet rk4 --dts 0.02 0.01 0.005 --json
  oscillators accuracy grid --set nx=40 --set ny=30     # bigger lattice: wall time matters more

Python: from app.study.accuracy import accuracy_study  (returns the data; .as_dict() for JSON)
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``accuracy`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "accuracy", help=summary("accuracy"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser, default_scene="grid")
    parser.add_argument(
        "--integrators", nargs="+", metavar="NAME", default=None, choices=ALL_INTEGRATORS,
        help="integrators to compare (default: every compiled one that applies to the scene)",
    )
    parser.add_argument(
        "--dts", nargs="+", type=positive_float, metavar="DT",
        help="time steps in seconds (default: 0.9 of the RK4 limit down to 1/400 of it)",
    )
    parser.add_argument(
        "--until", type=positive_float, metavar="T",
        help="time (s) at which the error is measured (default: 5 periods of the dominant mode)",
    )
    parser.add_argument(
        "--tolerance", type=_fraction, default=1e-3,
        help="tolerance of the recommendation (as for `oscillators choose`) and the sweep's "
        "target relative position error (default 1e-3)",
    )
    parser.add_argument("--error", choices=MEASURES, default=None,
                        help="the recommendation checks this error alone (as for `oscillators "
                        "choose`; default: both)")
    parser.add_argument("--no-refine", action="store_true",
                        help="do not run the dt predicted to just meet the tolerance")
    parser.add_argument(
        "--precisions", nargs="+", choices=("float64", "float32"), default=None,
        metavar="PRECISION",
        help="precisions the compiled integrators run in (default: float64 float32, float64 "
        f"alone above {LARGE_LATTICE:,} particles; the recommendation uses float64)",
    )
    add_output_arguments(parser, picture="SCENE-work-precision.png")
    add_cluster_arguments(parser)
    parser.set_defaults(handler=command_accuracy, reads_cached_kernels=True)


def _fraction(text: str) -> float:
    """argparse type of --tolerance: a number in (0, 1]."""
    value = positive_float(text)
    if value > 1:
        raise argparse.ArgumentTypeError(f"must be a relative error in (0, 1], got {text!r}")
    return value


def command_accuracy(arguments: argparse.Namespace) -> int:
    from app.study.accuracy import accuracy_study, default_until
    from app.study.accuracy_report import format_report, plot_work_precision

    scene = scene_from_arguments(arguments)
    if arguments.json and not arguments.plot:
        arguments.no_plot = True  # machine output: a file only when --plot names one
    default_plot(arguments, scene_picture(scene, "work-precision"))
    if arguments.integrator and not arguments.integrators:
        arguments.integrators = [arguments.integrator]
    integrators = arguments.integrators or list(names(scene.model, kernel_only=True))
    dts = arguments.dts or ([arguments.dt] if arguments.dt else None)
    if dts:
        until = arguments.until or default_until(scene)
        particles = scene.model.n_particles
        runs = [(until / dt, particles, name) for name in integrators for dt in dts]
        # the numerical reference, at (smallest dt) / REFINEMENT
        runs.append((REFINEMENT * until / min(dts), particles, most_accurate(scene.model)))
        check_plan(runs, "accuracy")
    precisions = arguments.precisions or (
        ("float64",) if scene.model.n_particles > LARGE_LATTICE else ("float64", "float32"))
    planned = 2 * len(integrators) * (len(dts) if dts else 8) + 2 + len(integrators)
    with executor_from(arguments) as executor:
        with progress_bar(planned, arguments.quiet) as bar:
            study = accuracy_study(
                scene, integrators=integrators, dts=dts, until=arguments.until,
                tolerance=arguments.tolerance, refine=not arguments.no_refine,
                progress=advance(bar), precisions=precisions,
                executor=executor,
            )
            bar.total = bar.n
        choice = recommendation(scene, arguments.tolerance, integrators, executor,
                                arguments.quiet, arguments.error)
    data = study.as_dict()
    data["recommendation"] = choice.as_dict()
    answer = choice.answer
    verified = (f"recommended, verified over the scene's {choice.duration:g} s: "
                f"{answer.describe()}; {choice.measure} error <= {choice.tolerance:g}"
                if answer is not None else
                f"nothing met {choice.tolerance:g} ({choice.measure} error) over the scene's "
                f"{choice.duration:g} s")

    def plot(study, path: str) -> None:
        plot_work_precision(study, path, recommendation=verified)

    save_picture(arguments, data, plot, study)
    emit(arguments, data, format_report(study, "recommendation " + format_choice(choice)))
    return 0


def recommendation(scene, tolerance: float, integrators: list[str], executor, quiet: bool,
                   measure: str | None = None):
    """``app.study.choose.choose`` on the scene (the compiled integrators among ``integrators``),
    its runs through the sweep's executor, with the bar of `oscillators choose`."""
    from app.cli.choose import Bar
    from app.study.choose import choose
    from sim.integrators.registry import describe

    compiled = [name for name in integrators if describe(name).kernel] or None
    bar = Bar(quiet)
    try:
        return choose(scene, tolerance, measure=measure, integrators=compiled, progress=bar,
                      map_runs=lambda function, tasks: executor.map(function, tasks))
    finally:
        bar.close()
