"""Render a run (or a recording) to a movie: every frame is drawn from a frame source
(``app.movie.frames``) by a ``Painter`` (``app.movie.painter``) and encoded
(``app.movie.encode``).

No screen or browser is involved.  The simulation and drawing run in the calling thread while a
second thread encodes, so both cores are used.  Colour scales are fixed for the whole movie from
a look-ahead run (``app.recording.scales``), or, for a recording, from its own frames, so frames
are comparable.
"""

from __future__ import annotations

import dataclasses
import queue
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from app.movie.encode import kind_of, open_writer
from app.movie.frames import FrameSource
from app.movie.options import MovieOptions, check_movie_memory, default_colour
from app.movie.painter import Painter
from app.movie.recorded_field import open_recording
from app.movie.simulated import SimulationSource
from sim.storage.files import AtomicFile


def _encode_in_background(writer: Any, frames: queue.Queue, errors: list[BaseException]) -> None:
    while True:
        frame = frames.get()
        if frame is None:
            return
        if errors:
            continue
        try:
            writer.write(frame)
        except BaseException as error:  # noqa: BLE001 - handed to the producer
            errors.append(error)


class MovieCancelled(Exception):
    """The caller's ``on_frame`` asked to stop (the partial file is removed)."""


OnFrame = Callable[[int, int], bool]
"""``on_frame(frames_done, frames_planned)`` after each frame, and about every
``CANCEL_INTERVAL`` seconds while a frame's steps run; returning False cancels."""

CANCEL_INTERVAL = 0.1
"""Seconds of stepping between two looks at ``on_frame`` within a frame."""


def cancel_within_frames(source: FrameSource, on_frame: OnFrame | None, done: list[int]) -> Any:
    """Make the steps between two frames of ``source`` (its ``simulation``, if it has one) look
    at ``on_frame(done[0], planned)`` about every ``CANCEL_INTERVAL`` seconds, raising
    ``MovieCancelled`` when it returns False: a frame of a long scene can take minutes.
    Returns the same watch for another simulation (the colour scales' look-ahead run, which
    comes before the first frame), or None without ``on_frame``."""
    if on_frame is None:
        return None

    def watch(simulation: Any) -> None:
        _look_while_stepping(simulation, on_frame, done, source.frames)

    simulation = getattr(source, "simulation", None)
    if simulation is not None:
        watch(simulation)
    return watch


def _look_while_stepping(simulation: Any, on_frame: OnFrame, done: list[int],
                         planned: int) -> None:
    step = simulation.step

    def step_looking(n: int = 1) -> None:
        piece, left = 1, int(n)
        while left > 0:
            if not on_frame(done[0], planned):
                raise MovieCancelled(f"cancelled after {done[0]} of {planned} frames")
            count = min(piece, left)
            started = time.perf_counter()
            step(count)
            spent = time.perf_counter() - started
            left -= count
            piece = max(1, min(4 * count, int(count * CANCEL_INTERVAL / max(spent, 1e-9))))

    simulation.step = step_looking


