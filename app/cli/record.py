"""``oscillators record``: run a scene headless and write a rerun ``.rrd`` recording.

Exit codes: 0 done, 2 bad input or unwritable destination (checked before any step is run; an
existing file is only replaced with ``--force``) or a write that failed during the run (disk
full: the run stops, what was written is kept as a valid ``.rrd`` ending with an ERROR entry),
3 the run blew up (the file is still valid and ends with the error), 130 interrupted by
SIGINT/SIGTERM (what was recorded is kept).
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import os
import signal
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from app.cli import kernels
from app.cli.arguments import (
    add_length_arguments,
    add_scene_arguments,
    bounded_int,
    check_output_file,
    command_from_arguments,
    positive_float,
    positive_int,
    scene_from_arguments,
)
from app.cli.commands import summary
from app.cli.limits import planned_steps
from app.colours import SCALES
from app.recording import destination, instruments
from app.recording.destination import RecordingError
from app.recording.explain import RunInfo
from app.recording.field import FIELD_MODES, video_available
from app.recording.options import DETAIL_LIMIT, RecordingOptions
from app.recording.scales import QUANTITIES
from sim.storage.files import PARTIAL_SUFFIX, default_output

DEFAULT_FOLDER = Path("recordings")
"""Where a recording goes without -o: DEFAULT_FOLDER/<scene name, made a plain file name>.rrd."""

MAX_DEFAULT_FRAMES = 1000
"""Frames a recording gets by default (--every is chosen to stay within it)."""
SIZE_BUDGET_BYTES = 8e6
"""Default --every also keeps the estimated file size within this (all trees together)."""

EPILOG = f"""examples:
  oscillators record grid                                  # -> recordings/grid.rrd, the scene's 20 s
  oscillators record chain --duration 20 -o /tmp/chain.rrd
  oscillators record ionic --integrator verlet --dt 0.005 --steps 4000 --every 4
  oscillators record grid --compare euler,verlet,rk4 --dt 0.05 --steps 600
  oscillators record interference                          # 150 s: the fronts meet; H.264 field
  oscillators record interference --steps 200 --field raw  # lossless float32 field
  oscillators record interference --field jpeg --positions 50 --quantity speed
  oscillators record membrane --exaggerate 20              # heights drawn 20x (default: ~8 % of the width)
  oscillators record grid --set nx=40 --set ny=30 --set damping=0.5
  oscillators record resonance --probe 0,0 --probe 4,0     # displacement series + spectra
  oscillators record grid --set linear=true --modes        # energy per normal mode, log colour

what is logged: planar lattices of up to {DETAIL_LIMIT} particles get every particle and every
spring (coloured by strain) each recorded frame; 3-D ones a surface through the particles coloured
by height; larger ones the signed displacement (or |u|, or speed) of every particle as one image
per frame (--field), positions only with --positions, no springs. Energies, the energy-balance
error, dt and the integrator are logged every frame in every mode. Colour scales are fixed from a
short look-ahead run, so frames are comparable; the "read me" document in the file lists the
scene's parameters with units, the initial displacement, the run and how to read each view.
By default a frame is recorded every K steps so that there are at most {MAX_DEFAULT_FRAMES} frames
and the file stays under about {SIZE_BUDGET_BYTES / 1e6:.0f} MB (sizes in MB = 10^6 bytes).
Scenes with a driver also plot its work (`driven`); absorbing walls are outlined.

instruments: --probe I,J records the displacement of the particle in column I, row J every frame
(probes/I_J/x, y; z in 3-D) and, at the end, its spectrum with the peaks and the nearest normal
modes named in the read-me. --modes records the energy in every normal mode (modes/x, y, z: a
tensor in J and a log-colour heat map), thinned so that they take at most
{instruments.MODES_BUDGET_BYTES / 1e6:.0f} MB of the budget; lattices over {instruments.MODE_IMAGE_SIDE} modes
wide or high are summed over blocks of modes.

open a recording with the viewer of the same version:
  pip install rerun-sdk==0.41.0 && rerun recordings/grid.rrd
  rerun --web-viewer recordings/grid.rrd          # the bundled web viewer, in a browser
