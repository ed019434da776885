"""Scenes: named presets (the paper's configurations) and the scene file format.

A scene is data: a ``Model`` plus the initial displacements and velocities, a default integrator
and time step, and a description.  ``build(name, **overrides)`` makes a preset; ``save`` / ``load``
write and read a scene as a human-editable TOML file (arrays that are not uniform go in a ``.npz``
file beside it, named in the TOML); ``to_bytes`` / ``from_bytes`` do the same with the content of
one file (a ``.toml``, or a ``.zip`` of the TOML and its ``.npz``), for downloads and uploads.

Reading is defensive, as scene files may come from anyone: only regular files of bounded size
(``MAX_SCENE_FILE_BYTES``, ``MAX_UPLOAD_BYTES``), an array file only beside the TOML, optionally
only inside a given directory (``load(path, within=...)``), and every ``.npz`` member's shape,
dtype and unpacked size checked against the lattice before it is read (``read_arrays``).

Presets (units: metres, kilograms, seconds; stiffness 35 N/m is the paper's "35 % of maximum"):

=============== ================================================================================
single          one particle held by 4 springs (paper Fig. 3), displaced diagonally
square          2x2, the paper's four particles, one displaced (Fig. 5)
chain           5 in a line, the middle one displaced along the chain (Fig. 4, longitudinal)
grid            12x8 lattice (Fig. 2), one particle near the centre displaced
ionic           12x8 checkerboard of heavy (4 kg) and light (1 kg) particles (Fig. 7)
catenary        15x10 under gravity with dashpots, settling into catenaries (Fig. 8)
interference    682x383, the middle particles of the left and right boundaries displaced in
                opposite directions, velocity Verlet, pre-tensioned (Figs. 10-14)
membrane        24x24 drum skin in 3-D, pre-tensioned, a bump pushed out of the plane
=============== ================================================================================
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
import stat
import tomllib
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sim.integrators import check_integrator_name, check_precision
from sim.model import Model, ModelError, _whole_number, check_size

FORMAT_VERSION = 1


class SceneError(ValueError):
    """A scene could not be built, read or written (the message says why)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    """A model with its initial condition and recommended integrator settings.

    ``initial_positions`` / ``initial_velocities`` are (n_particles, dim) arrays (m, m/s); they
    default to the rest lattice, at rest.
    """

    name: str
    model: Model
    description: str = ""
    integrator: str = "rk4"
    dt: float = 0.01
    initial_positions: np.ndarray = None  # type: ignore[assignment]
    duration: float = 20.0
    """Simulated seconds worth watching (the default length of `run` and `record`)."""
    initial_velocities: np.ndarray = None  # type: ignore[assignment]
    precision: str = "float64"
    """Floating-point precision of the simulation's state and kernels: "float64" or "float32"."""

    def __post_init__(self) -> None:
        shape = (self.model.n_particles, self.model.dim)
        positions = (
            self.model.rest_positions.copy()
            if self.initial_positions is None
            else _checked_array("initial_positions", self.initial_positions, shape)
        )
        velocities = (
            np.zeros(shape)
            if self.initial_velocities is None
            else _checked_array("initial_velocities", self.initial_velocities, shape)
        )
        positions.setflags(write=False)
        velocities.setflags(write=False)
        object.__setattr__(self, "initial_positions", positions)
        object.__setattr__(self, "initial_velocities", velocities)
        object.__setattr__(self, "integrator", check_integrator_name(self.integrator))
        try:
            object.__setattr__(self, "precision", check_precision(self.precision).__name__)
        except ValueError as error:
            raise SceneError(str(error)) from None
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise SceneError(f"dt must be a positive number of seconds, got {self.dt!r}")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise SceneError(f"duration must be a positive number of seconds, got {self.duration!r}")

    def with_displacement(self, particle: int, displacement: tuple[float, ...]) -> Scene:
        """A copy with one more particle displaced from its initial position (m)."""
        positions = self.initial_positions.copy()
        positions[particle, : len(displacement)] += displacement
        return dataclasses.replace(self, initial_positions=positions)

    def summary(self) -> str:
        return f"{self.name}: {self.model.describe()}; {self.integrator}, dt={self.dt:g} s"


