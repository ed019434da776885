"""A rerun recording of the continuum limit: one body (``sim.scenes.bodies``) at several particle counts
and the exact continuum solution (``sim.scenes.continuum``), all on one timeline, so a student scrubs
the comparison.

Entities (N written with four digits, so they sort: ``N0016``):

* ``/continuum/N0016/lattice``: the string's beads and the line through them, drawn across
  the string (s, offset + E u) with the displacement exaggerated E times; for a membrane the
  displacement field as an image in the ``signed-field`` colours of ``app.colours``;
* ``/continuum/N0016/continuum``: the continuum solution over it, a thin curve on 400 points
  (string), or the reference panel: the continuum at the same particles in the same colours
  (membrane);
* ``/distance/N0016``: the relative L2 distance of that lattice from the continuum at its
  particles, against time;
* ``/scene``: a read-me saying what is drawn.

The timeline is ``time`` (simulated seconds) with ``frame`` beside it.  The lattices are run with
the study's first step (``sim.scenes.bodies.Body.first_step``: a tenth of a / c), shortened so that
every frame time is a whole number of steps.  The file is written as ``NAME.rrd.partial`` and
renamed when complete (``app.recording.destination``).
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

import app.recording.destination as destination
from app.colours import get as colour_map
from app.recording.recorder import APPLICATION_ID
from sim.runtime.simulation import Simulation
from sim.scenes.bodies import Body
from sim.scenes.continuum import ContinuumSolution

CURVE_POINTS = 400
"""Intervals of the continuum curve drawn over a string."""

LATTICE_COLOUR = (40, 90, 200)
CONTINUUM_COLOUR = (220, 60, 40)


def entity(particles: int, part: str) -> str:
    """``/continuum/N0016/lattice`` and the like."""
    return f"/continuum/N{particles:04d}/{part}"


def distance_entity(particles: int) -> str:
    return f"/distance/N{particles:04d}"


def estimated_bytes(body: Body, particles: Sequence[int], frames: int) -> float:
    """A generous size (bytes) of the recording: per frame and N, a string's beads, line and
    curve in float32 (and their overhead), a membrane's two RGB images."""
    if body.kind == "string":
        per_frame = sum(24 * (n + 2) + 8 * (CURVE_POINTS + 1) + 2000 for n in particles)
    else:
        per_frame = sum(2 * 3 * n * n + 2000 for n in particles)
    return float(per_frame) * (frames + 1)


def drawn_exaggeration(body: Body) -> float:
    """How many times a string's displacement is enlarged when drawn: its amplitude becomes
    12 % of its length."""
    return 0.12 * body.length / abs(body.shape.amplitude)


def _blueprint(body: Body, particles: Sequence[int]) -> rrb.Blueprint:
    if body.kind == "string":
        views = [rrb.Spatial2DView(origin=f"/continuum/N{n:04d}", name=f"N = {n}")
                 for n in particles]
        bodies = rrb.Vertical(*views)
    else:
        bodies = rrb.Grid(*[view for n in particles for view in (
            rrb.Spatial2DView(origin=entity(n, "lattice"), name=f"N = {n} lattice"),
            rrb.Spatial2DView(origin=entity(n, "continuum"), name=f"N = {n} continuum"))],
            grid_columns=2)
    return rrb.Blueprint(
        rrb.Horizontal(bodies, rrb.Vertical(
            rrb.TimeSeriesView(origin="/distance", name="distance from the continuum"),
            rrb.TextDocumentView(origin="/scene", name="read me"), row_shares=[2, 1]),
            column_shares=[3, 2]),
        collapse_panels=True,
    )


def _document(body: Body, particles: Sequence[int], exaggeration: float, duration: float) -> str:
    drawn = (f"the beads and the line through them (blue; displacement drawn across the string, "
             f"{exaggeration:g} times exaggerated), the continuum solution over them (thin red "
             "curve)" if body.kind == "string" else
             "the lattice's displacement u_z as an image (blue - white - red) beside the "
             "continuum solution at the same particles in the same colours")
    return (
        f"# Continuum limit\n\n{body.describe()}.\n\nThe same body with "
        f"{', '.join(map(str, particles))} particles per side, on one clock for "
        f"{duration:.4g} s (one crossing time 2 L0 / c = {body.crossing_time:.4g} s).  Each panel "
        f"shows {drawn}.  The plot gives each lattice's relative L2 distance from the continuum "
        "at its particles: the few-particle lattices lag and disperse, the many-particle ones "
        "follow the wave equation (the error falls as a^2 for a smooth shape)."
    )