video fields: `pip install av` to record them; the native viewer decodes H.264 with ffmpeg
(install it), the web viewer with the browser. Use --field jpeg if neither is available.
layout of the file for analysis: docs/recording.md
"""


def register(subparsers: Any) -> None:
    """Add the ``record`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "record", help=summary("record"),
        description="Run a scene without a viewer and record it into a rerun .rrd file: "
        "positions, springs coloured by strain (small lattices) or a field image (large ones), "
        "energies, integrator and dt on the timelines `step` and `sim_time`.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser)
    parser.add_argument(
        "-o", "--output", type=Path,
        help="the .rrd file to write (default: recordings/SCENE.rrd, or SCENE-compare.rrd, "
        "SCENE being the scene's name made a plain file name); an existing file is replaced "
        "only with --force; its folder must exist. `record NAME.rrd.partial` says how much of a "
        "recording cut off by a kill is readable and copies that part to NAME.rrd",
    )
    parser.add_argument("--force", action="store_true",
                        help="replace the output file if it exists")
    add_length_arguments(parser, "steps to run (default: the scene's duration, e.g. 150 s for "
                         "interference, so the waves meet)")
    parser.add_argument(
        "--every", type=positive_int, metavar="K",
        help=f"record a frame every K steps (default: every step, or every K-th for at most "
        f"{MAX_DEFAULT_FRAMES} frames and about {SIZE_BUDGET_BYTES / 1e6:.0f} MB)",
    )
    parser.add_argument(
        "--field", choices=("auto", "none", *FIELD_MODES), default="auto",
        help="field image: auto (none for small lattices; video if PyAV is installed, else jpeg, "
        "for large ones), video (H.264: 4-30 MB per 1000 frames of interference), jpeg (9-90 "
        "MB), raw (float image, lossless: up to 1 MB a frame) or none",
    )
    parser.add_argument(
        "--quantity", choices=QUANTITIES, default="displacement",
        help="what the field image shows: displacement (the signed component the scene is "
        "displaced along, m; blue negative, red positive), magnitude |x - x_rest| (m) or "
        "speed |v| (m/s)",
    )
    parser.add_argument(
        "--field-scale", type=positive_float, metavar="VALUE",
        help="field value at the end of the colour map (default: from a look-ahead run); "
        "alone it fixes the field's scale (--scale fixed)",
    )
    parser.add_argument(
        "--scale", choices=tuple(SCALES), dest="field_policy",
        help="the field's colour scale: adaptive-symlog (default: a log scale whose limit follows "
        "the field, as on the page and in movies, so the waves show at every moment), adaptive "
        "(linear), symlog (log, fixed limit) or fixed (linear, one limit for the whole recording)",
    )
    parser.add_argument(
        "--exaggerate", type=positive_float, metavar="FACTOR",
        help="3-D scenes: draw heights FACTOR times larger (default: the typical height shows "
        "as about 8 %% of the lattice width)",
    )
    parser.add_argument(
        "--raw-dtype", choices=("float32", "float16"), default="float32",
        help="precision of --field raw (float16 halves the size)",
    )
    parser.add_argument("--jpeg-quality", type=bounded_int(1, 95), default=80,
                        help="1-95 (default 80)")
    parser.add_argument(
        "--positions", type=_positions_choice, default="auto", metavar="auto|all|none|N",
        help="particle positions: auto (every frame for small lattices, none for large), all, "
        "none, or N: every N-th recorded frame",
    )
    parser.add_argument(
        "--compare", metavar="A,B,...",
        help="record the same initial state under several integrators, e.g. euler,verlet,rk4 "
        "(one entity tree per integrator, shared timelines)",
    )
    parser.add_argument(
        "--screen", type=int, metavar="COLUMN",
        help="an intensity screen on this column: <u^2> over whole periods of the drive, with "
        "the fringe theory of a slit barrier (screen/intensity, screen/rows/<j>)",
    )
    parser.add_argument(
        "--probe", action="append", type=_probe_choice, metavar="I,J",
        help="record the displacement of the particle in column I, row J (from 0) every frame, "
        "and its spectrum at the end; repeatable",
    )
    parser.add_argument(
        "--modes", action="store_true",
        help="record the energy in each normal mode (one heat map per polarisation, log colour; "
        f"at most {instruments.MODES_BUDGET_BYTES / 1e6:.0f} MB of the file, thinned in time); "
        "refused for unequal-mass lattices too large for their modes to be computed",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=command_record, command_parser=parser, reads_cached_kernels=True)


class _StopRequest:
    """SIGINT / SIGTERM: the first asks the loop to stop after the frame being computed (so every
    recorded frame is complete); a second one stops at once (KeyboardInterrupt)."""

    def __init__(self) -> None:
        self.signal_name: str | None = None

    def handle(self, number: int, frame: Any) -> None:
        if self.signal_name is not None:
            raise KeyboardInterrupt
        self.signal_name = signal.Signals(number).name

    @contextlib.contextmanager
    def installed(self) -> Iterator[_StopRequest]:
        try:
            previous = {number: signal.signal(number, self.handle)
                        for number in (signal.SIGINT, signal.SIGTERM)}
        except ValueError:  # not the main thread: leave the signals alone
            yield self
            return
        try:
            yield self
        finally:
            for number, handler in previous.items():
                signal.signal(number, handler)


@contextlib.contextmanager
def _signals_ignored() -> Iterator[None]:
    """While the file is being finished, a second Ctrl-C must not leave it half-written."""
    try:
        previous = {number: signal.signal(number, signal.SIG_IGN)
                    for number in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:
        yield
        return
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def _positions_choice(text: str) -> str:
    """argparse type of --positions: auto, all, none or a whole number >= 1."""
    if text in ("auto", "all", "none") or (text.isdigit() and int(text) >= 1):
        return text
    raise argparse.ArgumentTypeError(f"must be auto, all, none or a whole number >= 1, got {text!r}")


def _probe_choice(text: str) -> str:
    """argparse type of --probe: "I,J" with whole numbers >= 0 (checked against the lattice once
    the scene is built); kept as text so the read-me's command line shows it as typed."""
    try:
        instruments.parse_probe(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return text


@contextlib.contextmanager
def _runner_log_quiet() -> Iterator[None]:
    """The runner logs a detached subscriber with a traceback; the command prints one line
    instead, so that log goes nowhere while it runs."""
    logger = logging.getLogger("oscillators")
    handler = logging.NullHandler()
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)


def _integrators(text: str | None) -> list[str]:
    from sim.integrators import ALL_INTEGRATORS as INTEGRATORS

    if text is None:
        return []
    names = [name.strip() for name in text.split(",") if name.strip()]
    choices = ", ".join(INTEGRATORS)
    if not names:
        raise ValueError(f"--compare needs a comma-separated list of integrators among {choices}, "
                         f"got {text!r}")
    unknown = [name for name in names if name not in INTEGRATORS]
    if unknown:
        raise ValueError(f"--compare takes integrators among {choices}, got {text!r}")
    if len(set(names)) != len(names):
        raise ValueError(f"--compare lists an integrator twice: {text!r}")
    return names


def _salvage(arguments: argparse.Namespace) -> int:
    """``record NAME.rrd.partial``: say how much of a recording cut off by a kill is readable
    and copy that part to NAME.rrd (or -o)."""
    partial = Path(arguments.scene)
    if not partial.is_file():
        raise ValueError(f"no file {partial}")
    output = arguments.output or partial.with_name(partial.name[: -len(PARTIAL_SUFFIX)])
    if output.suffix != ".rrd":
        output = output.with_suffix(".rrd")
    try:
        part = destination.salvage(partial, output, overwrite=arguments.force)
    except RecordingError as error:
        raise ValueError(str(error)) from None
    print(f"{part.describe(partial)}; wrote {output}")
    return 0


def default_every(steps: int, runs: int, options: RecordingOptions, model: Any) -> int:
    """Steps between recorded frames: at most MAX_DEFAULT_FRAMES frames, and an estimated file
    of at most SIZE_BUDGET_BYTES for ``runs`` trees together (mode energies included)."""
    per_frame = options.plan(model).estimated_bytes_per_frame(model, options.jpeg_quality,
                                                              modes=False)
    # mode energies are thinned to their own share of the budget (instruments.modes_every)
    reserve = instruments.modes_reserve_bytes(model) * runs if options.modes else 0.0
    budget = SIZE_BUDGET_BYTES - reserve
    by_count = math.ceil(steps / MAX_DEFAULT_FRAMES)
    by_size = math.ceil(steps * runs * per_frame / budget)
    return max(1, by_count, by_size)


def command_record(arguments: argparse.Namespace) -> int:
    from tqdm import tqdm

    from sim import BlowUpError, Simulation
    from sim.runtime.runner import Runner

    if arguments.scene.endswith(PARTIAL_SUFFIX):
        return _salvage(arguments)
    compare = _integrators(arguments.compare)
    if compare and arguments.integrator:
        raise ValueError("give either --integrator or --compare, not both")
    if arguments.output is not None:
        check_output_file(arguments.output, arguments.force, ".rrd")
    scene = scene_from_arguments(arguments)
    probes = [instruments.parse_probe(text) for text in arguments.probe or []]
    try:
        instruments.check_probes(probes, scene.model)
    except ValueError as error:
        raise ValueError(f"--probe: {error}") from None
    if arguments.modes:
        try:
            instruments.check_modes(scene.model)
        except ValueError as error:
            raise ValueError(f"--modes: {error}") from None
    command = (command_from_arguments(arguments.command_parser, arguments)
               if getattr(arguments, "command_parser", None) else None)
    names = compare or [arguments.integrator or scene.integrator]
    simulations = {name: Simulation(scene, integrator=name, dt=arguments.dt) for name in names}
    first = next(iter(simulations.values()))
    dt = first.dt
    steps = planned_steps(first, steps=arguments.steps, duration=arguments.duration,
                          runs=len(simulations))
    output = arguments.output
    if output is None:
        DEFAULT_FOLDER.mkdir(exist_ok=True)  # the default folder only, never its parents
        output = default_output(DEFAULT_FOLDER, scene.name + ("-compare" if compare else ""),
                                ".rrd")
    check_output_file(output, arguments.force, ".rrd")
    options = RecordingOptions(
        field=arguments.field, quantity=arguments.quantity, field_scale=arguments.field_scale,
        field_policy=arguments.field_policy,
        positions=arguments.positions, jpeg_quality=arguments.jpeg_quality,
        raw_dtype=arguments.raw_dtype, exaggeration=arguments.exaggerate, frame_interval=0.0,
        probes=tuple(probes), modes=arguments.modes, screen=arguments.screen,
    )
    if arguments.every is None:
        arguments.every = default_every(steps, len(simulations), options, scene.model)
    if arguments.field == "auto" and scene.model.n_particles > DETAIL_LIMIT:
        if not video_available():
            print("note: PyAV not installed, recording the field as JPEG (pip install av for "
                  "H.264 video, ~10x smaller)", file=sys.stderr)
    frames = steps // arguments.every + 2
    trees = compare if compare else [None]
    for simulation in simulations.values():  # before the file is opened
        kernels.prepare(simulation, arguments.every, sys.stdout)
    from app.recording.recorder import Recorder  # rerun's writer: not needed for --help

    try:
        recorder = Recorder(
            output, scene, options=options, trees=trees, expected_frames=frames,
            integrator=", ".join(names), dt=dt, overwrite=arguments.force,
            run=RunInfo(steps=steps, every=arguments.every, command=command),
        )
    except RecordingError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    runners = {name: Runner(simulation) for name, simulation in simulations.items()}
    for name, runner in runners.items():
        recorder.attach(runner, tree=name if compare else None)
    print(scene.summary())
    print(f"recording {', '.join(names)}, dt = {dt:g} s, {steps} steps, a frame every "
          f"{arguments.every} -> {output}")
    print(f"logging: {recorder.plan.describe()}")

    status = 0
    started = time.perf_counter()
    alive = dict(runners)
    # Small chunks for large lattices so a stop request is honoured within a frame or so.
    frames_per_chunk = 1 if scene.model.n_particles > DETAIL_LIMIT else max(1, 50 // arguments.every)
    chunk_steps = arguments.every * frames_per_chunk
    bar = tqdm(total=steps * len(runners), unit="step", disable=arguments.quiet,
               dynamic_ncols=True)
    interrupted = False
    stop = _StopRequest()
    try:
        with stop.installed(), _runner_log_quiet():
            for runner in runners.values():
                runner.publish()  # the initial state, step 0
            done = 0
            while (done < steps and alive and stop.signal_name is None
                   and recorder.failure is None):
                count = min(chunk_steps, steps - done)
                for name, runner in list(alive.items()):
                    try:
                        runner.advance(count, every=arguments.every)
                    except BlowUpError as error:
                        del alive[name]
                        bar.write(f"{name}: stopped: {error}")
                        # In a comparison a blow-up is a result; it fails the run only if alone.
                        status = 3 if not alive or not compare else status
                    bar.update(count)
                done += count
    except KeyboardInterrupt:
        stop.signal_name = stop.signal_name or "SIGINT"
    finally:
        bar.close()
        if stop.signal_name is not None:
            interrupted = True
            status = 130
            print(f"{stop.signal_name}: stopped, keeping what was recorded", file=sys.stderr)
        with _signals_ignored():
            try:
                path = recorder.close(interrupted=interrupted, reason=(
                    None if stop.signal_name in (None, "SIGINT") else stop.signal_name))
            except RecordingError as error:  # writing failed: the file is kept, readable
                print(f"error: {error}", file=sys.stderr)
                if recorder.writer_stuck:  # rerun's exit handlers would wait for its writer
                    sys.stdout.flush()
                    sys.stderr.flush()
                    os._exit(2)
                return 2
    elapsed = time.perf_counter() - started
    size = path.stat().st_size
    print(f"wrote {path} ({size / 1e6:.1f} MB, {recorder.frames_logged} frames, "
          f"{elapsed:.1f} s, {recorder.logging_seconds:.1f} s of it recording); "
          f"open it with: rerun {path}")
    return status
