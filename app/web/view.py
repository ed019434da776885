"""Draws simulation frames into a viser scene: particles, springs, walls, anchors, selection.

Two ways to draw particles, chosen by lattice size:

* small lattices (up to ``SPHERE_LIMIT`` particles): instanced spheres whose diameter grows with
  the cube root of the mass;
* large lattices: one float32 point cloud coloured by the displacement field (or speed), so wave
  fronts show up; on very large lattices the points stay at their rest sites by default, and
  then the field is one picture (``app.web.frames``: encoded once per frame, shared by every
  page, at a frame rate the server chooses).

Springs are line segments coloured by strain (blue compressed, red stretched); they are hidden
automatically above ``SPRING_AUTO_LIMIT`` particles (the paper's 25x20) and never sent above
``SPRING_HARD_LIMIT`` springs.  Every update happens inside ``server.atomic()`` so a browser
never sees half a frame.  Coordinates: metres, lattice in the plane z = 0, centred on 0.
"""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import viser

from app import colours
from app.web.frames import FieldImage, uses_image
from sim.model import Model
from sim.runner import Frame

SPHERE_LIMIT = 2500
"""Up to this many particles, draw instanced spheres; above, a point cloud."""
SPRING_AUTO_LIMIT = 25 * 20
"""Above this many particles springs start hidden (the paper's largest drawn lattice)."""
SPRING_HARD_LIMIT = 20_000
"""Never send more springs than this (521k segments froze a software-rendered page)."""
MOVE_POINTS_LIMIT = 50_000
"""Above this many particles the point cloud stays at rest sites unless asked to move."""
COLOR_MODES = ("displacement", "speed", "mass", "plain")
SELECTED = (255, 30, 30)
"""RGB of selected particles."""
PARTICLE = (60, 60, 70)
"""RGB of particles when they are not coloured by a field."""
ANCHOR = (120, 90, 60)
"""RGB of the walls and their anchor points."""
STRAIN_FULL_SCALE = 0.05
"""Spring strain shown at full colour (``app.colours.STRAIN``: blue compressed, red stretched)."""


@dataclasses.dataclass
class ViewSettings:
    """What the view shows; ``None`` means "automatic for this lattice size"."""

    show_springs: bool | None = None
    move_points: bool | None = None
    particle_scale: float = 1.0
    color_by: str | None = None

    def springs_on(self, model: Model) -> bool:
        if model.n_springs > SPRING_HARD_LIMIT:
            return False
        if self.show_springs is None:
            return model.n_particles <= SPRING_AUTO_LIMIT
        return self.show_springs

    def points_move(self, model: Model) -> bool:
        if self.move_points is None:
            return model.n_particles <= MOVE_POINTS_LIMIT
        return self.move_points

    def coloring(self, model: Model) -> str:
        if self.color_by is None:
            planar_and_small = model.dim == 2 and model.n_particles <= SPHERE_LIMIT
            return "plain" if planar_and_small else "displacement"
        return self.color_by


def _sphere_mesh() -> tuple[np.ndarray, np.ndarray]:
    """A unit-diameter icosphere: vertices (V, 3), faces (F, 3)."""
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.5)
    return np.asarray(mesh.vertices, dtype=np.float32), np.asarray(mesh.faces, dtype=np.uint32)


def to_xyz(positions: np.ndarray) -> np.ndarray:
    """(n, dim) positions -> (n, 3) float32 (z = 0 in 2-D)."""
    xyz = np.zeros((positions.shape[0], 3), dtype=np.float32)
    xyz[:, : positions.shape[1]] = positions
    return xyz


def particle_diameters(model: Model, base: float) -> np.ndarray:
    """(n,) diameters (m): ``base`` for the mean mass, growing as mass^(1/3)."""
    masses = model.masses.reshape(-1)
    return (base * np.cbrt(masses / masses.mean())).astype(np.float32)


