"""Frames of a movie read back from a ``.rrd`` recording (its logged particle positions).

The lattice is rebuilt from the recording's own document (``/scene``: the parameter table with
units, see ``app.recording.explain``) and per-particle masses (``lattice/particles:mass``); the
positions come from ``lattice/particles`` (planar lattices) or the vertices of
``lattice/surface`` (3-D ones), on the ``sim_time`` timeline.  Speeds are finite differences of
consecutive recorded frames; strains are computed from the positions.  Recordings of large
lattices hold a field image, not positions, unless made with ``--positions all``: those are
refused with a message saying so.  In a comparison the first integrator's tree is used.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from app.movie.frames import State
from app.movie.options import MovieOptions
from app.recording.explain import table_rows
from app.recording.scales import (
    PERCENTILE,
    ColourScales,
    displacement_axis,
    field_values,
)
from sim.integrators.registry import most_accurate

POSITION_COLUMNS = {"Points2D:positions": 2, "Points3D:positions": 3,
                    "Mesh3D:vertex_positions": 3}


def _flat(value: Any) -> np.ndarray:
    flat = value.values
    while hasattr(flat, "flatten") and not hasattr(flat, "to_numpy_zero_copy"):
        flat = flat.flatten()
    return np.asarray(flat.to_numpy(zero_copy_only=False))


class RecordingSource:
    """Frames of a recording (see the module docstring), an ``app.movie.frames.FrameSource``."""

    def __init__(self, path: Path, options: MovieOptions) -> None:
        chunks = read_chunks(path)
        document, masses = document_and_masses(chunks, path)
        self.model, integrator, dt = model_from_document(document, masses)
        times, positions = self._positions(chunks, path)
        if options.duration is not None:
            keep = times <= times[0] + options.duration + 1e-9
            times, positions = times[keep], [p for p, k in zip(positions, keep, strict=True) if k]
        wanted = options.frames or options.max_frames
        if wanted is not None and wanted < len(times):
            picks = np.unique(np.linspace(0, len(times) - 1, wanted).round().astype(int))
            times, positions = times[picks], [positions[k] for k in picks]
        self.times, self.positions = times, positions
        self.frames = len(times)
        duration = max(float(times[-1] - times[0]), dt)
        self.scene = scene_of(document, self.model, integrator, dt, duration, positions[0],
                              path.stem)
        self.summary = f"{self.scene.summary()}; recording {path.name}"

    def _positions(self, chunks: list, path: Path) -> tuple[np.ndarray, list[np.ndarray]]:
        found: dict[str, dict[int, tuple[float, np.ndarray]]] = {}
        for chunk in chunks:
            if chunk.is_static or not (chunk.entity_path.endswith("/lattice/particles")
                                       or chunk.entity_path.endswith("/lattice/surface")):
                continue
            batch = chunk.to_record_batch()
            columns = [c for c in POSITION_COLUMNS if c in batch.schema.names]
            if not columns or "sim_time" not in batch.schema.names:
                continue
            width = POSITION_COLUMNS[columns[0]]
            rows = found.setdefault(chunk.entity_path, {})
            steps = batch.column("step").to_pylist()
            nanoseconds = batch.column("sim_time").cast("int64").to_pylist()
            for step, ns, value in zip(steps, nanoseconds, batch.column(columns[0]), strict=True):
                if value.is_valid and len(value.values):
                    rows[step] = (ns * 1e-9, _flat(value).reshape(-1, width).astype(np.float64))
        if not found:
            raise ValueError(
                f"{path} holds no particle positions (large lattices are recorded as a field "
                "image): record with --positions all, or make the movie from the scene"
            )
        entity = sorted(found, key=lambda e: (e.count("/"), e))[0]
        rows = found[entity]
        order = sorted(rows)
        times = np.array([rows[s][0] for s in order])
        positions = [rows[s][1] for s in order]
        if positions[0].shape != (self.model.n_particles, self.model.dim):
            raise ValueError(f"{path}: positions of shape {positions[0].shape} do not match the "
                             f"{self.model.nx}x{self.model.ny} lattice of its document")
        return times, positions

    def _speeds(self, index: int) -> np.ndarray:
        before = max(0, index - 1)
        after = min(self.frames - 1, index + 1)
        if after == before:
            return np.zeros_like(self.positions[index])
        span = self.times[after] - self.times[before]
        return (self.positions[after] - self.positions[before]) / max(span, 1e-300)

    def _strains(self, positions: np.ndarray) -> np.ndarray:
        model = self.model
        ends = np.concatenate([positions, model.anchor_positions])
        vectors = ends[model.springs[:, 1]] - ends[model.springs[:, 0]]
        return np.linalg.norm(vectors, axis=1) / model.rest_length - 1.0

    def scales(self, colour: str, watch: Any = None) -> ColourScales:
        """Scales from the recording's own frames (99.9th percentiles over up to 60 of them)."""
        model = self.model
        axis = displacement_axis(self.scene)
        rest = model.rest_positions
        rest_strain = (model.spacing - model.rest_length) / model.rest_length
        picks = np.unique(np.linspace(0, self.frames - 1, min(60, self.frames)).astype(int))
        field, height, strain = [], [], []
        for k in picks:
            positions = self.positions[k]
            speeds = self._speeds(k) if colour == "speed" else None
            field.append(np.abs(field_values(colour, positions, rest, speeds, axis, model)))
            if model.dim == 3:
                height.append(np.abs(positions[:, 2] - rest[:, 2]))
            if colour == "strain":
                strain.append(np.abs(self._strains(positions) - rest_strain))
        floor = 1e-6 * model.spacing

        def scale(pool: list[np.ndarray], smallest: float) -> float:
            if not pool:
                return 0.0
            return max(float(np.percentile(np.concatenate(pool), PERCENTILE)), smallest)

        every = np.concatenate([p[:, :2] for p in self.positions])
        bounds = (tuple(every.min(axis=0)), tuple(every.max(axis=0)))
        return ColourScales(strain=scale(strain, 1e-6), field=scale(field, floor),
                            height=scale(height, floor), axis=axis, rest_strain=rest_strain,
                            seconds=float(self.times[-1] - self.times[0]), bounds=bounds)

    def states(self, velocities: bool, strains: bool) -> Iterator[State]:
        for k in range(self.frames):
            positions = self.positions[k]
            yield State(float(self.times[k]), positions,
                        self._speeds(k) if velocities else None,
                        self._strains(positions) if strains else None)


