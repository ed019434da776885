"""``oscillators movie``: render a scene's run, or a recording, to an MP4, WebM or GIF movie.

Exit codes: 0 done, 2 bad input (checked before anything runs; an existing file is replaced only
with ``--force``), 3 the run blew up (the frames before it are kept in the movie), 130 Ctrl+C
(SIGINT) and 143 SIGTERM: the movie stops, its ``.partial`` file is removed and one line on
stderr says so.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from app.cli.arguments import (
    add_scene_arguments,
    bounded_int,
    check_output_file,
    positive_float,
    scene_from_arguments,
)
from app.cli.commands import summary
from app.cli.limits import planned_steps
from app.colours import SCALES
from app.movie.options import COLOURS, DEFAULTS, MAX_FRAMES, MovieOptions
from sim.storage.files import PARTIAL_SUFFIX

GIF_FRAMES = DEFAULTS["gif"][2]

EPILOG = f"""examples:
  oscillators movie interference -o interference.mp4         # the paper's 150 s, 1000 frames, 720p
  oscillators movie grid -o grid.gif --size 480x270 --fps 15 # a small GIF for slides
  oscillators movie membrane -o drum.webm --exaggerate 20    # VP9 WebM, heights drawn 20x
  oscillators movie catenary -o sag.mp4 --color density --duration 10
  oscillators movie recordings/grid.rrd -o grid.mp4          # re-render a recording's positions
  oscillators movie interference -o short.mp4 --duration 10 --size 640x360
  oscillators movie interference -o interference.html      # one page, plays in 3-D offline
  oscillators movie recordings/interference.rrd -o run.html --fps 10

