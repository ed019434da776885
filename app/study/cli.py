"""Subcommands of the study: ``oscillators accuracy``, ``stability`` and ``dispersion``, and the
instruments ``oscillators response`` (resonance curve of a driven scene) and ``reflection``
(what the absorbing walls send back, against wavelength).

``app.cli`` imports this module and calls ``register(subparsers)``.  Each command prints a table
(or JSON with ``--json``), can save a picture (``--plot PATH.png``; accuracy, response and
reflection save one by default) and shows a progress bar on stderr while it runs.  Every option
is checked before anything runs (argparse types, then the planned number of steps against
``app.cli.MAX_STEPS`` / ``MAX_ESTIMATED_SECONDS``): bad values exit with code 2 and one line.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

INTEGRATOR_NAMES = ("euler", "heun", "verlet", "rk4")

STABILITY_STEPS = (10, 100_000)
"""Smallest and largest --steps of a stability trial."""

STABILITY_PRECISION = (1e-6, 1.0)
"""Range of --precision: below 1e-6 the bisection would stall at float resolution."""

DISPERSION_PARTICLES = (4, 6000)
"""Range of --particles: the wave-speed chain has 3x as many, at most ``sim.model.MAX_SIDE``."""

DISPERSION_SAMPLES = 2000
"""Samples of each spectrum (200 s every 0.1 s), to estimate the run time."""

ACCURACY_DESCRIPTION = """\
Speed against accuracy.  Runs each integrator over a range of time steps on a scene, from its
initial state to time T, and measures against a reference solution:

  error      largest particle position error at T / size of the initial disturbance
  energy     relative drift of the energy balance (kinetic + potential + dissipated)
  phase      phase error (rad) of the dominant normal mode
  wall time  of the stepping alone (compilation excluded; short runs repeated, fastest kept)

Reference: the exact normal-mode solution when the springs are linearised (--set linear=true,
lattices up to ~1500 particles); otherwise RK4 at (smallest dt)/8, whose own error is estimated
by Richardson extrapolation against (smallest dt)/4 and printed.

dt/limit is dt over the integrator's stability limit (Verlet: omega_max dt = 2, RK4: 2 sqrt 2;
explicit Euler and Heun have none without damping: their energy grows at every dt).  The measured
convergence order is the slope of log(error) against log(dt).  The recommendation is the fastest
configuration whose error is within --tolerance; for each integrator the dt that should just meet
the tolerance is also predicted from its measured order, run, and marked with *.
"""

ACCURACY_EPILOG = """\
examples:
  oscillators accuracy grid --set linear=true           # exact reference, default steps
  oscillators accuracy grid --until 5 --tolerance 1e-4 --plot docs/images/work_precision.png
  oscillators accuracy chain --integrators verlet rk4 --dts 0.02 0.01 0.005 --json
  oscillators accuracy grid --set nx=40 --set ny=30     # bigger lattice: wall time matters more

Python: from app.study.accuracy import accuracy_study  (returns the data; .as_dict() for JSON)
"""

STABILITY_DESCRIPTION = """\
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

STABILITY_EPILOG = """\
examples:
  oscillators stability                               # every case (682x383 included: minutes)
  oscillators stability --cases grid stiff heavy-among-light --plot stability.png
  oscillators stability grid --set damping=5          # one scene of your own
  oscillators stability --list                        # the cases and what they contain
"""

DISPERSION_DESCRIPTION = """\
The continuum limit.  A long chain (one row, unstressed, linearised springs, fixed ends) is given
a random displacement along the chain, integrated, and the space-time spectrum of its displacement
is taken (sine transform in space, windowed FFT in time).  The frequency measured for each
wavenumber q is compared with the discrete relation omega = 2 sqrt(k/m) |sin(q a / 2)| and the
continuum line omega = c q, c = a sqrt(k/m).  The wave speed is also measured directly by tracking
the front of a wide pulse.  For the ionic chain (masses M and m alternating) the acoustic and
optical branches and the gap between sqrt(2k/M) and sqrt(2k/m) are measured.
"""

DISPERSION_EPILOG = """\
examples:
  oscillators dispersion --plot docs/images/dispersion.png
  oscillators dispersion --particles 2000 --json
"""


RESPONSE_DESCRIPTION = """\
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

RESPONSE_EPILOG = """\
examples:
  oscillators response                                  # the resonance preset, 76 frequencies
  oscillators response resonance --set linear=true --plot docs/images/response_resonance.png
  oscillators response resonance --frequencies 0.6:0.75:30 --probe 6,0
  oscillators response single --set drag=0.5 --set linear=true \\
      --set driver=column=0,row=0,amplitude=0.01,kind=force --frequencies 0.3:2:40
  oscillators response bandgap --frequencies 0.2:1.6:57 --settle 300 --periods 20

