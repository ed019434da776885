"""``oscillators continuum``: one body at several particle counts against the exact continuum
solution of the wave equation (``app.study.continuum``), as a table or JSON and a picture.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from app.cli.arguments import IntegratorChoices, bounded_int, positive_float
from app.cli.commands import summary
from app.cli.limits import check_plan
from app.cli.study_output import (
    add_output_arguments,
    advance,
    check_plot_path,
    emit,
    progress_bar,
    save_picture,
)
from sim.model.lattice import MAX_SIDE
from sim.scenes.bodies import BODY_KINDS, SHAPE_KINDS

DEFAULT_PARTICLES = {"string": "4,16,64,256,1024", "membrane": "4,8,16,32,64"}
LARGEST = {"string": MAX_SIDE, "membrane": 1024}
"""Most particles per side of each body."""
PAGE_PARTICLES = 65_536
"""Most particles of one lattice the page runs live (a 256x256 membrane, a 65,536-bead string)."""

DESCRIPTION = """\
The continuum limit (the paper's eqs. 1-10).  A body given in physical units (length L0, mass
density, tension, initial shape released at rest) is discretised with N particles per side:
spacing a = L0/(N+1), masses lambda a (string) or sigma a^2 (membrane), springs keeping the
modulus K = k a fixed, so every N is the same body.  Each is run with the integrator at
dt = courant a / c, checked against the lattice's own exact normal-mode solution (dt is halved
until the time-stepping error is at most a tenth of the lattice's distance from the continuum),
and compared at 1/4, 1/2, 3/4 and 1 crossing time 2 L0/c with the exact Fourier-series solution
of the wave equation with fixed ends, evaluated at the particles (terms doubled until
converged).  It prints per N the relative L2 error and the measured order in a: 2 for smooth
shapes, about 1 for a pluck (its kink excites short waves, which the lattice disperses).

The string is run as the row's motion along its springs with k = T/a: a bead string of
tension T has exactly these equations for its transverse displacement (the lattice's rows have
wall springs above and below, which would hold a transverse row in place).  The membrane moves
out of the plane of a pre-tensioned 3-D lattice.
"""

EPILOG = """\
examples:
  oscillators continuum string --particles 4,16,64,256,1024 --plot string.png
  oscillators continuum string --shape pluck --json
  oscillators continuum string --particles 4,16,64,256 --record string.rrd
  oscillators continuum string --particles 4,16,64,256 --serve   # the page, on one clock
  oscillators continuum membrane --particles 8,16,32,64 --shape sine --mode 2