def read_chunks(path: Path) -> list:
    """The chunks of a ``.rrd`` file (a clear error if it is not one)."""
    from rerun.chunk import RrdReader

    try:
        return RrdReader(path).stream().to_chunks()
    except Exception as error:  # noqa: BLE001 - rerun raises various types for bad files
        raise ValueError(f"cannot read {path} as a rerun recording: {error}") from None


def document_and_masses(chunks: list, path: Path) -> tuple[str, np.ndarray | None]:
    """The recording's scene document (``/scene``) and per-particle masses (kg) if logged."""
    document = None
    masses = None
    for chunk in chunks:
        if chunk.is_static:
            batch = chunk.to_record_batch()
            if chunk.entity_path == "/scene" and "TextDocument:text" in batch.schema.names:
                document = batch.column("TextDocument:text")[0].as_py()[0]
            if chunk.entity_path.endswith("/lattice/particles") and "mass" in batch.schema.names:
                masses = masses if masses is not None else _flat(batch.column("mass")[0])
    if document is None:
        raise ValueError(f"{path} has no scene document: not a recording of this program")
    return document, masses


def scene_of(document: str, model: Any, integrator: str, dt: float, duration: float,
             positions: np.ndarray, fallback: str) -> Any:
    """A ``sim.Scene`` for the title of a movie of a recording."""
    import sim

    name = document.splitlines()[0].lstrip("# ").strip()
    paragraphs = [p for p in document.split("\n\n") if p.strip()]
    description = paragraphs[1].strip() if len(paragraphs) > 1 else ""
    return sim.Scene(name=name or fallback, model=model, description=description,
                     integrator=integrator, dt=dt, duration=duration, initial_positions=positions)


def model_from_document(document: str, masses: np.ndarray | None) -> tuple[Any, str, float]:
    """The ``sim.Model`` described by a recording's parameter table, its integrator and dt."""
    from sim import Model

    rows = table_rows(document)
    try:
        values: dict[str, Any] = {key: rows[key][2] for key in (
            "nx", "ny", "dim", "spacing", "stiffness", "rest_length", "damping", "drag",
            "gravity", "linear")}
        parameters: dict[str, Any] = {
            "nx": int(values["nx"]), "ny": int(values["ny"]), "dim": int(values["dim"]),
            "linear": values["linear"].lower() == "true",
            "gravity": tuple(float(g) for g in re.findall(r"[-+0-9.eE]+", values["gravity"])),
        }
        for key in ("spacing", "stiffness", "rest_length", "damping", "drag"):
            parameters[key] = float(values[key])
        if masses is not None:
            parameters["mass"] = np.asarray(masses, float).reshape(parameters["ny"], parameters["nx"])
        else:
            parameters["mass"] = float(rows["mass"][2])
        run_row = rows.get("integrator", rows.get("integrators"))
        integrator = run_row[1].split(",")[0] if run_row else most_accurate()
        dt = float(rows["time step dt"][1])
    except (KeyError, IndexError, ValueError) as error:
        raise ValueError(f"the recording's scene document lacks a parameter ({error})") from None
    if not math.isfinite(dt) or dt <= 0:
        raise ValueError("the recording's scene document has no valid dt")
    return Model.create(**parameters), integrator.strip(), dt
