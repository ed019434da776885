"""Draws simulation frames into a viser scene: particles, springs, walls, anchors, selection.

Two ways to draw particles, chosen by lattice size:

* small lattices (up to ``SPHERE_LIMIT`` particles): instanced spheres whose diameter grows with
  the cube root of the mass;
* large lattices: one float32 point cloud coloured by the displacement field (or speed), so wave
  fronts show up; on very large lattices the points stay at their rest sites by default, and
  then the field is one picture (``app.web.frames``: encoded once, sent to each page as soon
  as it has drawn the previous one, ``app.web.pacing``).

Colours come from the quantity's scheme in ``app.colours`` (the same language as movies and
recordings): the signed displacement along the scene's axis (the component it is displaced
along) on the blue - grey - red map (grey at rest, so the lattice shows before anything moves),
or the speed, on the scheme's scale (by default logarithmic, its limit following the field).  The
colour bar (quantity, units, the numbers of the scale in use; ``app.web.colour_bar``) floats over
the view's bottom-left corner, redrawn when the scale moves.

Springs are line segments coloured by strain (blue compressed, red stretched); they are hidden
automatically above ``SPRING_AUTO_LIMIT`` particles (the paper's 25x20) and never sent above
``SPRING_HARD_LIMIT`` springs.  Every update happens inside ``server.atomic()`` so a browser
never sees half a frame.  Coordinates: metres, lattice in the plane z = 0, centred on 0.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections.abc import Callable

import numpy as np
import viser

from app import colours
from app.web.colour_bar import (
    BAR_ASPECT,
    OVERLAY_HEIGHT,
    ColourBar,
    bar_width,
    phone_picture,
)
from app.web.equilibrium import sag
from app.web.frames import DEFAULT_FPS, FieldImage, uses_image
from sim.model.lattice import Model
from sim.runtime.runner import Frame

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


@dataclasses.dataclass
class ViewSettings:
    """What the view shows; ``None`` means "automatic for this lattice size"."""

    show_springs: bool | None = None
    move_points: bool | None = None
    particle_scale: float = 1.0
    color_by: str | None = None
    picture_rate: float = DEFAULT_FPS
    """Most pictures per second of a lattice drawn as a picture (``app.web.frames``)."""

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
        self._scales: dict[str, colours.ColourScale] = {}
        self._axis = 1
        self.colour_bar = ColourBar(server)
        self._bar_shown: tuple | None = None
        self._bar_time = 0.0
        self._image: FieldImage | None = None
        self._dirty = True
        self.frames_drawn = 0
        self.last_positions: np.ndarray | None = None
        self.model: Model | None = None
        self.picture_wanted: Callable[[], object] | None = None
        """Called (from viser's event loop) when a page is ready for a picture newer than the
        last one made: the app draws its newest frame again."""

    def _picture_wanted(self) -> None:
        if self.picture_wanted is not None:
            self.picture_wanted()

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
        self._bar_shown = None
        self._image = None
        self._scales = {}
        moved = ((frame.positions - model.rest_positions) ** 2).sum(axis=0)
        self._axis = int(np.argmax(moved)) if moved.max() > 0 else model.dim - 1
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
            if uses_image(model, self.settings.points_move(model)):
                self._image = FieldImage(self.server, model, self._particle_colors(frame),
                                         on_ready=self._picture_wanted)
                self._image.frame = frame
            else:
                shown = xyz if self.settings.points_move(model) else to_xyz(model.rest_positions)
                self._points = scene.add_point_cloud(
                    "/lattice/particles", shown, self._particle_colors(frame),
                    point_size=self._base_diameter(model), point_shape="square",
                    precision="float32", point_shading="flat",
                )
            if self.selection.size:
                self._selection_points = scene.add_point_cloud(
                    "/lattice/selection", xyz[self.selection[self.selection < len(xyz)]], SELECTED,
                    point_size=1.5 * model.spacing, point_shape="circle", precision="float32",
                    point_shading="flat",
                )
        if self.settings.springs_on(model):
            self._springs = scene.add_line_segments(
                "/lattice/springs", self._spring_points(model, frame.positions),
                self._spring_colors(frame), thickness=0.05 * model.spacing,
            )
        if self._bar_shown is None:  # nothing coloured by a scale: no colour bar
            self.colour_bar.hide()

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
        if self._image is not None:
            self._image.max_fps = self.settings.picture_rate
        if self._image is not None:
            # a paused lattice gets one picture of each new state, not one per redraw
            new_state = frame is not self._image.frame
            if (new_state and self._image.due_now()) or (not frame.playing and new_state):
                self._image.show(self._particle_colors(frame), force=True)
                self._image.frame = frame
            else:
                self._image.pacer.sync_pages()  # a page that just came gets its picture now
        if self._selection_points is not None:
            self._selection_points.points = xyz[self.selection[self.selection < len(xyz)]]
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
        values = None
        if mode == "displacement":
            values = frame.positions[:, self._axis] - model.rest_positions[:, self._axis]
        elif mode == "speed" and frame.velocities is not None:
            values = np.linalg.norm(frame.velocities, axis=1)
        if values is not None:
            scale = self._colour_scale(mode, model)
            scale.observe(values, frame.time)
            result = colours.scheme(mode).colour(values, scale, lines=True)
            self._draw_colour_bar(mode, model, scale)
        elif mode == "mass":
            masses = model.masses.reshape(-1)
            result = colours.MAGNITUDE.map(masses / masses.max(), 1.0)
        else:
            result = np.empty((n, 3), np.uint8)
            result[:] = PARTICLE
        if self._spheres is not None or n <= SPHERE_LIMIT:
            result[self.selection[self.selection < n]] = SELECTED  # a stale pick is not drawn
        return result

    def _colour_scale(self, mode: str, model: Model) -> colours.ColourScale:
        """The scale of ``mode``'s scheme for this lattice (new after a rebuild)."""
        if mode not in self._scales:
            quantity = colours.scheme(mode)
            unit = model.spacing if mode in ("displacement", "speed") else 1.0
            self._scales[mode] = colours.make_scale(quantity.scale, unit, quantity.signed,
                                                    floor=1e-9 * unit)
            self._bar_shown = None
        return self._scales[mode]

    def colour_label(self, mode: str, model: Model) -> str:
        """The colour bar's title: quantity (the displacement's component) and units."""
        quantity = colours.scheme(mode)
        if mode == "displacement":
            return f"displacement u_{'xyz'[self._axis]} ({quantity.units})"
        return quantity.title()

    def _draw_colour_bar(self, mode: str, model: Model, scale: colours.ColourScale) -> None:
        """The colour bar (``app.web.colour_bar``), redrawn when the scale's numbers change (at
        most twice a second)."""
        shown = (mode, f"{scale.limit:.2g}")
        now = time.monotonic()
        if shown == self._bar_shown or (self._bar_shown is not None
                                        and now - self._bar_time < 0.5):
            return
        label = self.colour_label(mode, model)
        picture = colours.colour_bar(colours.scheme(mode), scale, label, lines=True)
        self.colour_bar.show(picture, model, phone_picture(colours.scheme(mode), scale, label,
                                                           lines=True))
        self._bar_shown, self._bar_time = shown, now

    @staticmethod
    def _spring_points(model: Model, positions: np.ndarray) -> np.ndarray:
        ends = np.concatenate([to_xyz(positions), to_xyz(model.anchor_positions)])
        return ends[model.springs]

    def _spring_colors(self, frame: Frame) -> np.ndarray:
        """Springs coloured by strain - rest strain on the strain scheme's scale; the colour bar
        shows it when the particles carry no colour."""
        model = frame.model
        strain = colours.scheme("strain")
        if frame.strains is None:
            relaxed = colours.colour_fractions(np.full(1, 0.5 if strain.signed else 0.0),
                                               strain.lines.table())[0]
            return np.broadcast_to(relaxed, (model.n_springs, 2, 3))
        values = frame.strains - (model.spacing - model.rest_length) / model.rest_length
        scale = self._colour_scale("strain", model)
        scale.observe(values, frame.time)
        if self.settings.coloring(model) not in ("displacement", "speed"):
            self._draw_colour_bar("strain", model, scale)
        per_spring = strain.colour(values, scale, lines=True)
        return np.repeat(per_spring[:, None, :], 2, axis=1)


def laptop_fit(model: Model, fov: float, width: float, height: float
               ) -> tuple[tuple[float, float, float], tuple[float, float, float],
                          tuple[float, float, float]]:
    """``camera_fit`` for a view ``width`` x ``height`` CSS pixels at least ``NARROW`` wide: the
    lattice left of the panel, above the floating colour bar."""
    return camera_fit(model, fov, width / height, right=min(0.5, PANEL_WIDTH / width),
                      bottom=min(0.4, OVERLAY_HEIGHT / height), bar_in_scene=False)


VIEW_FOV = math.radians(20.0)
"""Vertical field of view of every page's camera (viser's default is 75 degrees): a wide one
draws the particles near a laptop view's left edge as eggs (a sphere off the axis of a
perspective view projects to an ellipse stretched by up to 1 / cos of its angle off the axis;
75 degrees puts the left edge of a 1366x768 view 54 degrees off it, 1.7 times longer than wide; 20
degrees 17 degrees off it, 5 % longer than wide)."""
PANEL_WIDTH = 420
"""CSS pixels of the page's control panel (viser's "large" controls) at the right edge."""
NARROW = 700
"""Views narrower than this (phones): the panel floats over the lower part of the view."""
PHONE_PANEL_SHARE = 0.1
"""Share of a narrow view's height under the panel's title bar: a phone's panel starts folded
(``app.web.phone``), and the lattice with its colour bar fills the view above it."""


def box_fit(left: float, right: float, bottom: float, top: float, fov: float, aspect: float,
            covered_right: float = 0.0, covered_bottom: float = 0.0
            ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(position, look_at) of a camera looking straight down -z that shows the box
    [left, right] x [bottom, top] (m, in the plane z = 0) with a small margin in the part of
    the view a panel leaves: ``covered_right`` and ``covered_bottom`` are the fractions of the
    view's width (right) and height (bottom) under it; ``fov`` vertical (radians), ``aspect``
    width / height."""
    free_x, free_y = max(0.2, 1.0 - covered_right), max(0.2, 1.0 - covered_bottom)
    tangent = math.tan(fov / 2)
    distance = max((right - left) / (2 * tangent * aspect * free_x),
                   (top - bottom) / (2 * tangent * free_y)) / 0.9
    x = (left + right) / 2 + distance * tangent * aspect * (1.0 - free_x)
    y = (top + bottom) / 2 - distance * tangent * (1.0 - free_y)
    return (x, y, distance), (x, y, 0.0)


def camera_fit(model: Model, fov: float, aspect: float, right: float = 0.0, bottom: float = 0.0,
               bar_in_scene: bool = True
               ) -> tuple[tuple[float, float, float], tuple[float, float, float],
                          tuple[float, float, float]]:
    """(position, look_at, up) of a camera that shows the whole lattice, its walls and (with
    ``bar_in_scene``: a phone's) the colour bar under it in the part of the view the panel
    leaves, with a small margin (a lattice under gravity: its sagged equilibrium, ``sag``).
    ``right`` and ``bottom``: the fractions of the view's width
    (on the right) and height (at the bottom) under the panel (or the floating colour bar);
    ``fov``: the vertical field of view (radians); ``aspect``: width / height of the view.
    Planar lattices, and every lattice on a phone (where a tilted view would shrink it), are
    seen straight from above; 3-D ones on a laptop from the front and above (about 40 degrees)
    so their out-of-plane motion shows."""
    a = model.spacing
    left, right_sag, down, up = sag(model)
    width = (model.nx + 1) * a + left + right_sag
    top = (model.ny + 1) * a / 2 + up
    lowest = -(model.ny + 1) * a / 2 - down
    if bar_in_scene:
        lowest = -(model.ny - 1) * a / 2 - down - 1.5 * a - bar_width(model) * BAR_ASPECT
        width = max(width, bar_width(model))
    free_x, free_y = max(0.2, 1.0 - right), max(0.2, 1.0 - bottom)
    tangent = math.tan(fov / 2)
    distance = max(width / (2 * tangent * aspect * free_x),
                   (top - lowest) / (2 * tangent * free_y)) / 0.9
    # the lattice's centre (sagged) at the centre of the free part of the view
    shift_x = distance * tangent * aspect * (1.0 - free_x) + (right_sag - left) / 2
    shift_y = -distance * tangent * (1.0 - free_y)
    centre = ((top + lowest) / 2 + shift_y, shift_x)
    if model.dim == 3 and not bar_in_scene:
        distance *= 1.15
        return ((centre[1], centre[0] - 0.75 * distance, 0.65 * distance),
                (centre[1], centre[0], 0.0), (0.0, 0.0, 1.0))
    return (centre[1], centre[0], distance), (centre[1], centre[0], 0.0), (0.0, 1.0, 0.0)
