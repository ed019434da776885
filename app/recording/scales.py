"""Colour scales from the scene's physics, fixed for a whole recording or movie.

A colour that means the same at every frame needs a scale chosen before the first frame.  The
scale comes from a *look-ahead run*: a private copy of the scene is run with the same integrator
and time step over the scene's duration (or as much of it as ``budget_seconds`` of computing
allows: all of it for the small presets, about the first 25 s of the 150 s ``interference``),
sampled at ``samples`` evenly spaced states, and each scale is the 99.9th percentile of the
quantity's absolute value pooled over all sampled states:

* ``strain``: |strain - rest strain| of the springs (dimensionless; rest strain (a - L)/L), the
  half-width of the diverging spring colour map centred on the rest lattice;
* ``field``: |u_axis| (m) for the signed displacement, |u| (m) or |v| (m/s) for magnitudes;
* ``height``: |z| (m) of 3-D lattices (out-of-plane displacement);
* ``energy`` (only when asked): the largest kinetic + spring energy (J) over the sampled states,
  the top of the log colour scale of mode energies (a driven lattice gains energy as it runs).

The signed displacement shows one component, ``axis``: the direction the scene's initial
displacement (or velocity) is largest in (y for ``interference``, whose two sources are pushed
in opposite y directions; z for the membrane), else the direction of gravity.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sim.integrators.registry import describe, descriptions

QUANTITIES = ("displacement", "magnitude", "speed")
"""Field quantities of recordings: signed displacement component (m), |u| (m), |v| (m/s)."""
SITE_QUANTITIES = ("strain", "density")
"""Per-particle quantities from the four springs of each particle (movies of large lattices):
mean strain - rest strain (dimensionless) and relative density change rho/rho_0 - 1."""
SIGNED = ("displacement", "strain", "density")
UNITS = {"displacement": "m", "magnitude": "m", "speed": "m/s", "strain": "dimensionless",
         "density": "dimensionless"}
LOOK_AHEAD_BUDGET_SECONDS = 1.5
PERCENTILE = 99.9
AXIS_NAMES = "xyz"


@dataclasses.dataclass(frozen=True)
class ColourScales:
    """Fixed colour scales of one recording (see the module docstring).

    strain: |strain - rest strain| at the ends of the spring colour map (dimensionless).
    field: value at the end(s) of the field colour map (m or m/s).
    height: |z| (m) at the ends of the height colour map (3-D; 0 for 2-D lattices).
    axis: displacement component of the signed field (0 x, 1 y, 2 z).
    rest_strain: (a - L)/L, the strain of every spring in the rest lattice.
    seconds: simulated seconds the look-ahead covered (0 if it was not run).
    bounds: ((x_min, y_min), (x_max, y_max)) m of the particles over the sampled states, or None
        (movies frame the lattice with it: the catenary sags below its rest box).
    energy: the largest kinetic + spring energy (J) over the sampled states (0 if not asked).
    """

    strain: float
    field: float
    height: float
    axis: int
    rest_strain: float
    seconds: float
    bounds: tuple[tuple[float, float], tuple[float, float]] | None = None
    energy: float = 0.0

    def describe(self, quantity: str) -> str:
        text = (f"colour scales fixed from a {self.seconds:g} s look-ahead run (99.9th percentile "
                f"of each quantity over {PERCENTILE_SAMPLES} sampled states): strain "
                f"±{self.strain:.3g}")
        text += f", field ±{self.field:.3g} {UNITS[quantity]}"
        if self.height:
            text += f", height ±{self.height:.3g} m"
        return text


PERCENTILE_SAMPLES = 60


def displacement_axis(scene: Any) -> int:
    """The component (0 x, 1 y, 2 z) the scene's initial displacement or velocity is largest in;
    else gravity's; else y (2-D) or z (3-D)."""
    model = scene.model
    displacement = np.asarray(scene.initial_positions) - model.rest_positions
    weight = (displacement**2).sum(axis=0) + (np.asarray(scene.initial_velocities) ** 2).sum(axis=0)
    if weight.max() > 0:
        return int(np.argmax(weight))
    gravity = np.abs(np.asarray(model.gravity[: model.dim]))
    if gravity.max() > 0:
        return int(np.argmax(gravity))
    return model.dim - 1


def site_strain_density(positions: np.ndarray, model: Any) -> tuple[np.ndarray, np.ndarray]:
    """Per particle, from (n_particles, dim) positions (m): the mean strain of its four springs
    minus the rest strain, and the relative density change a^2 / (l_h l_v) - 1, where l_h and l_v
    are the mean lengths of its horizontal and vertical springs (shear is ignored)."""
    nx, ny, dim = model.nx, model.ny, model.dim
    grid = positions.reshape(ny, nx, dim)
    anchors = model.anchor_positions
    left, right = anchors[:ny], anchors[ny : 2 * ny]
    bottom, top = anchors[2 * ny : 2 * ny + nx], anchors[2 * ny + nx :]
    rows = np.concatenate([left[:, None, :], grid, right[:, None, :]], axis=1)
    columns = np.concatenate([bottom[None, :, :], grid, top[None, :, :]], axis=0)
    horizontal = np.linalg.norm(np.diff(rows, axis=1), axis=2)  # (ny, nx + 1)
    vertical = np.linalg.norm(np.diff(columns, axis=0), axis=2)  # (ny + 1, nx)
    mean_h = 0.5 * (horizontal[:, :-1] + horizontal[:, 1:])
    mean_v = 0.5 * (vertical[:-1, :] + vertical[1:, :])
    length = model.rest_length
    rest_strain = (model.spacing - length) / length
    strain = 0.5 * (mean_h + mean_v) / length - 1.0 - rest_strain
    density = model.spacing**2 / np.maximum(mean_h * mean_v, 1e-12 * model.spacing**2) - 1.0
    return strain.ravel(), density.ravel()


