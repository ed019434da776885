"""A run as one HTML file: the 3-D lattice as on the page, played from what was simulated or
recorded, that opens from disk (file://) in any browser with no network and no server.

The frames come from the movie's frame sources (``app.movie.frames``: a scene's fresh run, a
running simulation, a ``.rrd`` recording).  Each frame updates a viser scene (small lattices:
spheres and springs, springs coloured by strain as on the page; large ones, and 3-D ones above
``SPHERE_LIMIT`` particles: the field picture, one block of pixels per particle, on the
quantity's colour scale) and viser records the updates with the pauses between them; its
player, inlined with the recording in one page (``app.movie.viser_page``), plays them: one
simulated second per second, play/pause, a time slider and a speed menu.  Over it we lay the
title (scene, integrator, dt), the simulated time, the colour bar whose numbers follow the
player, and an "About this run" panel with the read-me (``app.movie.html_readme``).

Size: small lattices send positions and colours (a few kB a frame, ``SMALL_FPS`` frames per
simulated second); large ones a JPEG picture of at most ``PICTURE_SIZE`` pixels
(``LARGE_FPS`` a second), so the flagship's 150 s stays under 25 MB (docs/recording.md,
"Sharing with students": measured by benchmarks/html_size.py).  Memory holds the encoded
updates (the size of the file) and one frame.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from app.colours import ColourScale, make_scale, scheme
from app.movie import viser_page
from app.movie.frames import FrameSource, State
from app.movie.html_overlay import overlay
from app.movie.html_readme import readme_html
from app.movie.options import MovieOptions
from app.recording.style import nice_number
from sim.storage.files import AtomicFile

SPHERE_LIMIT = 2500
"""Up to this many particles: spheres and springs (as on the page); above: the field picture."""
SMALL_FPS = 25.0
"""Frames per simulated second of small lattices by default."""
LARGE_FPS = 5.0
"""Pictures per simulated second of large lattices by default (the flagship: 751 pictures)."""
PICTURE_SIZE = (400, 400)
"""Largest field picture (pixels) by default: the flagship's 682x383 particles in blocks of
2x2, each showing its largest value with its sign (short waves neither alias nor average
away)."""
JPEG_QUALITY = 70
MAX_FRAMES = 4000
PARTICLE = (60, 60, 70)
ANCHOR = (120, 90, 60)

OnFrame = Callable[[int, int], bool]


@dataclasses.dataclass(frozen=True)
class HtmlPage:
    """A written page: its path, frames and the simulated seconds it shows."""

    path: Path
    frames: int
    start: float
    end: float

    def describe(self) -> str:
        """Its length in words, for the command line."""
        return (f"{self.frames} frames showing t = {self.start:.2f} s to {self.end:.2f} s; it "
                f"plays in {self.end - self.start:.1f} s at 1x")


def html_options(options: MovieOptions, model: Any) -> MovieOptions:
    """``options`` with the HTML defaults for ``model`` filled in: fps = frames per simulated
    second, size = the largest field picture."""
    small = model.n_particles <= SPHERE_LIMIT
    return dataclasses.replace(
        options, fps=options.fps or (SMALL_FPS if small else LARGE_FPS),
        size=options.size or PICTURE_SIZE, max_frames=options.max_frames or MAX_FRAMES)


def frames_for(duration: float, fps: float) -> int:
    """Frames that show ``duration`` simulated seconds at ``fps`` frames a second (ends
    included)."""
    return max(2, round(duration * fps) + 1)


def _xyz(positions: np.ndarray) -> np.ndarray:
    xyz = np.zeros((positions.shape[0], 3), np.float32)
    xyz[:, : positions.shape[1]] = positions
    return xyz


class LatticeScene:
    """The viser scene of one lattice, updated frame by frame (see the module docstring)."""

    def __init__(self, server: Any, model: Any, axis: int, picture: tuple[int, int],
                 start_limits: dict[str, float], exaggeration: float = 1.0) -> None:
        self.server = server
        self.model = model
        self.axis = axis
        self.exaggeration = exaggeration
        """3-D lattices: heights (z) drawn this many times larger, as in movies."""
        self.small = model.n_particles <= SPHERE_LIMIT
        if self.small:
            self.quantity = "displacement" if model.dim == 3 else "strain"
        else:
            self.quantity = "displacement"
        self.scheme = scheme(self.quantity)
        floor = 1e-9 * model.spacing if self.quantity == "displacement" else 1e-9
        self.scale: ColourScale = make_scale(self.scheme.scale,
                                             max(start_limits[self.quantity], floor),
                                             self.scheme.signed, floor)
        width, height = picture
        self.block = max(1, math.ceil(max(model.nx / width, model.ny / height)))
        self._nodes: dict[str, Any] = {}
        self._draw_walls()

    # -- static parts --

    def _draw_walls(self) -> None:
        model, scene = self.model, self.server.scene
        a = model.spacing
        rest = model.rest_positions
        left, right = rest[:, 0].min() - a, rest[:, 0].max() + a
        bottom, top = rest[:, 1].min() - a, rest[:, 1].max() + a
        corners = np.array([[left, bottom, 0], [right, bottom, 0], [right, top, 0],
                            [left, top, 0]], np.float32)
        scene.add_line_segments("/lattice/walls", np.stack([corners, np.roll(corners, -1, 0)], 1),
                                ANCHOR, thickness=0.15 * a)
        if self.small:
            scene.add_point_cloud("/lattice/anchors", _xyz(model.anchor_positions), ANCHOR,
                                  point_size=0.2 * a, point_shape="square", precision="float32",
                                  point_shading="flat")

    def camera(self, aspect: float = 16 / 9) -> str:
        """The initial camera: the whole lattice, between the title (top) and the colour bar
        and player (bottom); planar lattices from above, 3-D ones from the front and above.
        Returns the page's script that fits a planar lattice to the window's own shape
        (``viser_page.fit_camera_script``; "" for 3-D)."""
        model = self.model
        rest = model.rest_positions
        a = model.spacing
        centre = ((rest[:, 0].min() + rest[:, 0].max()) / 2, (rest[:, 1].min() + rest[:, 1].max()) / 2)
        width = float(np.ptp(rest[:, 0])) + 3 * a
        height = float(np.ptp(rest[:, 1])) + 3 * a
        fov = math.radians(50.0)
        tangent = math.tan(fov / 2)
        free_y = 0.62  # title above, colour bar and player below
        distance = max(width / (2 * tangent * aspect * 0.95), height / (2 * tangent * free_y))
        share = -0.06  # a little below the centre of the view
        shift = share * 2 * tangent * distance
        initial = self.server.initial_camera
        initial.fov = fov
        if model.dim == 3:
            distance *= 1.15
            initial.position = (centre[0], centre[1] + shift - 0.75 * distance, 0.65 * distance)
            initial.look_at = (centre[0], centre[1] + shift, 0.0)
            initial.up = (0.0, 0.0, 1.0)
            script = ""
        else:
            initial.position = (centre[0], centre[1] + shift, distance)
            initial.look_at = (centre[0], centre[1] + shift, 0.0)
            initial.up = (0.0, 1.0, 0.0)
            script = viser_page.fit_camera_script(centre, width, height, fov, free_y, share)
        initial.near = 0.01 * distance
        initial.far = 10.0 * distance
        return script

    # -- per frame --

    def values(self, state: State) -> np.ndarray:
        model = self.model
        if self.quantity == "strain":
            rest_strain = (model.spacing - model.rest_length) / model.rest_length
            return np.asarray(state.strains) - rest_strain
        return state.positions[:, self.axis] - model.rest_positions[:, self.axis]

    def show(self, state: State) -> float:
        """Update the scene to ``state``; returns the colour scale's limit in use."""
        values = self.values(state)
        self.scale.observe(values, state.time)
        if self.small:
            self._show_small(state, values)
        else:
            self._show_picture(values)
        return self.scale.limit

    def _show_small(self, state: State, values: np.ndarray) -> None:
        model, scene = self.model, self.server.scene
        xyz = _xyz(state.positions)
        if model.dim == 3 and self.exaggeration != 1.0:
            rest = model.rest_positions[:, 2]
            xyz[:, 2] = rest + self.exaggeration * (xyz[:, 2] - rest)
        ends = np.concatenate([xyz, _xyz(model.anchor_positions)])
        segments = ends[model.springs]
        if self.quantity == "strain":
            spring_colours = self.scheme.colour(values, self.scale, lines=True)
            particle_colours = np.tile(np.array(PARTICLE, np.uint8), (model.n_particles, 1))
        else:
            particle_colours = self.scheme.colour(values, self.scale, lines=True)
            spring_colours = np.broadcast_to(np.array((150, 150, 150), np.uint8),
                                             (model.n_springs, 3))
        spring_colours = np.ascontiguousarray(np.repeat(spring_colours[:, None, :], 2, axis=1))
        if "particles" not in self._nodes:
            import trimesh

            sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.5)
            masses = model.masses.reshape(-1)
            self._nodes["particles"] = scene.add_batched_meshes_simple(
                "/lattice/particles", np.asarray(sphere.vertices, np.float32),
                np.asarray(sphere.faces, np.uint32),
                batched_wxyzs=np.tile(np.array([1.0, 0, 0, 0], np.float32), (len(xyz), 1)),
                batched_positions=xyz,
                batched_scales=(0.35 * model.spacing * np.cbrt(masses / masses.mean())
                                ).astype(np.float32),
                batched_colors=particle_colours, cast_shadow=False, receive_shadow=False)
            self._nodes["springs"] = scene.add_line_segments(
                "/lattice/springs", segments, spring_colours, thickness=0.05 * model.spacing)
            return
        self._nodes["particles"].batched_positions = xyz
        if self.quantity != "strain":
            self._nodes["particles"].batched_colors = particle_colours
        self._nodes["springs"].points = segments
        self._nodes["springs"].colors = spring_colours

    def _show_picture(self, values: np.ndarray) -> None:
        model = self.model
        block = self.block
        grid = values.reshape(model.ny, model.nx)[::-1]  # top row first
        if block > 1:
            rows, columns = model.ny // block, model.nx // block
            blocks = grid[: rows * block, : columns * block].reshape(
                rows, block, columns, block).transpose(0, 2, 1, 3).reshape(rows, columns, -1)
            pick = np.abs(blocks).argmax(axis=2)
            grid = np.take_along_axis(blocks, pick[:, :, None], axis=2)[:, :, 0]
        picture = np.ascontiguousarray(self.scheme.colour(grid, self.scale))
        if "picture" in self._nodes:
            self._nodes["picture"].image = picture
            return
        rest = model.rest_positions
        centre = ((rest[:, 0].min() + rest[:, 0].max()) / 2,
                  (rest[:, 1].min() + rest[:, 1].max()) / 2, 0.0)
        self._nodes["picture"] = self.server.scene.add_image(
            "/lattice/particles", picture, render_width=model.nx * model.spacing,
            render_height=model.ny * model.spacing, format="jpeg", jpeg_quality=JPEG_QUALITY,
            position=centre, cast_shadow=False, receive_shadow=False)