class LatticeView:
    """Owns the scene nodes under ``/lattice`` and updates them from frames."""

    def __init__(self, server: viser.ViserServer) -> None:
        self.server = server
        self.settings = ViewSettings()
        self.selection: np.ndarray = np.zeros(0, dtype=np.int64)
        self._lock = threading.Lock()
        self._layout: tuple | None = None
        self._masses_key: bytes | None = None
        self._spheres: viser.BatchedMeshHandle | None = None
        self._points: viser.PointCloudHandle | None = None
        self._springs: viser.LineSegmentsHandle | None = None
        self._selection_points: viser.PointCloudHandle | None = None
        self._image: FieldImage | None = None
        self._field_scale = 0.0
        self._dirty = True
        self.frames_drawn = 0
        self.last_positions: np.ndarray | None = None
        self.model: Model | None = None

    # --- settings --------------------------------------------------------------------------------

    def invalidate(self) -> None:
        """Rebuild every node at the next frame (settings or selection changed)."""
        self._dirty = True

    def set_selection(self, indices: np.ndarray) -> None:
        self.selection = np.unique(np.asarray(indices, dtype=np.int64))
        self._dirty = True

    def wants_strains(self) -> bool:
        return self.model is None or self.settings.springs_on(self.model)

    def wants_velocities(self) -> bool:
        return self.model is not None and self.settings.coloring(self.model) == "speed"

    # --- drawing ---------------------------------------------------------------------------------

    def draw(self, frame: Frame) -> None:
        """Show ``frame`` (call from one thread only: the app's frame pump)."""
        with self._lock:
            model = frame.model
            layout = (model.nx, model.ny, model.dim, model.spacing, model.n_particles)
            masses_key = model.masses.tobytes() if model.n_particles <= SPHERE_LIMIT else b""
            rebuild = self._dirty or layout != self._layout or masses_key != self._masses_key
            with self.server.atomic():
                if rebuild:
                    self._rebuild(frame)
                    self._layout, self._masses_key, self._dirty = layout, masses_key, False
                else:
                    self._update(frame)
            self.model = model
            self.last_positions = frame.positions
            self.frames_drawn += 1

    def _base_diameter(self, model: Model) -> float:
        fraction = 0.35 if model.n_particles <= SPHERE_LIMIT else 1.0
        return fraction * model.spacing * self.settings.particle_scale

    def _rebuild(self, frame: Frame) -> None:
        scene = self.server.scene
        model = frame.model
        for handle in (self._spheres, self._points, self._springs, self._selection_points,
                       self._image):
            if handle is not None:
                handle.remove()
        self._spheres = self._points = self._springs = self._selection_points = None
        self._image = None
        self._draw_walls(model)
        xyz = to_xyz(frame.positions)
        if model.n_particles <= SPHERE_LIMIT:
            vertices, faces = _sphere_mesh()
            self._spheres = scene.add_batched_meshes_simple(
                "/lattice/particles", vertices, faces,
                batched_wxyzs=np.tile(np.array([1.0, 0, 0, 0], np.float32), (len(xyz), 1)),
                batched_positions=xyz,
                batched_scales=particle_diameters(model, self._base_diameter(model)),
                batched_colors=self._particle_colors(frame),
                cast_shadow=False, receive_shadow=False,
            )
        else:
            self._field_scale = 0.0
            if uses_image(model, self.settings.points_move(model)):
                self._image = FieldImage(self.server, model, self._particle_colors(frame))
            else:
                shown = xyz if self.settings.points_move(model) else to_xyz(model.rest_positions)
                self._points = scene.add_point_cloud(
                    "/lattice/particles", shown, self._particle_colors(frame),
                    point_size=self._base_diameter(model), point_shape="square",
                    precision="float32", point_shading="flat",
                )
            if self.selection.size:
                self._selection_points = scene.add_point_cloud(
                    "/lattice/selection", xyz[self.selection], SELECTED,
                    point_size=1.5 * model.spacing, point_shape="circle", precision="float32",
                    point_shading="flat",
                )
        if self.settings.springs_on(model):
            self._springs = scene.add_line_segments(
                "/lattice/springs", self._spring_points(model, frame.positions),
                self._spring_colors(frame), thickness=0.05 * model.spacing,
            )

    def _update(self, frame: Frame) -> None:
        model = frame.model
        xyz = to_xyz(frame.positions)
        if self._spheres is not None:
            self._spheres.batched_positions = xyz
            if self.settings.coloring(model) in ("displacement", "speed"):
                self._spheres.batched_colors = self._particle_colors(frame)
        if self._points is not None:
            if self.settings.points_move(model):
                self._points.points = xyz
            self._points.colors = self._particle_colors(frame)
        if self._image is not None and (self._image.due_now() or not frame.playing):
            self._image.show(self._particle_colors(frame), force=True)
        if self._selection_points is not None:
            self._selection_points.points = xyz[self.selection]
        if self._springs is not None:
            self._springs.points = self._spring_points(model, frame.positions)
            if frame.strains is not None:
                self._springs.colors = self._spring_colors(frame)

    def _draw_walls(self, model: Model) -> None:
        """Four wall lines one spacing outside the lattice and the anchor points."""
        origin_x, origin_y = model.origin
        a = model.spacing
        left, right = origin_x - a, origin_x + model.nx * a
        bottom, top = origin_y - a, origin_y + model.ny * a
        corners = np.array(
            [[left, bottom, 0], [right, bottom, 0], [right, top, 0], [left, top, 0]], np.float32
        )
        walls = np.stack([corners, np.roll(corners, -1, axis=0)], axis=1)
        self.server.scene.add_line_segments(
            "/lattice/walls", walls, ANCHOR, thickness=0.15 * a,
        )
        self.server.scene.add_point_cloud(
            "/lattice/anchors", to_xyz(model.anchor_positions), ANCHOR,
            point_size=0.2 * a if model.n_particles <= SPHERE_LIMIT else a,
            point_shape="square", precision="float32", point_shading="flat",
        )

    def _particle_colors(self, frame: Frame) -> np.ndarray:
        model = frame.model
        mode = self.settings.coloring(model)
        n = model.n_particles
        if mode == "displacement":
            values = np.linalg.norm(frame.positions - model.rest_positions, axis=1)
        elif mode == "speed" and frame.velocities is not None:
            values = np.linalg.norm(frame.velocities, axis=1)
        elif mode == "mass":
            masses = model.masses.reshape(-1)
            values = masses / masses.max()
        else:
            values = None
        if values is None:
            result = np.empty((n, 3), np.uint8)
            result[:] = PARTICLE
        else:
            result = colours.MAGNITUDE.map(values, self._adapt_scale(values, mode))
        if self._spheres is not None or n <= SPHERE_LIMIT:
            result[self.selection] = SELECTED
        return result

    def _adapt_scale(self, values: np.ndarray, mode: str) -> float:
        """Full-scale value of the colour map: a slowly decaying high percentile."""
        if mode == "mass":
            return 1.0
        sample = values[:: max(1, values.size // 20_000)]
        current = float(np.percentile(sample, 99.5)) if sample.size else 0.0
        current = max(current, float(values.max()) * 0.05)
        self._field_scale = max(current, 0.97 * self._field_scale)
        return self._field_scale or 1.0

    @staticmethod
    def _spring_points(model: Model, positions: np.ndarray) -> np.ndarray:
        ends = np.concatenate([to_xyz(positions), to_xyz(model.anchor_positions)])
        return ends[model.springs]

    @staticmethod
    def _spring_colors(frame: Frame) -> np.ndarray:
        if frame.strains is None:
            relaxed = colours.STRAIN.map(np.zeros(1), STRAIN_FULL_SCALE)[0]  # strain 0
            return np.broadcast_to(relaxed, (frame.model.n_springs, 2, 3))
        per_spring = colours.STRAIN.map(frame.strains, STRAIN_FULL_SCALE)
        return np.repeat(per_spring[:, None, :], 2, axis=1)
