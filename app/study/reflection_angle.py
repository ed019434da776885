"""Reflection off the absorbing layer at normal and oblique incidence, measured on transverse
(out-of-plane) waves of a pre-tensioned strip.

The strip: ``2 (distance + width)`` columns by ``rows`` rows, linearised springs (k = 35 N/m,
m = 1 kg, a = 1 m) of rest length ~0 (``REST_LENGTH``), so the tension T = k a makes the
out-of-plane wave obey m z'' = k (second differences of z along x and along y): the same
dispersion along each axis as the longitudinal chain of ``app.study.reflection``.  The
absorbing layers line the left and right walls (``sponge_sides="left,right"``); the bottom and
top walls are fixed.  The packet

    z = A sin(pi m (j + 1) / (rows + 1)) exp(-(x - x0)^2 / (2 lambda^2)) cos(q_x (x - x0))

is one sine mode across the strip (an exact mode of the fixed walls, which the layer's uniform
damping across the strip keeps), so it is two plane waves at angles +-theta to the walls'
normal, tan theta = q_y / q_x, q_y = pi m / (rows + 1), |q| = 2 pi / lambda.  45 degrees is
q_x = q_y: the strip is about lambda / sqrt(2) rows wide (one half wave across it), and the
wavelength is rounded to the one that fits.  (Normal incidence is the chain's measurement:
every mode across a strip between fixed walls has q_y >= pi / (rows + 1).)  As in the
chain, the packet starts at rest in the middle, splits, runs into the layers at the group
velocity along x, and the **reflected fraction** is the energy left between the layers at
t = 2 distance / c_gx over the energy at the start.
"""

from __future__ import annotations

import math

import numpy as np

import sim
from sim.model.boundaries import DEFAULT_LAYER_STRENGTH

STIFFNESS = 35.0
MASS = 1.0
DT = 0.05
DISTANCE = 300
AMPLITUDE = 0.01
REST_LENGTH = 1e-6
"""Rest length (m) of the springs: T = k (a - L) = k a to a part in a million."""


def strip_geometry(wavelength: float, angle: float) -> tuple[int, float, float, float]:
    """(rows, q_x, q_y, wavelength as fitted) of a packet of about ``wavelength`` spacings at
    ``angle`` degrees (0 or 45)."""
    if angle == 0.0:
        return 1, 2 * math.pi / wavelength, 0.0, float(wavelength)
    if angle != 45.0:
        raise ValueError(f"the strip measures 0 and 45 degrees, got {angle:g}")
    rows = max(1, round(wavelength / math.sqrt(2)) - 1)
    q = math.pi / (rows + 1)
    return rows, q, q, 2 * math.pi / math.hypot(q, q)


def group_velocity_x(q_x: float, q_y: float) -> float:
    """d omega / d q_x (m/s) of omega = 2 sqrt(k/m) sqrt(sin^2(q_x/2) + sin^2(q_y/2))."""
    omega = 2 * math.sqrt(STIFFNESS / MASS) * math.hypot(math.sin(q_x / 2), math.sin(q_y / 2))
    return STIFFNESS / MASS * math.sin(q_x) / omega


def strip_energy(simulation: sim.Simulation, first: int, stop: int) -> float:
    """Kinetic + spring energy (J) of columns ``first`` .. ``stop - 1`` of the out-of-plane
    motion, springs between two of them along x, and every spring across (to the walls too)."""
    model = simulation.model
    z = simulation.positions[:, 2].reshape(model.ny, model.nx)[:, first:stop]
    vz = simulation.velocities[:, 2].reshape(model.ny, model.nx)[:, first:stop]
    padded = np.pad(z, ((1, 1), (0, 0)))
    return float(0.5 * MASS * np.sum(vz**2)
                 + 0.5 * STIFFNESS * (np.sum(np.diff(z, axis=1) ** 2)
                                      + np.sum(np.diff(padded, axis=0) ** 2)))


def measure(width: int, wavelength: float, angle: float = 0.0,
            strength: float = DEFAULT_LAYER_STRENGTH, distance: int = DISTANCE,
            boundary: str = "absorbing") -> float:
    """Reflected energy fraction (see the module docstring) of a ``width``-deep layer."""
    if not angle:
        raise ValueError("normal incidence is measured on the chain (app.study.reflection)")
    rows, q_x, q_y, _ = strip_geometry(wavelength, angle)
    columns = 2 * (distance + width)
    extra = dict(sponge_width=width, sponge_strength=strength, sponge_sides="left,right") \
        if boundary == "absorbing" else {}
    model = sim.Model.create(columns, rows, stiffness=STIFFNESS, mass=MASS, rest_length=REST_LENGTH,
                             linear=True, dim=3, boundary=boundary, **extra)
    x = np.arange(columns, dtype=float) - (columns - 1) / 2
    across = np.sin(q_y * (np.arange(rows) + 1)) if q_y else np.ones(rows)
    envelope = np.exp(-0.5 * (x / wavelength) ** 2) * np.cos(q_x * x)
    positions = model.rest_positions.copy()
    positions[:, 2] = AMPLITUDE * np.outer(across, envelope).ravel()
    scene = sim.Scene(name="strip", model=model, integrator="rk4", dt=DT,
                      initial_positions=positions)
    simulation = sim.Simulation(scene)
    start = strip_energy(simulation, 0, columns)
    simulation.step(int(round(2 * distance / group_velocity_x(q_x, q_y) / DT)))
    return strip_energy(simulation, width, columns - width) / start