def _colour_words(lattice: LatticeScene, label: str) -> str:
    scale = lattice.scale
    if lattice.quantity == "strain":
        what = ("Springs are coloured by their strain minus the strain at rest: blue compressed, "
                "grey as at rest, red stretched.")
    elif lattice.small:
        what = (f"Particles are coloured by their {label}: blue negative, grey zero, red "
                "positive.")
    else:
        what = (f"The picture shows the {label} of every particle (the lattice seen from above, "
                "one block of pixels per particle or per few particles, each block its largest "
                "value): blue negative, white zero, red positive.")
    return (f"{what} The colour bar's numbers are those of the scale in use at the moment shown "
            f"({scale.describe()}): the scale follows the field, so colours of two moments are "
            "not comparable, read the bar." if scale.follows else
            f"{what} One scale for the whole run ({scale.describe()}).")


def write_html(source: FrameSource, path: Path, options: MovieOptions, *,
               command: str | None = None, start_time: float = 0.0,
               on_frame: OnFrame | None = None) -> HtmlPage:
    """Play ``source``'s frames into a viser scene and write the page to ``path`` (atomically).
    ``start_time``: added to the source's times (a run continued from a running simulation);
    ``on_frame(done, planned)`` returning False stops with ``MovieCancelled``."""
    from tqdm import tqdm

    from app.movie.render import MovieCancelled, cancel_within_frames

    model = source.model
    done = [0]
    watch = cancel_within_frames(source, on_frame, done)
    scene = source.scene
    colour = "strain" if model.n_particles <= SPHERE_LIMIT and model.dim == 2 else "displacement"
    scales = source.scales(colour, watch)
    limits = {"strain": scales.strain or 1e-3, "displacement": scales.field or model.spacing}
    if model.dim == 3 and model.n_particles <= SPHERE_LIMIT:
        limits["displacement"] = scales.height or scales.field or model.spacing
    axis = 2 if model.dim == 3 and model.n_particles <= SPHERE_LIMIT else scales.axis
    server = viser_page.start_server()
    try:
        exaggeration = 1.0
        if model.dim == 3 and model.n_particles <= SPHERE_LIMIT:
            width = (max(model.nx, model.ny) + 1) * model.spacing
            exaggeration = options.exaggeration or nice_number(
                0.08 * width / max(limits["displacement"], 1e-12))
        lattice = LatticeScene(server, model, axis, options.size, limits, exaggeration)
        camera_script = lattice.camera()
        serializer = server.get_scene_serializer()
        times: list[float] = []
        shown_limits: list[float] = []
        bar = tqdm(total=source.frames, unit="frame", disable=not options.progress,
                   dynamic_ncols=True, desc="html")
        try:
            for count, state in enumerate(source.states(False, lattice.quantity == "strain"),
                                          start=1):
                if times:
                    serializer.insert_sleep(max(0.0, state.time - times[-1]))
                shown_limits.append(lattice.show(state))
                times.append(state.time)
                bar.update(1)
                done[0] = count
                if on_frame is not None and not on_frame(count, source.frames):
                    raise MovieCancelled(f"cancelled after {count} of {source.frames} frames")
        finally:
            bar.close()
        if not times:
            raise ValueError("no frames to write")
        label = ("strain - rest strain (dimensionless)" if lattice.quantity == "strain" else
                 f"displacement u_{'xyz'[axis]} (m)")
        integrator = getattr(getattr(source, "simulation", None), "integrator", scene.integrator)
        dt = getattr(getattr(source, "simulation", None), "dt", scene.dt)
        readme = readme_html(
            scene, integrator=integrator, dt=dt, start=start_time + times[0],
            end=start_time + times[-1], frames=len(times), colours=_colour_words(lattice, label),
            command=command, source=source.summary)
        head, body = overlay(scene, integrator, dt, lattice, label,
                             [t - times[0] for t in times], shown_limits,
                             start_time + times[0], readme)
        document = viser_page.page(serializer, camera_script + head, body)
    finally:
        viser_page.stop_server(server)
    with AtomicFile(path, overwrite=True) as output:
        Path(output.library_path).write_text(document, encoding="utf-8")
    return HtmlPage(path, len(times), start_time + times[0], start_time + times[-1])