"""


def particle_list(text: str) -> list[int]:
    """argparse type: a comma-separated list of particle counts, each at least 1."""
    try:
        values = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected whole numbers separated by commas, got {text!r}") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"particle counts must be at least 1, got {text!r}")
    return values


def fraction(text: str) -> float:
    """argparse type: a number strictly between 0 and 1 (a place or width along a side)."""
    value = positive_float(text)
    if value >= 1.0:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1, got {text!r}")
    return value


def check_recording_path(path: Path, force: bool) -> None:
    """--record must name a new .rrd file in an existing directory: checked before the study."""
    if path.suffix != ".rrd":
        raise ValueError(f"--record takes a .rrd file name, got {path}")
    if path.is_dir() or not path.parent.is_dir():
        raise ValueError(f"--record {path}: give a .rrd file in an existing directory")
    if path.exists() and not force:
        raise ValueError(f"{path} already exists; use --force to replace it")


def serve_page(body, particles: list[int], arguments: argparse.Namespace) -> int:
    """Serve the 'Continuum limit' page until Ctrl+C or SIGTERM."""
    import signal
    import time

    from app.web.continuum import ContinuumPage

    if max(particles) ** body.dimensions > PAGE_PARTICLES:
        raise ValueError(f"the page shows at most {PAGE_PARTICLES:,} particles per lattice; "
                         f"use smaller --particles")
    page = ContinuumPage(body, particles, arguments.integrator, port=arguments.port)

    def terminate(number: int, frame: object) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        page.start()
        print(f"continuum limit of the {body.describe()}", flush=True)
        print(f"serving on {page.url}  (Ctrl+C to stop)", flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        print("stopping", flush=True)
    finally:
        page.stop()
        signal.signal(signal.SIGTERM, previous)
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``continuum`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "continuum", help=summary("continuum"),
        description=DESCRIPTION, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("body", nargs="?", choices=BODY_KINDS, default="string",
                        help="string (default) or membrane")
    parser.add_argument("--particles", type=particle_list, default=None,
                        help="particles per side, comma-separated (default: string "
                        f"{DEFAULT_PARTICLES['string']}, membrane {DEFAULT_PARTICLES['membrane']})")
    parser.add_argument("--shape", choices=SHAPE_KINDS, default="gaussian",
                        help="initial shape (default gaussian)")
    parser.add_argument("--amplitude", type=positive_float, default=0.01,
                        help="largest initial displacement in m (default 0.01)")
    parser.add_argument("--centre", type=fraction, default=0.5,
                        help="where the bump or pluck is, as a fraction of L0 (default 0.5)")
    parser.add_argument("--width", type=fraction, default=1 / 12,
                        help="the Gaussian's width as a fraction of L0 (default 1/12, at most 0.25)")
    parser.add_argument("--mode", type=int, default=1, help="the sine shape's mode number (default 1)")
    parser.add_argument("--length", type=positive_float, default=1.0, help="L0 in m (default 1)")
    parser.add_argument("--density", type=positive_float, default=0.01,
                        help="mass per length (kg/m) or per area (kg/m^2) (default 0.01)")
    parser.add_argument("--tension", type=positive_float, default=100.0,
                        help="tension in N (string) or N/m (membrane) (default 100)")
    parser.add_argument("--integrator", choices=IntegratorChoices(), default="verlet",
                        metavar="NAME", help="integrator of the runs (default verlet)")
    parser.add_argument("--courant", type=positive_float, default=0.1,
                        help="first try of c dt / a (default 0.1; halved while the step is not "
                        "accurate enough)")
    parser.add_argument("--record", metavar="PATH.rrd",
                        help="also record every N and the continuum solution on one timeline "
                        "(a rerun .rrd; open it with `rerun PATH.rrd`)")
    parser.add_argument("--frames", type=bounded_int(2, 5000), default=200,
                        help="frames of the recording over one crossing time (default 200)")
    parser.add_argument("--force", action="store_true", help="replace an existing recording")
    parser.add_argument("--serve", action="store_true",
                        help="show the body at every N in the browser on one clock, the continuum "
                        "solution drawn over each (the 'Continuum limit' page), instead of measuring")
    parser.add_argument("--port", type=bounded_int(0, 65535), default=8080,
                        help="port of the page with --serve (default 8080; 127.0.0.1 only)")
    add_output_arguments(parser)
    parser.set_defaults(handler=command_continuum)


def command_continuum(arguments: argparse.Namespace) -> int:
    from app.study import continuum, continuum_report
    from sim.scenes.bodies import Body

    check_plot_path(arguments)
    if arguments.record:
        check_recording_path(Path(arguments.record), arguments.force)
    particles = arguments.particles or particle_list(DEFAULT_PARTICLES[arguments.body])
    if max(particles) > LARGEST[arguments.body]:
        raise ValueError(f"a {arguments.body} takes at most {LARGEST[arguments.body]:,} particles "
                         f"per side, got {max(particles):,}")
    body = Body.create(arguments.body, arguments.shape, amplitude=arguments.amplitude,
                       centre=arguments.centre, width=arguments.width, mode=arguments.mode,
                       length=arguments.length, density=arguments.density,
                       tension=arguments.tension)
    if arguments.serve:
        return serve_page(body, particles, arguments)
    check_plan(continuum.planned_runs(body, particles, arguments.integrator, arguments.courant),
               "continuum")
    with progress_bar(len(set(particles)), arguments.quiet) as bar:
        study = continuum.continuum_study(body, particles, arguments.integrator,
                                          arguments.courant, progress=advance(bar))
    data = study.as_dict()
    save_picture(arguments, data, continuum_report.plot_continuum, study)
    if arguments.record:
        from app.recording.continuum import record_continuum
        from app.recording.destination import RecordingError

        with progress_bar(arguments.frames + 1, arguments.quiet) as bar:
            try:
                path = record_continuum(body, particles, arguments.record,
                                        frames=arguments.frames, integrator=arguments.integrator,
                                        overwrite=arguments.force, progress=advance(bar))
            except RecordingError as error:
                raise ValueError(str(error)) from None
        data["recording"] = str(path.resolve())
    emit(arguments, data, continuum_report.format_report(study))
    if arguments.record and not arguments.json:
        print(f"recording saved to {data['recording']}")
    return 0