def _checked_array(name: str, value: Any, shape: tuple[int, int]) -> np.ndarray:
    array = np.array(value, dtype=float)
    if array.shape != shape:
        raise SceneError(f"{name} must have shape {shape} (n_particles, dim), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise SceneError(f"{name} contains NaN or infinite values")
    return array


# --- presets ---------------------------------------------------------------------------------------

PAPER_STIFFNESS = 35.0
"""The paper's default stiffness: 35 % of a maximum of 100 N/m."""


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named recipe: default model parameters plus how to set the initial condition."""

    name: str
    description: str
    parameters: dict[str, Any]
    integrator: str
    dt: float
    initial: Callable[[Model], tuple[np.ndarray, np.ndarray]]
    duration: float = 20.0


def _rest(model: Model) -> tuple[np.ndarray, np.ndarray]:
    return model.rest_positions.copy(), np.zeros((model.n_particles, model.dim))


def _displace(picks: Callable[[Model], list[tuple[int, tuple[float, ...]]]]):
    def initial(model: Model) -> tuple[np.ndarray, np.ndarray]:
        positions, velocities = _rest(model)
        for particle, displacement in picks(model):
            positions[particle, : len(displacement)] += displacement
        return positions, velocities

    return initial


def _index(model: Model, column: int, row: int) -> int:
    return row * model.nx + column


def _centre(model: Model) -> int:
    return _index(model, model.nx // 2, model.ny // 2)


def _membrane_bump(model: Model) -> tuple[np.ndarray, np.ndarray]:
    positions, velocities = _rest(model)
    if model.dim == 3:
        rest = model.rest_positions
        half_width = (max(model.nx, model.ny) + 1) * model.spacing / 2
        radius_squared = (rest[:, 0] ** 2 + rest[:, 1] ** 2) / (0.25 * half_width) ** 2
        positions[:, 2] = 0.3 * model.spacing * np.exp(-radius_squared)
    return positions, velocities


def _two_sources(model: Model) -> list[tuple[int, tuple[float, ...]]]:
    """The middle particles of the left and right edges displaced in opposite directions, or,
    behind an absorbing layer, the first particles inside it."""
    inset = model.sponge_width if model.boundary == "absorbing" else 0
    inset = min(inset, (model.nx - 1) // 2)
    return [
        (_index(model, inset, model.ny // 2), (0.0, 0.5 * model.spacing)),
        (_index(model, model.nx - 1 - inset, model.ny // 2), (0.0, -0.5 * model.spacing)),
    ]


def chain_mode_frequency(mode: int, particles: int, stiffness_across: float, mass: float) -> float:
    """Frequency (Hz) of normal mode ``mode`` (1, 2, ...) of a chain of ``particles`` equal
    masses between fixed walls, for a spring stiffness ``stiffness_across`` (N/m; k for
    longitudinal motion, T/a for transverse): 2 sqrt(s/m) sin(n pi / (2 (N + 1))) / (2 pi)."""
    omega = 2.0 * math.sqrt(stiffness_across / mass) * math.sin(
        mode * math.pi / (2 * (particles + 1))
    )
    return omega / (2.0 * math.pi)


# the resonance preset: a 12-particle chain driven along its length at its third mode
_RESONANCE_FREQUENCY = chain_mode_frequency(3, 12, PAPER_STIFFNESS, 1.0)
# the bandgap preset: the 4 kg / 1 kg ionic chain, band edges sqrt(2k/M) and sqrt(2k/m) (rad/s)
_ACOUSTIC_TOP = math.sqrt(2 * PAPER_STIFFNESS / 4.0) / (2 * math.pi)
_OPTICAL_BOTTOM = math.sqrt(2 * PAPER_STIFFNESS / 1.0) / (2 * math.pi)
_OPTICAL_TOP = math.sqrt(2 * PAPER_STIFFNESS * (1 / 1.0 + 1 / 4.0)) / (2 * math.pi)


def _ionic_masses(nx: int, ny: int, heavy: float = 4.0, light: float = 1.0) -> np.ndarray:
    rows, columns = np.indices((ny, nx))
    return np.where((rows + columns) % 2 == 0, heavy, light).astype(float)


PRESETS: dict[str, Preset] = {
    preset.name: preset
    for preset in [
        Preset(
            "single", "One particle held by four springs to the walls (paper Fig. 3).",
            dict(nx=1, ny=1, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(0, (0.3 * m.spacing, 0.2 * m.spacing))]),
        ),
        Preset(
            "square", "Four particles in a square; one is displaced and passes its energy on "
            "(paper Fig. 5).",
            dict(nx=2, ny=2, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(0, (0.3 * m.spacing, 0.3 * m.spacing))]),
        ),
        Preset(
            "chain", "Five particles in a line between two walls; the middle one is pushed "
            "along the chain (longitudinal waves; displace along y for transverse ones, Fig. 4).",
            dict(nx=5, ny=1, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(_index(m, m.nx // 2, 0), (0.3 * m.spacing, 0.0))]),
        ),
        Preset(
            "grid", "A 12x8 lattice (paper Fig. 2); a particle near the centre is displaced "
            "and the disturbance spreads to its neighbours (Fig. 6).",
            dict(nx=12, ny=8, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(_centre(m), (0.4 * m.spacing, 0.3 * m.spacing))]),
        ),
        Preset(
            "ionic", "A 12x8 ionic crystal: a checkerboard of heavy (4 kg) and light (1 kg) "
            "particles; a heavy one is displaced and the light sublattice rings (paper Fig. 7).",
            dict(nx=12, ny=8, stiffness=PAPER_STIFFNESS, mass="ionic"), "rk4", 0.01,
            _displace(
                lambda m: [(_index(m, 2 * (m.nx // 4), 2 * (m.ny // 4)), (0.3 * m.spacing, 0.0))]
            ),
        ),
        Preset(
            "catenary", "A 15x10 lattice (150 particles) under gravity with dashpots: it sags "
            "and settles into catenary curves (paper Fig. 8).",
            dict(nx=15, ny=10, stiffness=PAPER_STIFFNESS, gravity=9.81, damping=2.0),
            "verlet", 0.01, _rest, duration=30.0,
        ),
        Preset(
            "interference", "The paper's continuum-limit run (Figs. 10-14): 682x383 = 261,206 "
            "particles, the middle particles of the left and right boundaries displaced in "
            "opposite directions; pre-tension (L = 0.8 a) lets the disturbance spread in 2-D.",
            # velocity Verlet at dt = 0.02 s keeps the energy balance within 1 % over 150 s at
            # less cost than RK4 at 0.05 s, which loses 60 % of the energy by numerical damping
            # of the short waves (README, "Speed against accuracy")
            dict(nx=682, ny=383, stiffness=PAPER_STIFFNESS, rest_length=0.8), "verlet", 0.02,
            _displace(_two_sources),
            duration=150.0,  # longitudinal fronts meet near t = 58 s, transverse ones near 130 s
        ),
        Preset(
            "interference-open", "The interference run with absorbing walls: a 30-particle "
            "sponge along every wall takes the waves out, so the pattern of the two sources "
            "(displaced just inside it) is seen without wall reflections.",
            dict(nx=682, ny=383, stiffness=PAPER_STIFFNESS, rest_length=0.8,
                 boundary="absorbing", sponge_width=30),
            # the layer's splitting adds to Verlet's error: at dt = 0.02 s the energy balance
            # is off by 1.08 % over 150 s, at 0.015 s by 0.61 % (second order)
            "verlet", 0.015, _displace(_two_sources), duration=150.0,
        ),
        Preset(
            "resonance", "A chain of 12 particles with light drag, its first particle pushed "
            f"back and forth along the chain at the third mode's frequency (f3 = "
            f"{_RESONANCE_FREQUENCY:.4f} Hz): the amplitude builds up into a standing wave with "
            "3 loops.  Change the driver's frequency to see the response fall off the resonance.",
            dict(nx=12, ny=1, stiffness=PAPER_STIFFNESS, drag=0.1,
                 driver=dict(column=0, row=0, direction="x", amplitude=0.02,
                             frequency=_RESONANCE_FREQUENCY, kind="force", ramp=5.0)),
            "verlet", 0.01, _rest, duration=60.0,
        ),
        Preset(
            "bandgap", "An ionic chain (4 kg and 1 kg alternating, 100 particles, absorbing at "
            f"the right end) driven along its length at 0.95 Hz, inside the band gap "
            f"({_ACOUSTIC_TOP:.3f} to {_OPTICAL_BOTTOM:.3f} Hz): no wave can travel, the "
            "response dies out exponentially from the driven end.  Driven at 0.4 Hz "
            f"(acoustic band) or 1.4 Hz (optical band, up to {_OPTICAL_TOP:.3f} Hz) a wave "
            "travels to the absorbing end.",
            dict(nx=100, ny=1, stiffness=PAPER_STIFFNESS, mass="ionic", boundary="absorbing",
                 sponge_width=20, sponge_sides="right",
                 driver=dict(column=0, row=0, direction="x", amplitude=0.02, frequency=0.95,
                             kind="force", ramp=5.0)),
            "verlet", 0.01, _rest, duration=60.0,
        ),
        Preset(
            "membrane", "A 24x24 drum skin moving out of the plane (3-D), pre-tensioned "
            "(L = 0.9 a); a smooth bump in the middle is released and the membrane drums.",
            dict(nx=24, ny=24, dim=3, stiffness=PAPER_STIFFNESS, rest_length=0.9), "rk4", 0.02,
            _membrane_bump, duration=40.0,
        ),
    ]
}

OVERRIDES = (
    "nx", "ny", "spacing", "mass", "stiffness", "rest_length", "damping", "drag", "gravity",
    "linear", "dim", "driver", "boundary", "sponge_width", "sponge_strength", "sponge_sides",
)
"""Keywords accepted by ``build`` (plus ``integrator``, ``dt`` and ``precision``)."""


def names() -> list[str]:
    """Names of the presets, in a sensible teaching order."""
    return list(PRESETS)


def build(name: str, **overrides: Any) -> Scene:
    """Build the preset ``name`` with some parameters overridden.

    Overrides: nx, ny, spacing, mass (scalar or (ny, nx) array), stiffness, rest_length
    (absolute, m), damping (dashpot coefficient), drag, gravity (vector, or a scalar meaning
    downwards), linear (bool), dim (2 or 3), integrator, dt, precision ("float64" or
    "float32").  Invalid values raise ``ModelError``
    or ``SceneError`` with a clear message.
    """
    if name not in PRESETS:
        raise SceneError(f"unknown scene {name!r}; choose one of: {', '.join(PRESETS)}")
    preset = PRESETS[name]
    unknown = set(overrides) - set(OVERRIDES) - {"integrator", "dt", "precision"}
    if unknown:
        raise SceneError(
            f"unknown parameter(s) {', '.join(sorted(unknown))} for scene {name!r}; "
            f"accepted: {', '.join(OVERRIDES + ('integrator', 'dt', 'precision'))}"
        )
    parameters = dict(preset.parameters)
    integrator = overrides.pop("integrator", preset.integrator)
    dt = overrides.pop("dt", preset.dt)
    precision = overrides.pop("precision", "float64")
    parameters.update(overrides)
    if "rest_length" in preset.parameters and "rest_length" not in overrides:
        # keep the preset's pre-tension ratio when only the spacing changes
        parameters["rest_length"] = preset.parameters["rest_length"] * parameters.get("spacing", 1.0)
    if isinstance(parameters.get("mass"), str):
        if parameters["mass"] != "ionic":
            raise ModelError(f"mass must be a number or an array, got {parameters['mass']!r}")
        parameters["mass"] = _ionic_masses(parameters.get("nx", 1), parameters.get("ny", 1))
    model = Model.create(**parameters)
    positions, velocities = preset.initial(model)
    try:
        dt_value = float(dt)
    except (TypeError, ValueError):
        raise SceneError(f"dt must be a number, got {dt!r}") from None
    return Scene(
        name=name, model=model, description=preset.description, integrator=integrator,
        dt=dt_value, initial_positions=positions, initial_velocities=velocities,
        duration=preset.duration, precision=precision,
    )


# --- files -----------------------------------------------------------------------------------------

MAX_SCENE_FILE_BYTES = 2**20
"""Largest scene TOML file read (1 MB): a hand-written scene is a few kB, and ``save`` writes at
most 64 sparse displacement rows before it moves them to the ``.npz``."""

MAX_UPLOAD_BYTES = 64 * 2**20
"""Largest scene given to ``from_bytes`` (64 MB): the masses, displacements and velocities of the
682x383 interference lattice take 10.4 MB uncompressed."""

ARRAY_MEMBERS = ("masses", "displacements", "velocities")
"""The arrays an ``.npz`` scene file may hold; any other member is refused."""

_NPY_HEADER_BYTES = 4096
"""Room allowed for the ``.npy`` header of each member (numpy writes 128 bytes)."""

_ZIP_MAGIC = b"PK\x03\x04"


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    raise SceneError(f"cannot write {value!r} to a scene file")


def _scene_text(scene: Scene, array_file_name: str) -> tuple[str, dict[str, np.ndarray]]:
    """The TOML text of ``scene`` and the arrays that go to ``array_file_name`` (may be empty,
    then the TOML names no array file)."""
    model = scene.model
    arrays: dict[str, np.ndarray] = {}
    mass: Any = float(model.masses.flat[0])
    if not model.uniform_mass:
        arrays["masses"] = np.asarray(model.masses)
        mass = "arrays:masses"
    displacement = scene.initial_positions - model.rest_positions
    if np.any(displacement != 0):
        arrays["displacements"] = displacement
    if np.any(scene.initial_velocities != 0):
        arrays["velocities"] = np.asarray(scene.initial_velocities)
    lines = [
        "# coupled-oscillators scene file: edit freely; units are SI (m, kg, s, N/m, N s/m).",
        f"format = {FORMAT_VERSION}",
        f"name = {_toml_value(scene.name)}",
        f"description = {_toml_value(scene.description)}",
        f"integrator = {_toml_value(scene.integrator)}",
        f"dt = {_toml_value(scene.dt)}",
        f"duration = {_toml_value(scene.duration)}",
        f"precision = {_toml_value(scene.precision)}",
        "",
        "[model]",
        f"nx = {model.nx}",
        f"ny = {model.ny}",
        f"dim = {model.dim}",
        f"spacing = {_toml_value(model.spacing)}",
        f"mass = {_toml_value(mass)}",
        f"stiffness = {_toml_value(model.stiffness)}",
        f"rest_length = {_toml_value(model.rest_length)}",
        f"damping = {_toml_value(model.damping)}",
        f"drag = {_toml_value(model.drag)}",
        f"gravity = {_toml_value(list(model.gravity))}",
        f"linear = {_toml_value(model.linear)}",
        f"boundary = {_toml_value(model.boundary)}",
    ]
    if model.boundary == "absorbing":
        lines += [
            f"sponge_width = {model.sponge_width}",
            f"sponge_strength = {_toml_value(model.sponge_strength)}",
            f"sponge_sides = {_toml_value(list(model.sponge_sides))}",
        ]
    if model.driver is not None:
        lines += ["", "# a sinusoidal driver: kind force (A k sin 2 pi f t, N) or displacement "
                  "(A sin 2 pi f t, m)", "[model.driver]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in model.driver.as_table().items()]
    sparse = _sparse_displacements(displacement) if "displacements" in arrays else None
    if sparse is not None:
        del arrays["displacements"]
        lines += ["", "# initial displacements from rest: [particle index, dx, dy(, dz)]",
                  "[initial]", "displacements = ["]
        lines += [f"  {_toml_value(row)}," for row in sparse]
        lines += ["]"]
    if arrays:
        lines += ["", "[arrays]", f"file = {_toml_value(array_file_name)}"]
    return "\n".join(lines) + "\n", arrays


def save(scene: Scene, path: str | Path) -> Path:
    """Write ``scene`` to ``path`` (.toml).  Non-uniform masses and any displacement or velocity
    that is not sparse go to ``<path stem>.npz`` beside it (named in the TOML).  Returns the TOML
    path."""
    path = Path(path)
    if path.suffix != ".toml":
        path = path.with_suffix(".toml")
    array_path = path.with_suffix(".npz")
    text, arrays = _scene_text(scene, array_path.name)
    if arrays:
        np.savez_compressed(array_path, **arrays)
    path.write_text(text)
    return path


def to_bytes(scene: Scene) -> tuple[str, bytes]:
    """``scene`` as the content of one file, for a download: ``(".toml", TOML text)`` when it
    needs no arrays, else ``(".zip", zip of scene.toml and scene.npz)`` (what ``save`` writes).
    ``from_bytes`` reads either back."""
    text, arrays = _scene_text(scene, "scene.npz")
    if not arrays:
        return ".toml", text.encode("utf-8")
    arrays_buffer = io.BytesIO()
    np.savez_compressed(arrays_buffer, **arrays)
    package = io.BytesIO()
    with zipfile.ZipFile(package, "w") as archive:
        archive.writestr("scene.toml", text, compress_type=zipfile.ZIP_DEFLATED)
        archive.writestr("scene.npz", arrays_buffer.getvalue(), compress_type=zipfile.ZIP_STORED)
    return ".zip", package.getvalue()


def _sparse_displacements(displacement: np.ndarray, limit: int = 64) -> list | None:
    moved = np.flatnonzero(np.any(displacement != 0, axis=1))
    if moved.size > limit:
        return None
    return [[int(p)] + [float(v) for v in displacement[p]] for p in moved]


# --- reading: checked before anything large is read or allocated ------------------------------------


def _inside(path: Path, root: Path | None, what: str) -> None:
    """With a root directory, ``path`` must resolve (symlinks followed) inside it."""
    if root is not None and not path.resolve().is_relative_to(root):
        raise SceneError(f"the {what} {path} is outside {root}")


def _read_regular_file(path: Path, limit: int, what: str) -> bytes:
    """The content of ``path`` if it is a regular file of at most ``limit`` bytes.  A directory,
    a device or a named pipe is refused before it is opened (and the opened file is checked
    again, without blocking, in case it was swapped meanwhile)."""
    try:
        status = os.stat(path)
    except OSError as error:
        raise SceneError(f"cannot read {what} {path}: {error.strerror or error}") from None
    if not stat.S_ISREG(status.st_mode):
        raise SceneError(f"{path} is not a regular file; a {what} must be one")
    if status.st_size > limit:
        raise SceneError(
            f"{what} {path} is {status.st_size:,} bytes, more than the {limit:,} bytes allowed"
        )
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as error:
        raise SceneError(f"cannot read {what} {path}: {error.strerror or error}") from None
    with os.fdopen(descriptor, "rb") as stream:
        if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            raise SceneError(f"{path} is not a regular file; a {what} must be one")
        content = stream.read(limit + 1)
    if len(content) > limit:
        raise SceneError(f"{what} {path} is more than the {limit:,} bytes allowed")
    return content


def _array_file_name(document: dict[str, Any], label: str) -> str:
    """The ``[arrays] file`` entry: a bare file name beside the TOML (no directory part)."""
    table = document["arrays"]
    name = table.get("file") if isinstance(table, dict) else None
    if (not isinstance(name, str) or not name or name in (".", "..") or "/" in name
            or "\\" in name or "\0" in name or Path(name).is_absolute()):
        raise SceneError(
            f"{label}: [arrays] file must be the bare name of a file beside the scene file "
            f"(no directory), got {name!r}"
        )
    return name


def _lattice_shape(model_table: dict[str, Any], label: str) -> tuple[int, int, int]:
    """nx, ny, dim of a [model] table, validated (sizes and memory) before any array is read."""
    try:
        nx = _whole_number("nx", model_table.get("nx", 1))
        ny = _whole_number("ny", model_table.get("ny", 1))
        dim = model_table.get("dim", 2)
        if dim not in (2, 3) or isinstance(dim, bool):
            raise ModelError(f"dim must be 2 or 3, got {dim!r}")
        check_size(nx, ny, int(dim))
    except ModelError as error:
        raise SceneError(f"{label}: {error}") from None
    return nx, ny, int(dim)


def _expected_shapes(nx: int, ny: int, dim: int) -> dict[str, tuple[tuple[int, ...], ...]]:
    n = nx * ny
    return {"masses": ((ny, nx), (n,)), "displacements": ((n, dim),), "velocities": ((n, dim),)}


def read_arrays(source: Any, nx: int, ny: int, dim: int, label: str) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` scene file (a path or a binary file object) for an nx x ny
    lattice in ``dim`` dimensions.

    Before any array is read, every member is checked: its name is one of ``ARRAY_MEMBERS``
    (other members are refused), its ``.npy`` header gives a numeric dtype of at most 8 bytes and
    the shape the lattice needs (masses (ny, nx) or (n_particles,), displacements and velocities
    (n_particles, dim)), and its uncompressed size in the zip directory fits that shape.  So a
    small file that would unpack to gigabytes is refused without allocating.  Never unpickles.
    """
    shapes = _expected_shapes(nx, ny, dim)
    largest = {key: max(math.prod(shape) for shape in options) * 8 + _NPY_HEADER_BYTES
               for key, options in shapes.items()}
    try:
        with zipfile.ZipFile(source) as archive:
            members = archive.infolist()
            if len(members) > len(ARRAY_MEMBERS):
                raise SceneError(f"{label} has {len(members)} members; at most "
                                 f"{len(ARRAY_MEMBERS)} ({', '.join(ARRAY_MEMBERS)}) are allowed")
            checked: dict[str, zipfile.ZipInfo] = {}
            for info in members:
                key = info.filename.removesuffix(".npy")
                if key not in shapes or not info.filename.endswith(".npy") or key in checked:
                    raise SceneError(f"{label}: unexpected member {info.filename!r} (allowed: "
                                     f"{', '.join(name + '.npy' for name in ARRAY_MEMBERS)})")
                if info.file_size > largest[key]:
                    raise SceneError(f"{label}: {info.filename} unpacks to {info.file_size:,} "
                                     f"bytes, more than a {nx}x{ny} lattice needs")
                with archive.open(info) as member:
                    shape, dtype = _npy_header(member, f"{label}: {info.filename}")
                if shape not in shapes[key]:
                    wanted = " or ".join(str(option) for option in shapes[key])
                    raise SceneError(f"{label}: {key} has shape {shape}; a {nx}x{ny} lattice in "
                                     f"{dim}-D needs {wanted}")
                if dtype.kind not in "fiu" or dtype.itemsize > 8 or dtype.hasobject:
                    raise SceneError(f"{label}: {key} has dtype {dtype}; want float64 numbers")
                if info.file_size > math.prod(shape) * dtype.itemsize + _NPY_HEADER_BYTES:
                    raise SceneError(f"{label}: {info.filename} is larger than its header says")
                checked[key] = info
            arrays = {}
            for key, info in checked.items():
                with archive.open(info) as member:
                    arrays[key] = np.lib.format.read_array(member, allow_pickle=False)
            return arrays
    except SceneError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile) as error:
        raise SceneError(f"cannot read the array file {label}: {error}") from None