Python: from app.study.response import response_curve  (returns the data; .as_dict() for JSON)
"""

REFLECTION_DESCRIPTION = """\
How much of a wave the absorbing walls (boundary=absorbing) send back, against wavelength.  A
long linearised chain (k = 35 N/m, m = 1 kg, a = 1 m) of 2 (distance + width) particles has a
sponge `width` particles deep at each end.  A Gaussian wave packet (envelope width = one
wavelength, at rest) in the middle splits into two halves that run into the layers at the group
velocity c_g = a sqrt(k/m) cos(q a / 2).  At t = 2 distance / c_g whatever the layers sent back has
returned to the middle: the reflected fraction is the energy (kinetic + springs) left between
the layers then, divided by the starting energy.  RK4, dt = 0.05 s.

The fixed-wall column is the control: the same chain without a sponge reflects everything, less
what RK4 damps numerically (mostly the shortest waves).

The sponge damps each particle at the rate strength sqrt(k/m) d^2 (d: depth into the layer, 0 at
its inner edge, 1 at the wall), integrated exactly.  The damping must grow slowly over a
wavelength not to reflect, so long waves need wider layers.
"""

REFLECTION_EPILOG = """\
examples:
  oscillators reflection                                  # widths 20,30,40; 6 wavelengths
  oscillators reflection --plot docs/images/reflection.png
  oscillators reflection --widths 30 --wavelengths 10,40,80 --distance 300 --json
  oscillators reflection --widths 30 --strength 1.0      # a steeper sponge

