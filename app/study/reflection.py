"""How much of a wave the absorbing walls send back: the sponge's reflection against wavelength.

The measurement (``measure_reflection``): a long linearised chain, one row of
``2 (distance + width)`` particles (k = 35 N/m, m = 1 kg, a = 1 m) with ``boundary="absorbing"``
and a sponge ``width`` particles deep at both ends.  A Gaussian wave packet

    u_i = A exp(-(x_i - x_0)^2 / (2 lambda^2)) cos(2 pi (x_i - x_0) / lambda)

(envelope width one wavelength, displacements along the chain, starting at rest) sits in the
middle, ``distance`` particles from each layer.  Released, it splits into two halves that run into
the layers at the group velocity c_g = a sqrt(k/m) cos(q a / 2), q = 2 pi / lambda.  At
t = 2 distance / c_g what the layers sent back has returned to the middle; the **reflected
fraction** is the energy (kinetic + springs) left in the interior (outside the layers) then,
divided by the energy at the start.

A control run with fixed walls (no layer, same chain, same interior) reflects everything: its
fraction is 1 less what the integrator (``chain_integrator``: the most accurate, RK4) at
dt = 0.05 s damps numerically (the short waves lose most: 7 % at lambda = 5 a), the scale against
which the sponge's numbers are read.

``reflection_study`` measures every (wavelength, width) pair; ``format_report`` and
``plot_reflection`` show them.  ``oscillators reflection`` runs it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

import sim
from app.study import reflection_angle
from sim.integrators.registry import describe, most_accurate
from sim.model.boundaries import DEFAULT_LAYER_STRENGTH
from sim.model.forcing import SPONGE_POWER

ProgressCallback = Callable[[str], None]

STIFFNESS = 35.0
"""k (N/m) of the chain."""

MASS = 1.0
"""m (kg) of each particle."""

DISTANCE = 300
"""Particles between the packet's centre and each layer's inner edge."""

DT = 0.05
"""Time step (s): omega_max dt = 0.59, a fifth of RK4's stability limit."""

PACKET_AMPLITUDE = 0.01
"""Peak displacement of the packet (m); the springs are linearised, so only ratios matter."""

DEFAULT_WIDTHS = (sim.model.boundaries.DEFAULT_LAYER_WIDTH, 30)
"""The default layer and a deep one (particles)."""
DEFAULT_WAVELENGTHS = (5.0, 10.0, 20.0, 30.0, 40.0, 60.0, 80.0)

SHORTEST_WAVELENGTH = 2.5
"""Shortest wavelength (in spacings) measured: at lambda = 2 a the group velocity is zero."""


def chain_integrator() -> str:
    """The integrator of every run: the most accurate compiled one (RK4), whose numerical damping
    of short waves the control run measures."""
    return most_accurate()


def group_velocity(wavelength: float, stiffness: float = STIFFNESS, mass: float = MASS,
                   spacing: float = 1.0) -> float:
    """c_g = d omega / d q = a sqrt(k/m) cos(q a / 2) (m/s) of the monatomic chain at
    q = 2 pi / (wavelength a)."""
    q = 2 * math.pi / (wavelength * spacing)
    return spacing * math.sqrt(stiffness / mass) * math.cos(q * spacing / 2)


def packet_scene(width: int, wavelength: float, boundary: str = "absorbing",
                 strength: float = DEFAULT_LAYER_STRENGTH, distance: int = DISTANCE) -> sim.Scene:
    """The chain of ``2 (distance + width)`` particles with the wave packet in its middle, at
    rest; ``boundary`` "absorbing" (a ``width``-deep sponge at both ends) or "fixed" (the
    control)."""
    particles = 2 * (distance + width)
    model = sim.Model.create(
        particles, 1, stiffness=STIFFNESS, mass=MASS, linear=True, boundary=boundary,
        sponge_width=width, sponge_strength=strength,
    )
    x = np.arange(particles, dtype=float)
    centre = (particles - 1) / 2
    envelope = np.exp(-0.5 * ((x - centre) / wavelength) ** 2)
    displacement = PACKET_AMPLITUDE * envelope * np.cos(2 * math.pi * (x - centre) / wavelength)
    positions = model.rest_positions.copy()
    positions[:, 0] += displacement
    return sim.Scene(name=f"packet-{wavelength:g}a-{boundary}-{width}", model=model,
                     integrator=chain_integrator(), dt=DT, initial_positions=positions)