def _npy_header(member: Any, label: str) -> tuple[tuple[int, ...], np.dtype]:
    version = np.lib.format.read_magic(member)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(member)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(member)
    else:
        raise SceneError(f"{label}: unsupported .npy version {version}")
    return tuple(int(size) for size in shape), np.dtype(dtype)


def load(path: str | Path, *, within: str | Path | None = None) -> Scene:
    """Read a scene file written by ``save`` (or by hand).  Raises ``SceneError`` saying what is
    wrong (missing file, not a regular file, too large, bad TOML, missing or invalid parameter,
    bad array file).

    ``within``: a directory the scene file and its array file must resolve into (symlinks
    followed), for callers that take names from users.  The ``[arrays] file`` entry must be a
    bare file name beside the TOML in any case.  Sizes: the TOML at most
    ``MAX_SCENE_FILE_BYTES``; the ``.npz`` is checked member by member (``read_arrays``).
    """
    path = Path(path)
    root = Path(within).resolve() if within is not None else None
    _inside(path, root, "scene file")
    content = _read_regular_file(path, MAX_SCENE_FILE_BYTES, "scene file")
    document = _parse_toml(content, str(path))

    def arrays_for(nx: int, ny: int, dim: int) -> dict[str, np.ndarray]:
        array_path = path.parent / _array_file_name(document, str(path))
        _inside(array_path, root, "array file")
        shapes = _expected_shapes(nx, ny, dim)
        limit = sum(max(math.prod(shape) for shape in options) * 8 + 2 * _NPY_HEADER_BYTES
                    for options in shapes.values()) + 2**16
        content = _read_regular_file(array_path, limit, "array file")
        return read_arrays(io.BytesIO(content), nx, ny, dim, str(array_path))

    return _scene_from_document(document, str(path), path.stem, arrays_for)