def field_values(
    quantity: str, positions: np.ndarray, rest: np.ndarray, velocities: np.ndarray | None,
    axis: int, model: Any = None,
) -> np.ndarray:
    """(n_particles,) field values from (n_particles, dim) positions (m) / velocities (m/s);
    ``model`` is needed for the site quantities (strain, density)."""
    if quantity in SITE_QUANTITIES:
        strain, density = site_strain_density(positions, model)
        return strain if quantity == "strain" else density
    if quantity == "displacement":
        return positions[:, axis] - rest[:, axis]
    if quantity == "magnitude":
        u = positions - rest
        return np.sqrt(np.einsum("ij,ij->i", u, u))
    if quantity == "speed":
        if velocities is None:
            raise ValueError("the speed field needs velocities")
        return np.sqrt(np.einsum("ij,ij->i", velocities, velocities))
    raise ValueError(f"quantity must be one of {QUANTITIES}, got {quantity!r}")


def look_ahead_integrator(integrator: str | None, scene: Any) -> str:
    """The integrator of the look-ahead run for ``integrator`` (one name or a comma-separated
    comparison): of the named ones that have a stable step on an undamped lattice, the one of
    highest order (RK4 before Verlet); else the only one named; else the scene's."""
    names = [n.strip() for n in (integrator or "").split(",") if n.strip()]
    stable = [d for d in descriptions()
              if d.stability_factor is not None and ({d.name, *d.aliases} & set(names))]
    if stable:
        return max(stable, key=lambda d: d.order).name
    return names[0] if len(names) == 1 else scene.integrator


def look_ahead(
    scene: Any, *, integrator: str | None = None, dt: float | None = None,
    quantity: str = "displacement", strains: bool = True,
    budget_seconds: float = LOOK_AHEAD_BUDGET_SECONDS, samples: int = PERCENTILE_SAMPLES,
    energies: bool = False, watch: Any = None,
) -> ColourScales:
    """Run a copy of ``scene`` and return fixed colour scales (see the module docstring).

    integrator: one name, or a comma-separated comparison (``look_ahead_integrator`` picks the
    accurate one); dt: the step (s), default the scene's.  A blow-up ends the look-ahead early
    (the scales use what was sampled).  ``energies``: also find the largest kinetic + spring
    energy (``ColourScales.energy``).  ``watch(simulation)``: called with the look-ahead's
    simulation before it steps (a movie makes its steps look for a cancel)."""
    from sim import BlowUpError, Simulation

    model = scene.model
    name = look_ahead_integrator(integrator, scene)
    simulation = Simulation(scene, integrator=name, dt=dt or scene.dt)
    if watch is not None:
        watch(simulation)
    dt = simulation.dt
    wanted = max(1, math.ceil(scene.duration / dt - 1e-9))
    step_seconds = describe(name).seconds_per_step(model.n_particles)
    affordable = max(samples, int(budget_seconds / step_seconds))
    steps = min(wanted, affordable)
    axis = displacement_axis(scene)
    rest = model.rest_positions
    rest_strain = (model.spacing - model.rest_length) / model.rest_length
    stride = max(1, model.n_particles // 20000)  # ~20k values a state suffice for a percentile
    strain_pool: list[np.ndarray] = []
    field_pool: list[np.ndarray] = []
    height_pool: list[np.ndarray] = []
    top_energy = 0.0
    low = np.full(2, np.inf)
    high = np.full(2, -np.inf)
    marks = np.unique(np.linspace(0, steps, samples).round().astype(int))
    for mark in marks:
        try:
            simulation.step(int(mark) - simulation.step_count)
        except BlowUpError:
            break
        positions = simulation.peek_positions()
        low = np.minimum(low, positions[:, :2].min(axis=0))
        high = np.maximum(high, positions[:, :2].max(axis=0))
        velocities = simulation.velocities if quantity == "speed" else None
        values = field_values(quantity, positions, rest, velocities, axis, model)
        field_pool.append(np.abs(values)[::stride])
        if model.dim == 3:
            height_pool.append(np.abs(positions[::stride, 2] - rest[::stride, 2]))
        if strains:
            strain_pool.append(np.abs(simulation.strains() - rest_strain))
        if energies:
            energy = simulation.energy()
            top_energy = max(top_energy, energy.kinetic + energy.spring)
    floor = 1e-6 * model.spacing

    def scale(pool: list[np.ndarray], smallest: float) -> float:
        if not pool:
            return smallest
        return max(float(np.percentile(np.concatenate(pool), PERCENTILE)), smallest)

    return ColourScales(
        strain=scale(strain_pool, 1e-6) if strains else 0.0,
        field=scale(field_pool, floor),
        height=scale(height_pool, floor) if model.dim == 3 else 0.0,
        axis=axis, rest_strain=rest_strain, seconds=simulation.time,
        bounds=(tuple(low), tuple(high)) if np.isfinite(low).all() else None,
        energy=top_energy,
    )