def chain_energy(simulation: sim.Simulation, first: int, stop: int) -> float:
    """Kinetic + spring energy (J) of particles ``first`` .. ``stop - 1`` of a linearised chain
    moving along its length, counting only the springs between two of them."""
    displacement = simulation.positions[first:stop, 0] - simulation.rest_positions[first:stop, 0]
    velocity = simulation.velocities[first:stop, 0]
    masses = np.asarray(simulation.masses, dtype=float).ravel()[first:stop]
    stiffness = simulation.model.stiffness
    return float(0.5 * np.sum(masses * velocity**2)
                 + 0.5 * stiffness * np.sum(np.diff(displacement) ** 2))


def measure_reflection(width: int, wavelength: float, boundary: str = "absorbing",
                       strength: float = DEFAULT_LAYER_STRENGTH,
                       distance: int = DISTANCE, angle: float = 0.0) -> float:
    """Energy fraction left between the layers at t = 2 distance / c_g (see the module
    docstring); with ``boundary="fixed"`` the same interior of a chain with fixed walls.
    ``angle`` 45 (degrees from the wall's normal) measures oblique incidence on a strip
    instead (``app.study.reflection_angle``)."""
    if angle:
        return reflection_angle.measure(width, wavelength, angle, strength, distance, boundary)
    scene = packet_scene(width, wavelength, boundary, strength, distance)
    simulation = sim.Simulation(scene)
    particles = scene.model.nx
    start = chain_energy(simulation, 0, particles)
    until = 2 * distance / group_velocity(wavelength)
    simulation.step(int(round(until / DT)))
    return chain_energy(simulation, width, particles - width) / start


@dataclasses.dataclass(frozen=True)
class ReflectionStudy:
    """``fractions[i, j]``: reflected energy fraction for ``wavelengths[i]`` (in spacings) and
    layer ``widths[j]`` (particles); ``fixed_walls[i]``: the control's fraction (None if not
    run)."""

    widths: tuple[int, ...]
    wavelengths: tuple[float, ...]
    strength: float
    distance: int
    fractions: np.ndarray
    fixed_walls: tuple[float, ...] | None
    angle: float = 0.0
    """Incidence angle (degrees from the walls' normal)."""

    def as_dict(self) -> dict[str, Any]:
        rows = []
        for index, wavelength in enumerate(self.wavelengths):
            row: dict[str, Any] = dict(
                wavelength=wavelength, group_velocity=group_velocity(wavelength),
                reflected={str(width): float(self.fractions[index, column])
                           for column, width in enumerate(self.widths)},
            )
            if self.fixed_walls is not None:
                row["fixed_walls"] = self.fixed_walls[index]
            rows.append(row)
        return dict(
            chain=dict(stiffness=STIFFNESS, mass=MASS, spacing=1.0, distance=self.distance,
                       integrator=chain_integrator(), dt=DT),
            sponge_strength=self.strength, sponge_power=SPONGE_POWER, widths=list(self.widths),
            angle=self.angle,
            measurements=rows,
        )

    def good_range(self, width: int, limit: float = 0.01) -> tuple[float, float] | None:
        """(shortest, longest) of the wavelengths measured whose reflection off a ``width``
        layer is at most ``limit``; None if none is."""
        column = self.widths.index(width)
        good = [wavelength for index, wavelength in enumerate(self.wavelengths)
                if self.fractions[index, column] <= limit]
        return (min(good), max(good)) if good else None