def load_file(path: str | Path) -> Scene:
    """A scene file of either kind: a ``.toml`` (``load``) or the ``.zip`` that ``to_bytes``
    makes (read as a regular file of at most ``MAX_UPLOAD_BYTES``, then ``from_bytes``)."""
    path = Path(path)
    if path.suffix.lower() == ".zip":
        return from_bytes(_read_regular_file(path, MAX_UPLOAD_BYTES, "scene archive"), path.name)
    return load(path)


def from_bytes(data: bytes, filename: str) -> Scene:
    """A scene from the content of an uploaded file: a TOML scene (UTF-8 text) or the ``.zip``
    that ``to_bytes`` makes (decided by the content, not by ``filename``, which only names the
    scene when the TOML has no name).

    The same checks as ``load``: at most ``MAX_UPLOAD_BYTES`` in all and ``MAX_SCENE_FILE_BYTES``
    of TOML; a zip holds exactly one ``.toml`` member and at most one ``.npz`` member, both bare
    names (no directories), their uncompressed sizes checked in the zip directory before reading;
    the TOML's ``[arrays] file`` names the ``.npz`` member; the arrays are checked as by
    ``read_arrays``.  Nothing is written to disk.
    """
    label = Path(str(filename)).name or "uploaded scene"
    if len(data) > MAX_UPLOAD_BYTES:
        raise SceneError(f"{label} is {len(data):,} bytes, more than the "
                         f"{MAX_UPLOAD_BYTES:,} bytes allowed")
    if not data.startswith(_ZIP_MAGIC):
        document = _parse_toml(_limited(data, MAX_SCENE_FILE_BYTES, label), label)

        def no_arrays(nx: int, ny: int, dim: int) -> dict[str, np.ndarray]:
            raise SceneError(f"{label} names an array file; upload the .zip of the scene "
                             "(its TOML and .npz together)")

        return _scene_from_document(document, label, Path(label).stem, no_arrays)
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            members = archive.infolist()
            names = [info.filename for info in members]
            tomls = [info for info in members if info.filename.endswith(".toml")]
            npzs = [info for info in members if info.filename.endswith(".npz")]
            bare = all(name and "/" not in name and "\\" not in name and name not in (".", "..")
                       for name in names)
            if len(tomls) != 1 or len(npzs) > 1 or len(members) != len(tomls) + len(npzs) \
                    or not bare:
                raise SceneError(f"{label} must hold one .toml and at most one .npz file, "
                                 f"without directories; it holds {names[:5]}")
            if tomls[0].file_size > MAX_SCENE_FILE_BYTES:
                raise SceneError(f"{label}: {tomls[0].filename} is larger than the "
                                 f"{MAX_SCENE_FILE_BYTES:,} bytes allowed")
            if npzs and npzs[0].file_size > MAX_UPLOAD_BYTES:
                raise SceneError(f"{label}: {npzs[0].filename} is larger than the "
                                 f"{MAX_UPLOAD_BYTES:,} bytes allowed")
            document = _parse_toml(archive.read(tomls[0]), f"{label}: {tomls[0].filename}")
            npz = archive.read(npzs[0]) if npzs else None
    except SceneError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile) as error:
        raise SceneError(f"cannot read {label}: {error}") from None

    def arrays_in_zip(nx: int, ny: int, dim: int) -> dict[str, np.ndarray]:
        name = _array_file_name(document, label)
        if npz is None or name != npzs[0].filename:
            raise SceneError(f"{label}: the array file {name!r} is not in the zip")
        return read_arrays(io.BytesIO(npz), nx, ny, dim, f"{label}: {name}")

    return _scene_from_document(document, label, Path(tomls[0].filename).stem, arrays_in_zip)