the picture: large lattices as a field image (one block of pixels per particle, the lattice seen
from the front), small ones as springs and particles, 3-D ones in an oblique view coloured by
height; a title line, the simulated time, a colour bar with its unit and the scene's one-line
summary. Colours (--color): displacement (the signed component the scene is displaced along, m;
blue negative, red positive), speed |v| (m/s), strain (of the springs, minus the rest strain) or
density (relative change rho/rho_0 - 1 from each particle's four springs). The colour scale
(--scale) follows the field by default (adaptive-symlog: a log scale whose limit follows the
99th percentile of each frame, smoothed over a few simulated seconds), so waves stay visible as
they spread and weaken; the colour bar's numbers show the scale at each frame. --scale fixed
keeps one linear scale from a look-ahead run, so frames are comparable in brightness.

length: --duration simulated seconds (default: the scene's) shown in --frames frames (default:
at most {MAX_FRAMES}, 25 per simulated second); the movie lasts frames / fps seconds.
formats by suffix: .mp4 (H.264, yuv420p: browsers, slides), .webm (VP9), .gif, or .html: one
self-contained page that any browser opens from disk with no network and no server; it plays
the run in 3-D as on the web page (spheres and springs, or the field picture of a large
lattice), one simulated second per second, with play/pause, a time slider, the colour bar and
an "About this run" read-me. For .html, --fps is frames per simulated second (default 25; large
lattices 5) and --size the largest field picture (default 400x400); the defaults keep the
flagship's 150 s near 12 MB.
"""


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected WIDTHxHEIGHT such as 1280x720, got {text!r}") from None
    if not (160 <= width <= 7680 and 90 <= height <= 4320):
        raise argparse.ArgumentTypeError(f"must be between 160x90 and 7680x4320, got {text!r}")
    return width, height


def _say_if_compiling(scene: Any, arguments: argparse.Namespace) -> None:
    """Say so before the run when its kernels are not in numba's cache yet (they compile in
    this process, seconds to a minute on a first run): a step tried with compiles refused."""
    from sim import Simulation
    from sim.runtime.warming import WouldCompile, refusing_compiles

    simulation = Simulation(scene, integrator=arguments.integrator, dt=arguments.dt)
    try:
        with refusing_compiles():
            simulation.energy()
            simulation.step(1)
    except WouldCompile:
        print("compiling the kernels for this run (first time on this machine; later runs read "
              "them from the cache) ...", file=sys.stderr, flush=True)


def register(subparsers: Any) -> None:
    """Add the ``movie`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "movie", help=summary("movie"),
        description="Run a scene (or read a .rrd recording) and render it to a movie without a "
        "screen: field image or springs and particles, title, time, colour bar, summary.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser)
    parser.add_argument("-o", "--output", type=Path, required=True,
                        help="the movie file: .mp4, .webm, .gif or .html (one page)")
    parser.add_argument("--force", action="store_true", help="replace the output if it exists")
    parser.add_argument("--fps", type=bounded_int(1, 120),
                        help="movie frames per second (default 30; GIF 15)")
    parser.add_argument("--frames", type=bounded_int(2, 100_000),
                        help=f"movie frames (default: at most {MAX_FRAMES} (GIF {GIF_FRAMES}), "
                        "25 per simulated second)")
    parser.add_argument("--duration", type=positive_float,
                        help="simulated seconds to show (default: the scene's; a recording: all)")
    parser.add_argument("--size", type=_size, metavar="WxH",
                        help="frame size in pixels (default 1280x720; GIF 640x360)")
    parser.add_argument("--color", "--colour", dest="colour", choices=COLOURS,
                        help="what the colours show (default: strain for small planar lattices, "
                        "displacement otherwise)")
    parser.add_argument("--scale", choices=tuple(SCALES),
                        help="colour scale: adaptive-symlog (default), adaptive (linear), symlog "
                        "(log, fixed limit) or fixed (linear, fixed limit)")
    parser.add_argument("--exaggerate", type=positive_float, metavar="FACTOR",
                        help="3-D scenes: draw heights FACTOR times larger")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=command_movie, command_parser=parser)


def _readable_copy(partial: Path, cleanup: contextlib.ExitStack) -> Path:
    """The readable part of a recording cut off by a kill, copied to a temporary file (said on
    stderr)."""
    from app.recording.destination import RecordingError, salvage

    folder = Path(cleanup.enter_context(tempfile.TemporaryDirectory(prefix="partial-")))
    copy = folder / "readable.rrd"
    try:
        part = salvage(partial, copy)
    except RecordingError as error:
        raise ValueError(str(error)) from None
    print(part.describe(partial), file=sys.stderr)
    return copy


def movie_length(path: Path) -> str:
    """A movie file's length in words: seconds, frames and frames per second."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames = stream.frames or sum(1 for _ in container.demux(stream) if _.size)
        rate = float(stream.average_rate or 0)
    seconds = frames / rate if rate else 0.0
    return f"{seconds:.1f} s of movie: {frames} frames at {rate:g} frames/s"


class _Stopped(KeyboardInterrupt):
    """SIGTERM, raised where the movie is, so it ends as Ctrl+C does (its file removed)."""


@contextlib.contextmanager
def _stop_on_sigterm():
    """SIGTERM raises ``_Stopped`` in the main thread while the movie is made (Ctrl+C raises
    ``KeyboardInterrupt`` already); outside the main thread the signals are left alone."""

    def stop(number: int, _frame: Any) -> None:
        raise _Stopped(signal.Signals(number).name)

    try:
        previous = signal.signal(signal.SIGTERM, stop)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def command_movie(arguments: argparse.Namespace) -> int:
    """Make the movie; Ctrl+C or SIGTERM stop it with one line on stderr, no file left."""
    with _stop_on_sigterm():
        try:
            return _make_movie(arguments)
        except KeyboardInterrupt as stopped:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a second one while we say so
            name = "SIGTERM" if isinstance(stopped, _Stopped) else "Ctrl+C"
            print(f"movie stopped by {name}: nothing written to {arguments.output}",
                  file=sys.stderr)
            return 128 + (signal.SIGTERM if isinstance(stopped, _Stopped) else signal.SIGINT)


def _make_movie(arguments: argparse.Namespace) -> int:
    from app.movie import encode
    from app.movie.render import render_movie

    output: Path = arguments.output
    page = output.suffix.lower() == ".html"
    kind = "html" if page else encode.kind_of(output)
    if not page and not encode.available(kind):
        raise ValueError(f"this PyAV build cannot write .{kind}; try .mp4 or .gif")
    check_output_file(output, arguments.force, f".{kind}")
    options = MovieOptions(
        fps=arguments.fps, frames=arguments.frames, duration=arguments.duration,
        size=arguments.size, colour=arguments.colour, scale=arguments.scale,
        exaggeration=arguments.exaggerate,
        integrator=arguments.integrator, dt=arguments.dt, progress=not arguments.quiet,
    )
    with contextlib.ExitStack() as cleanup:
        if arguments.scene.endswith((".rrd", PARTIAL_SUFFIX)):
            if arguments.overrides or arguments.integrator or arguments.dt:
                raise ValueError("--set, --integrator and --dt apply to scenes, not to recordings")
            source: Any = Path(arguments.scene)
            if not source.is_file():
                raise ValueError(f"no recording {source}")
            if source.name.endswith(PARTIAL_SUFFIX):
                source = _readable_copy(source, cleanup)
        else:
            source = scene_from_arguments(arguments)
            planned_steps(SimpleNamespace(  # the same planned-work limit as run and record
                scene=source, model=source.model, dt=arguments.dt or source.dt,
                integrator=arguments.integrator or source.integrator),
                duration=arguments.duration)
        started = time.perf_counter()
        if not isinstance(source, Path) and not arguments.quiet:
            _say_if_compiling(source, arguments)
        if page:
            from app.cli.arguments import command_from_arguments
            from app.movie.html import render_html
            from app.recording.explain import command_line

            command = (command_from_arguments(arguments.command_parser, arguments)
                       if getattr(arguments, "command_parser", None) else command_line())
            written = render_html(source, output, options, command=command)
            path, length = written.path, written.describe()
        else:
            path = render_movie(source, output, options)
            length = movie_length(path)
    elapsed = time.perf_counter() - started
    print(f"wrote {path}: {length} ({path.stat().st_size / 1e6:.2f} MB, made in {elapsed:.1f} s)",
          file=sys.stderr if arguments.quiet else sys.stdout)
    return 0
