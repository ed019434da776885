"""The lattice view of one tree: rest positions, anchors and particles, springs coloured by
strain (small planar lattices) or a surface through the particles coloured by height (small 3-D
ones), a sponge layer's edge and the driven particle.

Planar lattices are flipped (rerun's 2-D views draw y downwards) so row 0 is at the bottom; 3-D
ones lie flat, z up, with heights exaggerated for display only (``exaggeration``).  Positions are
in metres; springs and the surface are coloured on ``app.colours.SIGNED_LINES`` with the fixed
scales of the recording (``app.recording.scales``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import rerun as rr

import app.recording.instruments as instruments
from app.colours import SIGNED_LINES
from app.recording.layout import TreePaths
from app.recording.options import LoggingPlan
from app.recording.scales import ColourScales
from app.recording.style import ANCHOR_COLOUR, NEUTRAL_COLOUR, PARTICLE_COLOUR
from sim.model.lattice import Model
from sim.runtime.runner import Frame


def grid_triangles(nx: int, ny: int) -> np.ndarray:
    """(2 (nx-1) (ny-1), 3) uint32 vertex indices: two triangles per lattice cell."""
    if nx < 2 or ny < 2:
        return np.zeros((0, 3), dtype=np.uint32)
    j, i = np.mgrid[0 : ny - 1, 0 : nx - 1]
    p = (j * nx + i).ravel()
    first = np.stack([p, p + 1, p + nx + 1], axis=1)
    second = np.stack([p, p + nx + 1, p + nx], axis=1)
    return np.concatenate([first, second]).astype(np.uint32)


class LatticeView:
    """Logs the lattice of one tree: static parts once, positions (and springs or the surface)
    on the frames the plan asks for."""

    def __init__(self, paths: TreePaths, model: Model, plan: LoggingPlan, scales: ColourScales,
                 exaggeration: float) -> None:
        self.paths = paths
        self.model = model
        self.plan = plan
        self.scales = scales
        self.exaggeration = exaggeration

    def log_static(self, stream: rr.RecordingStream) -> None:
        model, paths, plan = self.model, self.paths, self.plan
        points = rr.Points3D if model.dim == 3 else rr.Points2D
        a = model.spacing
        if model.dim == 2:
            # Rerun's 2-D views draw y downwards; flip the lattice so row 0 is at the bottom.
            stream.log(paths.lattice, rr.Transform3D(mat3x3=np.diag([1.0, -1.0, 1.0])), static=True)
        else:
            # The sheet lies flat, z up; heights exaggerated for display only.
            stream.log(paths.root or "/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
            stream.log(
                paths.lattice,
                rr.Transform3D(scale=[1.0, 1.0, self.exaggeration]),
                rr.AnyValues(height_exaggeration=self.exaggeration),
                static=True,
            )
        rest = np.asarray(model.rest_positions, dtype=np.float32)
        stream.log(paths.rest, points(rest, radii=0.04 * a, colors=NEUTRAL_COLOUR), static=True)
        stream.log(
            paths.anchors,
            points(np.asarray(model.anchor_positions, np.float32), radii=0.12 * a,
                   colors=ANCHOR_COLOUR),
            static=True,
        )
        self.log_masses(stream)
        if plan.springs:
            stream.log(
                paths.springs,
                rr.AnyValues(
                    first=model.springs[:, 0].astype(np.int32),
                    second=model.springs[:, 1].astype(np.int32),
                    strain_colour_scale=self.scales.strain,
                    rest_strain=self.scales.rest_strain,
                ),
                static=True,
            )
        if plan.surface:
            stream.log(
                paths.surface,
                rr.Mesh3D.from_fields(triangle_indices=grid_triangles(model.nx, model.ny)),
                rr.AnyValues(height_colour_scale=self.scales.height),
                static=True,
            )
        instruments.log_sponge(stream, paths, model, lattice=plan.positions_every > 0,
                               field=plan.field is not None)
        if plan.positions_every:
            instruments.log_driver(stream, paths, model)

    def log_masses(self, stream: rr.RecordingStream) -> None:
        """Static radii/colours (detailed lattices) and per-particle masses (kg)."""
        model = self.model
        masses = model.masses.ravel()
        archetype: Any = rr.Points2D if model.dim == 2 else rr.Points3D
        if self.plan.detailed:
            relative = (masses / masses.mean()) ** (1.0 / 3.0)
            radii = (0.18 * model.spacing * relative).astype(np.float32)
            if model.uniform_mass:
                colours = np.array([PARTICLE_COLOUR], dtype=np.uint8)
            else:
                weight = (masses - masses.min()) / max(masses.max() - masses.min(), 1e-300)
                colours = np.stack(
                    [40 + 160 * weight, 110 - 40 * weight, 235 - 185 * weight], axis=1
                ).astype(np.uint8)
            stream.log(self.paths.particles, archetype.from_fields(radii=radii, colors=colours),
                       rr.AnyValues(mass=masses), static=True)
        else:
            stream.log(
                self.paths.particles,
                archetype.from_fields(radii=0.3 * model.spacing, colors=PARTICLE_COLOUR),
                static=True,
            )
            if not model.uniform_mass:
                stream.log(self.paths.particles, rr.AnyValues(mass=masses), static=True)

    def log_frame(self, stream: rr.RecordingStream, frame: Frame, index: int) -> None:
        """Every ``plan.positions_every``-th frame: the (n_particles, dim) positions (m) as
        points or the surface's vertices; the springs too when the plan has them and strains
        (n_springs,) came with the frame."""
        every = self.plan.positions_every
        if not every or index % every:
            return
        positions, strains = np.asarray(frame.positions, dtype=np.float32), frame.strains
        if self.plan.surface:
            self._log_surface(stream, positions)
        else:
            archetype = rr.Points3D if self.model.dim == 3 else rr.Points2D
            stream.log(self.paths.particles, archetype(positions))
        if self.plan.springs and strains is not None:
            self._log_springs(stream, positions, strains)

    def model_changed(self, stream: rr.RecordingStream, model: Model,
                      same_lattice: bool) -> str | None:
        """New parameters: the masses again if they changed."""
        masses_changed = not np.array_equal(model.masses, self.model.masses)
        self.model = model
        if masses_changed:
            self.log_masses(stream)
        return None

    def finish(self, stream: rr.RecordingStream) -> list[str]:
        return []

    def _log_surface(self, stream: rr.RecordingStream, positions: np.ndarray) -> None:
        """(n_particles, 3) float32 positions (m) as the mesh's vertices, coloured by height."""
        height = positions[:, 2] - self.model.rest_positions[:, 2]
        colours = SIGNED_LINES.map(height, self.scales.height)
        stream.log(self.paths.surface,
                   rr.Mesh3D.from_fields(vertex_positions=positions, vertex_colors=colours))

    def _log_springs(self, stream: rr.RecordingStream, positions: np.ndarray,
                     strains: np.ndarray) -> None:
        """Springs as segments between (n_particles, dim) float32 positions (m) and the anchors,
        coloured by strain - rest strain on the fixed symmetric scale."""
        model = self.model
        ends = np.concatenate([positions, model.anchor_positions.astype(np.float32)])
        strips = ends[model.springs]  # (n_springs, 2, dim)
        colours = SIGNED_LINES.map(strains - self.scales.rest_strain, self.scales.strain)
        archetype = rr.LineStrips3D if model.dim == 3 else rr.LineStrips2D
        stream.log(
            self.paths.springs,
            archetype(strips, colors=colours, radii=0.04 * model.spacing),
            rr.AnyValues(strain=np.asarray(strains, dtype=np.float32)),
        )