def _limited(data: bytes, limit: int, label: str) -> bytes:
    if len(data) > limit:
        raise SceneError(f"{label} is {len(data):,} bytes, more than the {limit:,} bytes allowed")
    return data


def _parse_toml(content: bytes, label: str) -> dict[str, Any]:
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(f"{label} is not a text (TOML) scene file") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"{label} is not valid TOML: {error}") from None


def _scene_from_document(
    document: dict[str, Any], label: str, default_name: str,
    arrays_for: Callable[[int, int, int], dict[str, np.ndarray]],
) -> Scene:
    """Build the scene a parsed TOML document describes; ``arrays_for(nx, ny, dim)`` reads the
    array file it names (called only if it names one)."""
    if document.get("format", FORMAT_VERSION) != FORMAT_VERSION:
        raise SceneError(
            f"{label} has format {document['format']!r}; this version reads format {FORMAT_VERSION}"
        )
    if "model" not in document or not isinstance(document["model"], dict):
        raise SceneError(f"{label} has no [model] table")
    model_table = dict(document["model"])
    unknown = set(model_table) - set(OVERRIDES)
    if unknown:
        raise SceneError(f"{label}: unknown [model] key(s) {', '.join(sorted(unknown))}")
    arrays: dict[str, np.ndarray] = {}
    if "arrays" in document:
        arrays = arrays_for(*_lattice_shape(model_table, label))
    if isinstance(model_table.get("mass"), str):
        key = model_table["mass"].removeprefix("arrays:")
        if key not in arrays:
            raise SceneError(f"{label}: mass refers to array {key!r}, which the array file lacks")
        model_table["mass"] = arrays[key]
    try:
        model = Model.create(**model_table)
    except (ModelError, TypeError) as error:
        raise SceneError(f"{label}: {error}") from None
    try:
        positions = model.rest_positions.copy()
        if "displacements" in arrays:
            positions = positions + arrays["displacements"]
        initial = document.get("initial", {})
        rows = initial.get("displacements", []) if isinstance(initial, dict) else None
        if not isinstance(rows, list):
            raise SceneError(f"{label}: [initial] displacements must be a list of rows")
        for row in rows:
            if (not isinstance(row, list) or len(row) < 2
                    or not 0 <= int(row[0]) < model.n_particles):
                raise SceneError(
                    f"{label}: bad displacement entry {row!r} (want [particle, dx, dy])"
                )
            values = [float(v) for v in row[1 : 1 + model.dim]]
            positions[int(row[0]), : len(values)] += values
        velocities = arrays.get("velocities")
        dt = float(document.get("dt", 0.01))
        duration = float(document.get("duration", 20.0))
        return Scene(
            name=str(document.get("name", default_name)), model=model,
            description=str(document.get("description", "")),
            integrator=str(document.get("integrator", "rk4")),
            dt=dt, duration=duration, initial_positions=positions,
            initial_velocities=velocities,
            precision=str(document.get("precision", "float64")),
        )
    except (ValueError, TypeError, OverflowError) as error:
        raise SceneError(f"{label}: {error}") from None


def scene_from_simulation(simulation: Any, name: str | None = None) -> Scene:
    """The current state and parameters of a running simulation as a scene (to save it)."""
    return Scene(
        name=name or simulation.scene.name, model=simulation.model,
        description=simulation.scene.description, integrator=simulation.integrator,
        dt=simulation.dt, duration=simulation.scene.duration,
        precision=getattr(simulation, "precision", "float64"),
        initial_positions=simulation.state.particle_positions().copy(),
        initial_velocities=simulation.state.particle_velocities().copy(),
    )
