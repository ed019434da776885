"""Scenes: named presets (the paper's configurations) and the scene file format.

A scene is data: a ``Model`` plus the initial displacements and velocities, a default integrator
and time step, and a description.  ``build(name, **overrides)`` makes a preset; ``save`` / ``load``
write and read a scene as a human-editable TOML file (arrays that are not uniform go in a ``.npz``
file beside it, named in the TOML).

Presets (units: metres, kilograms, seconds; stiffness 35 N/m is the paper's "35 % of maximum"):

=============== ================================================================================
single          one particle held by 4 springs (paper Fig. 3), displaced diagonally
square          2x2, the paper's four particles, one displaced (Fig. 5)
chain           5 in a line, the middle one displaced along the chain (Fig. 4, longitudinal)
grid            12x8 lattice (Fig. 2), one particle near the centre displaced
ionic           12x8 checkerboard of heavy (4 kg) and light (1 kg) particles (Fig. 7)
catenary        15x10 under gravity with dashpots, settling into catenaries (Fig. 8)
interference    682x383, the middle particles of the left and right boundaries displaced in
                opposite directions, RK4, pre-tensioned (Figs. 10-14)
membrane        24x24 drum skin in 3-D, pre-tensioned, a bump pushed out of the plane
=============== ================================================================================
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sim.integrators import check_integrator_name
from sim.model import Model, ModelError

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
            dict(nx=682, ny=383, stiffness=PAPER_STIFFNESS, rest_length=0.8), "rk4", 0.05,
            _displace(
                lambda m: [
                    (_index(m, 0, m.ny // 2), (0.0, 0.5 * m.spacing)),
                    (_index(m, m.nx - 1, m.ny // 2), (0.0, -0.5 * m.spacing)),
                ]
            ),
            duration=150.0,  # longitudinal fronts meet near t = 58 s, transverse ones near 130 s
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
    "linear", "dim",
)
"""Keywords accepted by ``build`` (plus ``integrator`` and ``dt``)."""


def names() -> list[str]:
    """Names of the presets, in a sensible teaching order."""
    return list(PRESETS)


def build(name: str, **overrides: Any) -> Scene:
    """Build the preset ``name`` with some parameters overridden.

    Overrides: nx, ny, spacing, mass (scalar or (ny, nx) array), stiffness, rest_length
    (absolute, m), damping (dashpot coefficient), drag, gravity (vector, or a scalar meaning
    downwards), linear (bool), dim (2 or 3), integrator, dt.  Invalid values raise ``ModelError``
    or ``SceneError`` with a clear message.
    """
    if name not in PRESETS:
        raise SceneError(f"unknown scene {name!r}; choose one of: {', '.join(PRESETS)}")
    preset = PRESETS[name]
    unknown = set(overrides) - set(OVERRIDES) - {"integrator", "dt"}
    if unknown:
        raise SceneError(
            f"unknown parameter(s) {', '.join(sorted(unknown))} for scene {name!r}; "
            f"accepted: {', '.join(OVERRIDES + ('integrator', 'dt'))}"
        )
    parameters = dict(preset.parameters)
    integrator = overrides.pop("integrator", preset.integrator)
    dt = overrides.pop("dt", preset.dt)
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
        duration=preset.duration,
    )


# --- files -----------------------------------------------------------------------------------------


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


def save(scene: Scene, path: str | Path) -> Path:
    """Write ``scene`` to ``path`` (.toml).  Non-uniform masses and any displacement or velocity
    go to ``<path stem>.npz`` beside it (named in the TOML).  Returns the TOML path."""
    path = Path(path)
    if path.suffix != ".toml":
        path = path.with_suffix(".toml")
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
    ]
    sparse = _sparse_displacements(displacement) if "displacements" in arrays else None
    if sparse is not None:
        del arrays["displacements"]
        lines += ["", "# initial displacements from rest: [particle index, dx, dy(, dz)]",
                  "[initial]", "displacements = ["]
        lines += [f"  {_toml_value(row)}," for row in sparse]
        lines += ["]"]
    if arrays:
        array_path = path.with_suffix(".npz")
        lines += ["", "[arrays]", f"file = {_toml_value(array_path.name)}"]
        np.savez_compressed(array_path, **arrays)
    path.write_text("\n".join(lines) + "\n")
    return path


def _sparse_displacements(displacement: np.ndarray, limit: int = 64) -> list | None:
    moved = np.flatnonzero(np.any(displacement != 0, axis=1))
    if moved.size > limit:
        return None
    return [[int(p)] + [float(v) for v in displacement[p]] for p in moved]


def load(path: str | Path) -> Scene:
    """Read a scene file written by ``save`` (or by hand).  Raises ``SceneError`` saying what is
    wrong (missing file, bad TOML, missing or invalid parameter, bad array file)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise SceneError(f"cannot read scene file {path}: {error.strerror or error}") from None
    except UnicodeDecodeError:
        raise SceneError(f"{path} is not a text (TOML) scene file") from None
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"{path} is not valid TOML: {error}") from None
    if document.get("format", FORMAT_VERSION) != FORMAT_VERSION:
        raise SceneError(
            f"{path} has format {document['format']!r}; this version reads format {FORMAT_VERSION}"
        )
    if "model" not in document or not isinstance(document["model"], dict):
        raise SceneError(f"{path} has no [model] table")
    model_table = dict(document["model"])
    arrays: dict[str, np.ndarray] = {}
    if "arrays" in document:
        array_file = path.parent / str(document["arrays"].get("file", ""))
        try:
            with np.load(array_file) as archive:
                arrays = {key: archive[key] for key in archive.files}
        except (OSError, ValueError) as error:
            raise SceneError(f"cannot read the array file {array_file}: {error}") from None
    if isinstance(model_table.get("mass"), str):
        key = model_table["mass"].removeprefix("arrays:")
        if key not in arrays:
            raise SceneError(f"{path}: mass refers to array {key!r}, which the array file lacks")
        model_table["mass"] = arrays[key]
    unknown = set(model_table) - set(OVERRIDES)
    if unknown:
        raise SceneError(f"{path}: unknown [model] key(s) {', '.join(sorted(unknown))}")
    try:
        model = Model.create(**model_table)
    except ModelError as error:
        raise SceneError(f"{path}: {error}") from None
    try:
        positions = model.rest_positions.copy()
        if "displacements" in arrays:
            positions = positions + arrays["displacements"]
        for row in document.get("initial", {}).get("displacements", []):
            if (not isinstance(row, list) or len(row) < 2
                    or not 0 <= int(row[0]) < model.n_particles):
                raise SceneError(
                    f"{path}: bad displacement entry {row!r} (want [particle, dx, dy])"
                )
            values = [float(v) for v in row[1 : 1 + model.dim]]
            positions[int(row[0]), : len(values)] += values
        velocities = arrays.get("velocities")
        dt = float(document.get("dt", 0.01))
        duration = float(document.get("duration", 20.0))
        return Scene(
            name=str(document.get("name", path.stem)), model=model,
            description=str(document.get("description", "")),
            integrator=str(document.get("integrator", "rk4")),
            dt=dt, duration=duration, initial_positions=positions,
            initial_velocities=velocities,
        )
    except (ValueError, TypeError) as error:
        raise SceneError(f"{path}: {error}") from None


def scene_from_simulation(simulation: Any, name: str | None = None) -> Scene:
    """The current state and parameters of a running simulation as a scene (to save it)."""
    return Scene(
        name=name or simulation.scene.name, model=simulation.model,
        description=simulation.scene.description, integrator=simulation.integrator,
        dt=simulation.dt, duration=simulation.scene.duration,
        initial_positions=simulation.state.particle_positions().copy(),
        initial_velocities=simulation.state.particle_velocities().copy(),
    )