def reflection_study(
    widths: Sequence[int] = DEFAULT_WIDTHS, wavelengths: Sequence[float] = DEFAULT_WAVELENGTHS,
    strength: float = DEFAULT_LAYER_STRENGTH, distance: int = DISTANCE, control: bool = True,
    progress: ProgressCallback | None = None, angle: float = 0.0,
) -> ReflectionStudy:
    """Measure every (wavelength, width) pair, and the fixed-wall control per wavelength, at
    normal incidence (``angle`` 0) or 45 degrees."""
    check_plan(widths, wavelengths, distance)
    fractions = np.empty((len(wavelengths), len(widths)))
    fixed: list[float] = []
    for row, wavelength in enumerate(wavelengths):
        for column, width in enumerate(widths):
            fractions[row, column] = measure_reflection(width, wavelength, "absorbing", strength,
                                                        distance, angle)
            if progress:
                progress(f"lambda = {wavelength:g} a, width {width}")
        if control:
            fixed.append(measure_reflection(max(widths), wavelength, "fixed", strength, distance,
                                            angle))
            if progress:
                progress(f"lambda = {wavelength:g} a, fixed walls")
    return ReflectionStudy(tuple(int(w) for w in widths), tuple(float(w) for w in wavelengths),
                           float(strength), int(distance), fractions,
                           tuple(fixed) if control else None, float(angle))


def check_plan(widths: Sequence[int], wavelengths: Sequence[float], distance: int) -> None:
    """Raise ValueError when a wavelength or width cannot be measured on this chain."""
    if not widths or not wavelengths:
        raise ValueError("give at least one width and one wavelength")
    for wavelength in wavelengths:
        if wavelength < SHORTEST_WAVELENGTH:
            raise ValueError(
                f"wavelength {wavelength:g} a is too short: from {SHORTEST_WAVELENGTH:g} a up "
                "(at 2 a the group velocity is zero and the packet does not move)"
            )
        if 3 * wavelength > distance:
            raise ValueError(
                f"a packet of wavelength {wavelength:g} a reaches 3 wavelengths from its centre, "
                f"beyond the {distance} particles to the layers; use --distance "
                f"{math.ceil(3 * wavelength)} or more"
            )
    for width in widths:
        if not 1 <= width <= distance:
            raise ValueError(f"layer width {width} must be from 1 to --distance ({distance})")


def planned_runs(widths: Sequence[int], wavelengths: Sequence[float], distance: int,
                 control: bool = True, angle: float = 0.0) -> list[tuple[float, int, str]]:
    """(steps, particles, integrator) of every run, for the CLI's time and step limits."""
    runs = []
    integrator = chain_integrator()
    for wavelength in wavelengths:
        rows, q_x, q_y, _ = reflection_angle.strip_geometry(wavelength, angle)
        speed = reflection_angle.group_velocity_x(q_x, q_y) if angle else group_velocity(wavelength)
        steps = 2 * distance / speed / DT
        runs += [(steps, 2 * (distance + width) * rows, integrator) for width in widths]
        if control:
            runs.append((steps, 2 * (distance + max(widths)) * rows, integrator))
    return runs


def format_report(study: ReflectionStudy) -> str:
    """The table (rows: wavelength; columns: layer widths, then the fixed-wall control)."""
    lines = [
        f"reflected energy fraction of a wave packet (envelope width = one wavelength) off the "
        f"absorbing layer; chain k = {STIFFNESS:g} N/m, m = {MASS:g} kg, a = 1 m, linearised, "
        f"{study.distance} particles from the packet to each layer, "
        f"{describe(chain_integrator()).short_label} dt = {DT:g} s; "
        f"sponge_strength {study.strength:g}",
        "",
    ]
    if study.angle:
        lines[0] = (f"reflected energy fraction at {study.angle:g} degrees from the walls' "
                    f"normal: out-of-plane waves on a strip one half wave wide "
                    f"(app.study.reflection_angle), {study.distance} particles from the packet "
                    f"to each layer; c_g along the normal; sponge_strength {study.strength:g}")
    header = f"{'lambda/a':>8s} {'c_g (m/s)':>9s}" + "".join(
        f" {f'width {width}':>11s}" for width in study.widths)
    if study.fixed_walls is not None:
        header += f" {'fixed walls':>11s}"
    lines.append(header)
    for index, wavelength in enumerate(study.wavelengths):
        speed = group_velocity(wavelength)
        if study.angle:  # along the walls' normal, at the wavelength that fits the strip
            _, q_x, q_y, _ = reflection_angle.strip_geometry(wavelength, study.angle)
            speed = reflection_angle.group_velocity_x(q_x, q_y)
        line = f"{wavelength:8g} {speed:9.3f}" + "".join(
            f" {study.fractions[index, column]:11.2e}" for column in range(len(study.widths)))
        if study.fixed_walls is not None:
            line += f" {study.fixed_walls[index]:11.3f}"
        lines.append(line)
    lines.append("")
    for width in study.widths:
        span = study.good_range(width)
        if span is None:
            lines.append(f"width {width}: above 1 % at every wavelength measured")
        else:
            lines.append(f"width {width}: at most 1 % from lambda = {span[0]:g} a to "
                         f"{span[1]:g} a")
    return "\n".join(lines)


