"""Scenes: a model with its initial condition and recommended settings, and building one.

A scene is data: a ``Model`` plus the initial displacements and velocities, a default integrator
and time step, and a description.  ``build(name, **overrides)`` makes one from a preset
(``sim.scenes.presets``) with some parameters changed and checked; ``scene_from_simulation`` takes one
from a running simulation.  Reading and writing scene files is ``sim.scenes.scene_files``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sim.integrators.registry import check_integrator_name, check_precision
from sim.model.lattice import Model, ModelError
from sim.model.schema import printable
from sim.scenes.presets import MASS_PATTERNS, PRESETS


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
        """One line for a terminal (control characters in the name escaped)."""
        return printable(f"{self.name}: {self.model.describe()}; {self.integrator}, "
                         f"dt={self.dt:g} s", keep="")


def _checked_array(name: str, value: Any, shape: tuple[int, int]) -> np.ndarray:
    array = np.array(value, dtype=float)
    if array.shape != shape:
        raise SceneError(f"{name} must have shape {shape} (n_particles, dim), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise SceneError(f"{name} contains NaN or infinite values")
    return array




OVERRIDES = (
    "nx", "ny", "spacing", "mass", "stiffness", "rest_length", "damping", "drag", "gravity",
    "linear", "dim", "driver", "sources", "barriers", "boundary", "sponge_width", "sponge_strength",
    "sponge_sides", "diagonal_stiffness",
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
        pattern = MASS_PATTERNS.get(parameters["mass"])
        if pattern is None:
            raise ModelError(f"mass must be a number or an array, got {parameters['mass']!r}")
        parameters["mass"] = pattern(parameters.get("nx", 1), parameters.get("ny", 1))
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