def render_html(scene_or_simulation: Any, path: str | Path, options: MovieOptions | None = None,
                on_frame: OnFrame | None = None, command: str | None = None,
                **changes: Any) -> HtmlPage:
    """Write ``scene_or_simulation`` (a ``sim.Scene``, a running ``sim.Simulation``, or the
    path of a ``.rrd`` recording) as one HTML file at ``path`` and return the path.  Options
    (``MovieOptions``, ``changes`` override its fields): fps = frames per simulated second
    (default ``SMALL_FPS`` or ``LARGE_FPS``), frames, duration, size = the largest field
    picture (default ``PICTURE_SIZE``), integrator, dt, progress.  ``command``: the command
    line, for the read-me."""
    from app.movie.render import _source

    path = Path(path)
    if path.suffix.lower() != ".html":
        raise ValueError(f"the page must end in .html, got {path.name!r}")
    options = dataclasses.replace(options or MovieOptions(), **changes)
    probe = _source(scene_or_simulation, dataclasses.replace(options, frames=2)) \
        if not isinstance(scene_or_simulation, (str, Path)) else None
    model = probe.model if probe is not None else None
    if model is None:  # a recording: its lattice decides the defaults
        source = _source(scene_or_simulation, dataclasses.replace(options, frames=None))
        model = source.model
    options = html_options(options, model).checked()
    duration = options.duration
    if duration is None:
        duration = (probe.scene.duration if probe is not None
                    else float(source.times[-1] - source.times[0]))
    frames = options.frames or min(options.max_frames or MAX_FRAMES,
                                   frames_for(duration, options.fps))
    source = _source(scene_or_simulation, dataclasses.replace(options, frames=frames))
    return write_html(source, path, options, command=command, on_frame=on_frame)