def plot_reflection(studies: ReflectionStudy | Sequence[ReflectionStudy], path: str) -> None:
    """The layers' rate profiles, then per study (incidence angle) the reflection (%, log
    scale) against wavelength per width with the 1 % line; PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if isinstance(studies, ReflectionStudy):
        studies = [studies]
    figure, axes = plt.subplots(
        1, 1 + len(studies), figsize=(5.5 + 5.5 * len(studies), 4.6), sharey=False,
        gridspec_kw=dict(width_ratios=(0.8,) + (1.2,) * len(studies)))
    profile_axis = axes[0]
    first = studies[0]
    colours = plt.cm.viridis(np.linspace(0.05, 0.85, len(first.widths)))
    for width, colour in zip(first.widths, colours, strict=True):
        distance_to_wall = np.arange(0, width + 1)
        depth = np.clip((width - distance_to_wall) / width, 0.0, 1.0)
        profile_axis.plot(distance_to_wall, first.strength * depth**SPONGE_POWER, "o-",
                          color=colour, markersize=2.5, label=f"width {width}")
    profile_axis.set_xlabel("distance from the wall (particles)")
    profile_axis.set_ylabel("rate / sqrt(k/m)")
    profile_axis.set_title("matched layer's rate: strength x depth^2", fontsize=10)
    profile_axis.invert_xaxis()
    profile_axis.legend(fontsize=8)
    for study, axis in zip(studies, axes[1:], strict=True):
        _plot_curves(study, axis, colours)
    # one legend for the curves' panels, below them: inside, it hid points whatever the corner
    handles, labels = axes[1].get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=9,
                  bbox_to_anchor=(0.5 + 0.08 * (len(studies) > 1), 0.0), frameon=False)
    figure.tight_layout(rect=(0, 0.07, 1, 1))
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _plot_curves(study: ReflectionStudy, axis: Any, colours: Any) -> None:
    """One study's reflection (%) against wavelength per width, the control and the 1 % line."""
    for column, (width, colour) in enumerate(zip(study.widths, colours, strict=True)):
        axis.plot(study.wavelengths, 100 * study.fractions[:, column], "o-", color=colour,
                  label=f"layer {width} particles deep")
    if study.fixed_walls is not None:
        axis.plot(study.wavelengths, 100 * np.asarray(study.fixed_walls), "s--", color="grey",
                  label="fixed walls (control)")
    axis.axhline(1.0, color="tab:red", linestyle=":", linewidth=1.2)
    axis.text(study.wavelengths[0], 1.15, "1 %", color="tab:red", fontsize=9)
    axis.set_yscale("log")
    axis.set_xlabel("wavelength / a")
    axis.set_ylabel("reflected energy (%)")
    axis.set_title(f"incidence {study.angle:g} deg from the normal (sponge_strength "
                   f"{study.strength:g}; {describe(chain_integrator()).short_label} "
                   f"dt = {DT:g} s)", fontsize=10)
    axis.grid(True, which="major", alpha=0.3)