Python: from app.study.reflection import reflection_study
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the accuracy, stability, dispersion, response and reflection subcommands to the
    ``oscillators`` parser."""
    from app.cli import add_scene_arguments, bounded_int, positive_float

    formatter = argparse.RawDescriptionHelpFormatter
    accuracy = subparsers.add_parser(
        "accuracy", help="error against wall time of every integrator (work-precision)",
        description=ACCURACY_DESCRIPTION, epilog=ACCURACY_EPILOG, formatter_class=formatter,
    )
    add_scene_arguments(accuracy, default_scene="grid")
    accuracy.add_argument(
        "--integrators", nargs="+", metavar="NAME", default=None, choices=INTEGRATOR_NAMES,
        help="integrators to compare (default: euler heun verlet rk4)",
    )
    accuracy.add_argument(
        "--dts", nargs="+", type=positive_float, metavar="DT",
        help="time steps in seconds (default: 0.9 of the RK4 limit down to 1/400 of it)",
    )
    accuracy.add_argument(
        "--until", type=positive_float, metavar="T",
        help="time (s) at which the error is measured (default: 5 periods of the dominant mode)",
    )
    accuracy.add_argument(
        "--tolerance", type=_fraction, default=1e-3,
        help="target relative position error for the recommendation (default 1e-3)",
    )
    accuracy.add_argument("--no-refine", action="store_true",
                          help="do not run the dt predicted to just meet the tolerance")
    accuracy.add_argument(
        "--precisions", nargs="+", choices=("float64", "float32"), default=None,
        metavar="PRECISION",
        help="precisions the compiled integrators run in (default: float64 float32; "
        "the recommendation uses float64)",
    )
    _add_output_arguments(accuracy)
    accuracy.add_argument("--no-plot", action="store_true",
                          help="do not save the picture (by default it goes to "
                          "SCENE-work-precision.png here, or to --plot)")
    accuracy.set_defaults(handler=command_accuracy)

    stability = subparsers.add_parser(
        "stability", help="largest stable dt of every integrator, measured and theoretical",
        description=STABILITY_DESCRIPTION, epilog=STABILITY_EPILOG, formatter_class=formatter,
    )
    stability.add_argument(
        "scene", nargs="?", default=None,
        help="preset or .toml file to study alone (default: the built-in extreme cases)",
    )
    stability.add_argument(
        "--set", dest="overrides", action="append", metavar="KEY=VALUE",
        help="override a parameter of SCENE (as in `oscillators run`); repeatable",
    )
    stability.add_argument("--cases", nargs="+", metavar="CASE",
                           help="only these built-in cases (see --list)")
    stability.add_argument("--list", action="store_true", help="list the built-in cases and exit")
    stability.add_argument("--integrators", nargs="+", metavar="NAME", default=None,
                           choices=INTEGRATOR_NAMES)
    stability.add_argument(
        "--steps", type=bounded_int(*STABILITY_STEPS), default=400,
        help="steps per trial run (default 400; fewer on lattices above 100,000 particles)",
    )
    stability.add_argument(
        "--precision", type=_precision, default=0.005,
        help="relative width at which the bisection stops (default 0.005; from 1e-6 to 1)",
    )
    _add_output_arguments(stability)
    stability.set_defaults(handler=command_stability)

    dispersion = subparsers.add_parser(
        "dispersion", help="wave speed and dispersion relation measured on long chains",
        description=DISPERSION_DESCRIPTION, epilog=DISPERSION_EPILOG, formatter_class=formatter,
    )
    dispersion.add_argument("--particles", type=bounded_int(*DISPERSION_PARTICLES), default=400,
                            help="particles in the chain (default 400; from {} to {})".format(
                                *DISPERSION_PARTICLES))
    dispersion.add_argument("--stiffness", type=positive_float, default=35.0,
                            help="k in N/m (default 35)")
    dispersion.add_argument("--mass", type=positive_float, default=1.0, help="m in kg (default 1)")
    dispersion.add_argument("--heavy", type=positive_float, default=4.0,
                            help="heavy mass M of the ionic chain in kg (default 4)")
    _add_output_arguments(dispersion)
    dispersion.set_defaults(handler=command_dispersion)

    response = subparsers.add_parser(
        "response", help="resonance curve of a driven scene: steady amplitude against frequency",
        description=RESPONSE_DESCRIPTION, epilog=RESPONSE_EPILOG, formatter_class=formatter,
    )
    add_scene_arguments(response, default_scene="resonance")
    response.add_argument(
        "--frequencies", type=_frequencies, metavar="F0:F1:N",
        help="N evenly spaced drive frequencies from F0 to F1 Hz, or a list F,F,F (default: "
        "around the normal modes, with each mode's peak resolved)",
    )
    response.add_argument(
        "--probe", type=_column_row, metavar="I,J",
        help="measure at the particle in column I, row J, from 0 (default: the driven one)",
    )
    response.add_argument(
        "--settle", type=_seconds, metavar="SECONDS",
        help="seconds run after the driver's ramp before measuring (default: estimated for "
        "each frequency from the damping)",
    )
    response.add_argument(
        "--periods", type=bounded_int(2, 1000), default=4,
        help="drive periods in the fit window (default 4)",
    )
    _add_output_arguments(response)
    response.add_argument("--no-plot", action="store_true",
                          help="do not save the picture (by default it goes to "
                          "SCENE-response.png here, or to --plot)")
    response.set_defaults(handler=command_response)

    reflection = subparsers.add_parser(
        "reflection", help="reflection of the absorbing walls against wavelength",
        description=REFLECTION_DESCRIPTION, epilog=REFLECTION_EPILOG, formatter_class=formatter,
    )
    reflection.add_argument(
        "--widths", type=_whole_numbers, default=None, metavar="W,W,...",
        help="layer widths in particles (default 20,30,40)",
    )
    reflection.add_argument(
        "--wavelengths", type=_numbers, default=None, metavar="L,L,...",
        help="wavelengths in spacings a, from 2.5 (default 5,10,20,30,40,60)",
    )
    reflection.add_argument(
        "--strength", type=positive_float, default=None, metavar="S",
        help="sponge_strength: peak damping rate in units of sqrt(k/m) (default 0.5)",
    )
    reflection.add_argument(
        "--distance", type=bounded_int(10, 20_000), default=300,
        help="particles from the packet's centre to each layer (default 300; at least 3 "
        "wavelengths)",
    )
    reflection.add_argument("--no-control", action="store_true",
                            help="skip the fixed-wall control runs")
    _add_output_arguments(reflection)
    reflection.add_argument("--no-plot", action="store_true",
                            help="do not save the picture (by default it goes to "
                            "reflection.png here, or to --plot)")
    reflection.set_defaults(handler=command_reflection)


def _fraction(text: str) -> float:
    """argparse type of --tolerance: a number in (0, 1]."""
    from app.cli import positive_float

    value = positive_float(text)
    if value > 1:
        raise argparse.ArgumentTypeError(f"must be a relative error in (0, 1], got {text!r}")
    return value


def _precision(text: str) -> float:
    """argparse type of --precision: within STABILITY_PRECISION (0 would bisect forever)."""
    from app.cli import positive_float

    value = positive_float(text)
    low, high = STABILITY_PRECISION
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"must be from {low:g} to {high:g}, got {text!r}")
    return value


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


def _numbers(text: str) -> list[float]:
    """argparse type: positive numbers separated by commas."""
    try:
        values = [float(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"takes numbers separated by commas, e.g. 5,10,20, got {text!r}") from None
    if not values or not all(math.isfinite(value) and value > 0 for value in values):
        raise argparse.ArgumentTypeError(f"takes positive numbers, got {text!r}")
    return values


def _whole_numbers(text: str) -> list[int]:
    """argparse type: whole numbers >= 1 separated by commas."""
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"takes whole numbers separated by commas, e.g. 20,30,40, got {text!r}") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"takes whole numbers >= 1, got {text!r}")
    return values


def _default_plot(arguments: argparse.Namespace, name: str) -> None:
    """The picture goes to --plot, or to ``name`` here unless --no-plot; checked."""
    if arguments.no_plot:
        arguments.plot = None
    elif not arguments.plot:
        arguments.plot = name
    _check_plot_path(arguments)


def _check_plot_path(arguments: argparse.Namespace) -> None:
    """--plot must name a PNG file in an existing directory: checked before a long study runs."""
    if not arguments.plot:
        return
    path = Path(arguments.plot)
    if path.suffix.lower() != ".png":
        raise ValueError(f"--plot takes a .png file name, got {arguments.plot}")
    if path.is_dir():
        raise ValueError(f"--plot {arguments.plot} is a directory; give a .png file name")
    if not path.parent.is_dir():
        raise ValueError(f"--plot {arguments.plot}: the directory {path.parent} does not exist")


def _check_plan(runs: list[tuple[float, int, str]], what: str) -> None:
    """Refuse a study whose (steps, particles, integrator) runs exceed the step or time limits."""
    from app.cli import MAX_ESTIMATED_SECONDS, MAX_STEPS, describe_seconds
    from sim.integrators import estimated_seconds

    most = max(steps for steps, _, _ in runs)
    wall = sum(estimated_seconds(steps, particles, name) for steps, particles, name in runs)
    if most > MAX_STEPS or wall > MAX_ESTIMATED_SECONDS:
        raise ValueError(
            f"{what} plans runs of up to {most:.3g} steps, about {describe_seconds(wall)} of "
            f"computing, over the limit of {MAX_STEPS:.0e} steps or "
            f"{describe_seconds(MAX_ESTIMATED_SECONDS)}"
        )


def _add_output_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--plot", metavar="PATH.png", help="save the picture to this PNG file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _progress_bar(total: int, quiet: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="run", disable=quiet, dynamic_ncols=True, file=sys.stderr)


def _advance(bar) -> Callable[[str], None]:
    def progress(label: str) -> None:
        if bar.total is not None and bar.n >= bar.total:
            bar.total = bar.n + 1
        bar.set_description(label)
        bar.update(1)

    return progress


def _emit(arguments: argparse.Namespace, data: dict[str, Any], text: str) -> None:
    if arguments.json:
        print(json.dumps(data, indent=2))
    else:
        print(text)
        if arguments.plot:
            print(f"picture saved to {Path(arguments.plot).resolve()}")


def command_accuracy(arguments: argparse.Namespace) -> int:
    import sim
    from app.cli import scene_from_arguments
    from app.study.accuracy import accuracy_study, default_until
    from app.study.accuracy_report import format_report, plot_work_precision

    scene = scene_from_arguments(arguments)
    if arguments.no_plot:
        arguments.plot = None
    elif not arguments.plot:
        arguments.plot = f"{Path(scene.name).stem or 'scene'}-work-precision.png"
    _check_plot_path(arguments)
    if arguments.integrator and not arguments.integrators:
        arguments.integrators = [arguments.integrator]
    integrators = arguments.integrators or list(sim.INTEGRATORS)
    dts = arguments.dts or ([arguments.dt] if arguments.dt else None)
    if dts:
        until = arguments.until or default_until(scene)
        particles = scene.model.n_particles
        runs = [(until / dt, particles, name) for name in integrators for dt in dts]
        runs.append((8 * until / min(dts), particles, "rk4"))  # the numerical reference
        _check_plan(runs, "accuracy")
    planned = 2 * len(integrators) * (len(dts) if dts else 8) + 2 + len(integrators)
    with _progress_bar(planned, arguments.quiet) as bar:
        study = accuracy_study(
            scene, integrators=integrators, dts=dts, until=arguments.until,
            tolerance=arguments.tolerance, refine=not arguments.no_refine,
            progress=_advance(bar), precisions=arguments.precisions or ("float64", "float32"),
        )
        bar.total = bar.n
    data = study.as_dict()
    if arguments.plot:
        plot_work_precision(study, arguments.plot)
        data["picture"] = str(Path(arguments.plot).resolve())
    _emit(arguments, data, format_report(study))
    return 0


def command_stability(arguments: argparse.Namespace) -> int:
    from app.study import stability

    if arguments.list:
        for case in stability.default_cases():
            print(f"{case.name:22s} {case.description}")
        return 0
    _check_plot_path(arguments)
    if arguments.scene is not None:
        from app.cli import scene_from_arguments

        scene = scene_from_arguments(arguments)
        cases = [stability.Case(scene.name, "the scene given on the command line", scene)]
    else:
        cases = stability.default_cases(arguments.cases)
    integrators = arguments.integrators or None
    with _progress_bar(None, arguments.quiet) as bar:
        study = stability.stability_study(
            cases, integrators=integrators, steps=arguments.steps,
            precision=arguments.precision, progress=_advance(bar),
        )
    if arguments.plot:
        stability.plot_stability(study, arguments.plot)
    _emit(arguments, study.as_dict(), stability.format_report(study))
    return 0


def command_dispersion(arguments: argparse.Namespace) -> int:
    from app.study import dispersion

    _check_plot_path(arguments)
    lightest = min(arguments.mass, arguments.heavy)
    steps_per_sample = math.ceil(2 * math.sqrt(arguments.stiffness / lightest))
    particles = arguments.particles
    _check_plan([(DISPERSION_SAMPLES * steps_per_sample, particles, "rk4"),
                 (DISPERSION_SAMPLES * steps_per_sample, particles, "rk4"),
                 (DISPERSION_SAMPLES * steps_per_sample, max(3 * particles, 1200), "rk4")],
                "dispersion")
    with _progress_bar(None, arguments.quiet) as bar:
        study = dispersion.dispersion_study(
            particles=arguments.particles, stiffness=arguments.stiffness, mass=arguments.mass,
            heavy=arguments.heavy, progress=_advance(bar),
        )
    if arguments.plot:
        dispersion.plot_dispersion(study, arguments.plot)
    _emit(arguments, study.as_dict(), dispersion.format_report(study))
    return 0


def command_response(arguments: argparse.Namespace) -> int:
    from app.cli import scene_from_arguments
    from app.study import response, response_report

    scene = scene_from_arguments(arguments)
    _default_plot(arguments, f"{Path(scene.name).stem or 'scene'}-response.png")
    dt = arguments.dt or scene.dt
    checked = response.plan(scene, arguments.frequencies, arguments.probe, arguments.settle, dt)
    steps = response.planned_steps(scene.model.driver, checked.frequencies, checked.settles,
                                   arguments.periods, dt)
    integrator = arguments.integrator or scene.integrator
    _check_plan([(count, scene.model.n_particles, integrator) for count in steps], "response")
    with _progress_bar(len(checked.frequencies), arguments.quiet) as bar:
        curve = response.response_curve(
            scene, checked.frequencies, arguments.probe, arguments.settle, arguments.periods,
            integrator=arguments.integrator, dt=arguments.dt, precision=arguments.precision,
            threads=arguments.threads, progress=_advance(bar), prepared=checked,
        )
    data = curve.as_dict()
    if arguments.plot:
        response_report.plot_response(curve, arguments.plot)
        data["picture"] = str(Path(arguments.plot).resolve())
    _emit(arguments, data, response_report.format_report(curve))
    return 0


def command_reflection(arguments: argparse.Namespace) -> int:
    from app.study import reflection
    from sim.forcing import DEFAULT_SPONGE_STRENGTH

    _default_plot(arguments, "reflection.png")
    widths = arguments.widths or list(reflection.DEFAULT_WIDTHS)
    wavelengths = arguments.wavelengths or list(reflection.DEFAULT_WAVELENGTHS)
    strength = arguments.strength or DEFAULT_SPONGE_STRENGTH
    control = not arguments.no_control
    reflection.check_plan(widths, wavelengths, arguments.distance)
    _check_plan(reflection.planned_runs(widths, wavelengths, arguments.distance, control),
                "reflection")
    runs = len(wavelengths) * (len(widths) + int(control))
    with _progress_bar(runs, arguments.quiet) as bar:
        study = reflection.reflection_study(
            widths, wavelengths, strength, arguments.distance, control, progress=_advance(bar))
    data = study.as_dict()
    if arguments.plot:
        reflection.plot_reflection(study, arguments.plot)
        data["picture"] = str(Path(arguments.plot).resolve())
    _emit(arguments, data, reflection.format_report(study))
    return 0