def _render(source: FrameSource, target: str | Path | BinaryIO, kind: str,
            options: MovieOptions, on_frame: OnFrame | None = None) -> int:
    from tqdm import tqdm

    model = source.model
    colour = options.colour or getattr(source, "colour", None) or default_colour(model)
    if options.scale is None and getattr(source, "scale_policy", None):
        options = dataclasses.replace(options, scale=source.scale_policy)
    done = [0]
    watch = cancel_within_frames(source, on_frame, done)
    scales = source.scales(colour, watch)
    painter = Painter(source.scene, model, source.summary, colour, scales, options)
    width, height = options.size
    writer = open_writer(target, kind, width, height, options.fps, palette=painter.table)
    frames: queue.Queue = queue.Queue(maxsize=6)
    errors: list[BaseException] = []
    worker = threading.Thread(target=_encode_in_background, args=(writer, frames, errors),
                              name="movie-encoder", daemon=True)
    worker.start()
    count = 0
    bar = tqdm(total=source.frames, unit="frame", disable=not options.progress,
               dynamic_ncols=True, desc="movie")
    try:
        buffers = [np.empty((height, width, 3), np.uint8) for _ in range(8)]
        wants_velocities = colour == "speed"
        wants_strains = colour == "strain" and painter.detailed
        for state in source.states(wants_velocities, wants_strains):
            if errors:
                break
            frame = buffers[count % len(buffers)]
            painter.paint(state, frame)
            frames.put(frame)
            count += 1
            done[0] = count
            bar.update(1)
            if on_frame is not None and not on_frame(count, source.frames):
                raise MovieCancelled(f"cancelled after {count} of {source.frames} frames")
    except BaseException as stopped:  # cancelled or interrupted: drop the frames still queued
        errors.append(stopped)
        raise
    finally:
        bar.close()
        frames.put(None)
        worker.join()
    if errors:
        raise errors[0]
    if count == 0:
        raise ValueError("no frames to render")
    writer.close()
    return count


def _source(scene_or_simulation: Any, options: MovieOptions) -> FrameSource:
    """A frame source: a Scene, a Simulation (its current state becomes t = 0), or a recording
    (a path ending in .rrd)."""
    if isinstance(scene_or_simulation, (str, Path)) and str(scene_or_simulation).endswith(".rrd"):
        return open_recording(Path(scene_or_simulation), options)
    scene = scene_or_simulation
    start_time = options.start_time
    if hasattr(scene, "step") and hasattr(scene, "state"):  # a running Simulation: snapshot it
        from sim.scenes.building import scene_from_simulation

        start_time = float(scene.time)  # its frames are labelled with the run's own time
        scene = scene_from_simulation(scene)
        options = dataclasses.replace(
            options, integrator=options.integrator or scene.integrator, dt=options.dt or scene.dt)
    check_movie_memory(scene.model)  # before anything runs
    return SimulationSource(scene, options, start_time)


def render_movie(
    scene_or_simulation: Any, path: str | Path, options: MovieOptions | None = None,
    on_frame: OnFrame | None = None, **changes: Any,
) -> Path:
    """Render a movie to ``path`` (.mp4, .webm or .gif) and return the path.

    scene_or_simulation: a ``sim.Scene`` (run from its initial state), a ``sim.Simulation``
    (its current state is copied and run on; call it between steps, e.g. through
    ``Runner.post``), or the path of a ``.rrd`` recording (re-rendered from its positions).
    ``changes`` override fields of ``options`` (``MovieOptions``): fps, frames, duration, size,
    colour, scale, exaggeration, integrator, dt, progress.  ``on_frame(done, planned)`` is
    called after each frame; returning False stops with ``MovieCancelled``.  Raises
    ``ValueError`` on bad options.  Frames are encoded as they are drawn: memory does not grow
    with the number of frames.
    """
    path = Path(path)
    kind = kind_of(path)
    options = dataclasses.replace(options or MovieOptions(), **changes).resolved(kind).checked()
    source = _source(scene_or_simulation, options)
    with AtomicFile(path, overwrite=True) as output:  # the caller refuses an existing file
        _render(source, output.library_path, kind, options, on_frame)
    return path


def movie_bytes(
    scene_or_simulation: Any, kind: str = "mp4", options: MovieOptions | None = None,
    **changes: Any,
) -> bytes:
    """The movie as bytes (``kind``: mp4, webm or gif), for a download; see ``render_movie``."""
    import tempfile

    kind_of(f"movie.{kind}")
    options = dataclasses.replace(options or MovieOptions(), **changes).resolved(kind).checked()
    # through a temporary file: MP4's index goes to the front (+faststart) in a second pass
    # that reopens the file by name
    with tempfile.TemporaryDirectory(prefix="movie-") as directory:
        path = Path(directory) / f"movie.{kind}"
        _render(_source(scene_or_simulation, options), path, kind, options)
        return path.read_bytes()