def record_continuum(body: Body, particles: Sequence[int], path: str | Path, frames: int = 200,
                     duration: float | None = None, integrator: str = "verlet",
                     overwrite: bool = False,
                     progress: Callable[[str], None] | None = None) -> Path:
    """Record ``body`` at each of ``particles`` (per side) and its continuum solution, ``frames``
    frames over ``duration`` (s, default one crossing time); returns the final path."""
    path = Path(path)
    counts = sorted(set(int(n) for n in particles))
    duration = body.crossing_time if duration is None else float(duration)
    output = destination.open_destination(path, overwrite, estimated_bytes(body, counts, frames))
    try:
        stream = rr.RecordingStream(APPLICATION_ID, recording_id=uuid.uuid4())
        stream.save(output.library_path, default_blueprint=_blueprint(body, counts))
        stream.send_recording_name(f"continuum limit: {body.kind}")
        exaggeration = drawn_exaggeration(body)
        stream.log("/scene", rr.TextDocument(_document(body, counts, exaggeration, duration),
                                             media_type=rr.MediaType.MARKDOWN), static=True)
        for n in counts:
            stream.log(distance_entity(n), rr.SeriesLines(names=f"N = {n}"), static=True)
        runs = [BodyRun(body, n, integrator) for n in counts]
        curve = ContinuumSolution(body, CURVE_POINTS - 1) if body.kind == "string" else None
        for frame in range(frames + 1):
            time = duration * frame / frames
            stream.set_time("time", duration=time)
            stream.set_time("frame", sequence=frame)
            for run in runs:
                run.advance_to(time)
                run.log(stream, time, exaggeration, curve)
            if progress is not None:
                progress(f"frame {frame} of {frames}")
        destination.flush(stream, path.parent)
        stream.disconnect()
        output.commit()
    except BaseException:
        output.discard()
        raise
    return path


class BodyRun:
    """One particle count: its simulation (``advance_to`` a time), its continuum solution,
    the distance between them (``distance``) and how a recording draws it (``log``)."""

    def __init__(self, body: Body, particles: int, integrator: str) -> None:
        self.body = body
        self.particles = particles
        self.dt = body.first_step(particles, integrator)
        self.simulation = Simulation(body.scene(particles, integrator, self.dt))
        self.continuum = ContinuumSolution(body, particles)
        self.norm = float(np.linalg.norm(self.continuum.at(0.0)))

    def advance_to(self, time: float) -> None:
        remaining = time - self.simulation.time
        if remaining <= 0:
            return
        steps = max(1, math.ceil(remaining / self.dt - 1e-9))
        self.simulation.dt = remaining / steps
        self.simulation.step(steps)

    def fields(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """(lattice, continuum) (ny, nx) displacements (m) now, the continuum at ``time``."""
        field = self.body.field(self.simulation.model, self.simulation.peek_positions())
        return field, self.continuum.at(time)

    def distance(self, field: np.ndarray, reference: np.ndarray) -> float:
        """Relative L2 distance of the lattice from the continuum at its particles."""
        return float(np.linalg.norm(field - reference)) / self.norm

    def log(self, stream: rr.RecordingStream, time: float, exaggeration: float,
            curve: ContinuumSolution | None) -> None:
        body, n = self.body, self.particles
        field, reference = self.fields(time)
        stream.log(distance_entity(n), rr.Scalars(self.distance(field, reference)))
        if curve is not None:
            s = np.concatenate([[0.0], body.coordinates(n), [body.length]])
            u = np.concatenate([[0.0], field[0], [0.0]]) * exaggeration
            beads = np.stack([s, -u], axis=1)  # image-like 2-D space: y down, so up is -y
            stream.log(entity(n, "lattice"),
                       rr.LineStrips2D([beads], colors=LATTICE_COLOUR, radii=0.002),
                       rr.Points2D(beads[1:-1], colors=LATTICE_COLOUR,
                                   radii=min(0.012, 0.25 * body.spacing(n))))
            fine = np.concatenate([[0.0], curve.at(time)[0], [0.0]]) * exaggeration
            xs = np.linspace(0.0, body.length, CURVE_POINTS + 1)
            stream.log(entity(n, "continuum"),
                       rr.LineStrips2D([np.stack([xs, -fine], axis=1)], colors=CONTINUUM_COLOUR,
                                       radii=0.001))
            return
        colours = colour_map("signed-field")
        scale = abs(body.shape.amplitude)
        for part, values in (("lattice", field), ("continuum", reference)):
            image = colours.map(values[::-1], scale)  # row 0 (bottom) drawn last: y up
            stream.log(entity(n, part), rr.Image(image))
