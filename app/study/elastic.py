"""The elastic solid measured: the P and S wave speeds of a lattice with diagonal springs, and
its two in-plane branches along an axis, against the Lame parameters of its springs.

* Speeds (``measure_speeds``): the ``elastic-solid`` preset (a pulse pushed along x in the
  middle) is run; the displacement u_x is recorded along the middle row (the P wave: motion
  along its path) and along the middle column (the S wave: motion across its path).  The time
  of the largest |u_x| at each distance from 15 to 45 spacings is fitted by a line; its inverse
  slope is the measured speed, against sqrt((lambda + 2 mu) / rho) and sqrt(mu / rho)
  (``sim.theory.lattice_waves.elastic_constants``).  The fit over distances cancels the time
  the 2-D pulse takes to form its front.
* Branches (``measure_branches``): a column of the lattice whose rows are rings of two
  particles (``boundary="periodic"``), between walls at its ends, linearised, is given a
  random displacement that is the same in every column, so that only waves along y (q_x = 0)
  exist: u_y is the P branch, u_x the S branch, each a standing wave sin(p pi j / (ny + 1)).
  Their space-time spectra (as ``app.study.dispersion``) give each branch's frequency at each
  q, against omega = 2 sqrt((k + k2) / m) |sin(q a / 2)| (P) and 2 sqrt((T/a + k2) / m)
  |sin(q a / 2)| (S), the eigenvalues of the dynamical matrix at q_x = 0.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

import sim
from app.study.dispersion import ProgressCallback, peak_frequencies, sine_transform
from sim.integrators.registry import most_accurate
from sim.theory.lattice_waves import elastic_constants, in_plane_omegas

FIT_DISTANCES = (15.0, 45.0)
"""Distances (spacings) from the pulse over which the arrival times are fitted."""


def measure_speeds(scene: sim.Scene | None = None, sample_interval: float = 0.04,
                   progress: ProgressCallback | None = None) -> dict[str, float]:
    """Measured P and S speeds (m/s) of the ``elastic-solid`` scene (or ``scene``, a pulse in
    the middle pushed along x) and the theory's, with their relative errors."""
    scene = scene or sim.scenes.build("elastic-solid")
    model = scene.model
    constants = elastic_constants(model)
    a = model.spacing
    far = FIT_DISTANCES[1] * a
    if min(model.nx, model.ny) // 2 <= FIT_DISTANCES[1]:
        raise ValueError(f"the lattice must reach {FIT_DISTANCES[1]:g} spacings from its middle")
    duration = far / constants["s_speed"] + 4 * a / constants["s_speed"]
    simulation = sim.Simulation(scene, integrator=scene.integrator, dt=scene.dt)
    steps = max(1, round(sample_interval / scene.dt))
    column, row = model.nx // 2, model.ny // 2
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)
    times, along_row, along_column = [], [], []
    samples = int(math.ceil(duration / (steps * scene.dt)))
    for index in range(samples):
        times.append(simulation.time)
        along_row.append(simulation.state.positions[0, row, column:] - rest[0, row, column:])
        along_column.append(simulation.state.positions[0, row:, column] - rest[0, row:, column])
        simulation.step(steps)
        if progress and index % max(1, samples // 10) == 0:
            progress(f"elastic solid: t = {simulation.time:.3g} s")
    result: dict[str, float] = {}
    for name, series in (("p", np.array(along_row)), ("s", np.array(along_column))):
        distance = np.arange(series.shape[1]) * a
        kept = np.flatnonzero((distance >= FIT_DISTANCES[0] * a) & (distance <= far))
        arrival = np.array(times)[np.argmax(np.abs(series[:, kept]), axis=0)]
        slope, _ = np.polyfit(distance[kept], arrival, 1)
        result[f"{name}_speed_measured"] = float(1.0 / slope)
        result[f"{name}_speed_theory"] = constants[f"{name}_speed"]
        result[f"{name}_speed_relative_error"] = float(
            result[f"{name}_speed_measured"] / constants[f"{name}_speed"] - 1)
    return result


def branch_strip(rows: int, stiffness: float, diagonal_stiffness: float, mass: float,
                 seed: int = 1) -> sim.Scene:
    """A column of ``rows`` rows, each a ring of two particles, linearised and unstressed,
    displaced at random by 1 % of a spacing, the same in both columns (q_x = 0)."""
    scene = sim.scenes.build("grid", nx=2, ny=rows, stiffness=stiffness, mass=mass,
                             diagonal_stiffness=diagonal_stiffness, boundary="periodic",
                             linear=True)
    model = scene.model
    rng = np.random.default_rng(seed)
    positions = model.rest_positions.copy()
    shift = 0.01 * model.spacing * rng.standard_normal((rows, 1, 2))
    positions[:, :2] += np.broadcast_to(shift, (rows, 2, 2)).reshape(-1, 2)
    return dataclasses.replace(scene, initial_positions=positions,
                               initial_velocities=np.zeros_like(positions))


def measure_branches(rows: int = 200, stiffness: float = 35.0, diagonal_stiffness: float = 17.5,
                     mass: float = 1.0, duration: float = 200.0, sample_interval: float = 0.1,
                     progress: ProgressCallback | None = None) -> dict[str, Any]:
    """The P and S branches along y measured on ``branch_strip`` (see the module docstring):
    q (rad/m), measured and theoretical omega (rad/s) of each branch."""
    scene = branch_strip(rows, stiffness, diagonal_stiffness, mass)
    model = scene.model
    omega_max = 2 * math.sqrt((stiffness + diagonal_stiffness) / mass)
    steps = max(1, math.ceil(sample_interval * omega_max / 0.1))
    simulation = sim.Simulation(scene, integrator=most_accurate(model),
                                dt=sample_interval / steps)
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)[:, :, 0]
    samples = int(round(duration / sample_interval))
    record = np.empty((samples, 2, rows))
    for index in range(samples):
        record[index] = simulation.state.positions[:2, :, 0] - rest[:2]
        simulation.step(steps)
        if progress and index % max(1, samples // 10) == 0:
            progress(f"branches: t = {simulation.time:.4g} s")
    q = np.arange(1, rows + 1) * math.pi / ((rows + 1) * model.spacing)
    s_measured, _ = peak_frequencies(sine_transform(record[:, 0]), sample_interval)
    p_measured, _ = peak_frequencies(sine_transform(record[:, 1]), sample_interval)
    s_theory, p_theory = in_plane_omegas(model, np.zeros_like(q), q)
    if diagonal_stiffness + model.tension_stiffness > stiffness + diagonal_stiffness:
        s_theory, p_theory = p_theory, s_theory  # the lower branch is then the P one
    return dict(q=q, p_measured=p_measured, p_theory=p_theory, s_measured=s_measured,
                s_theory=s_theory)


def branch_checkpoints(branches: dict[str, Any], fractions=(0.1, 0.25, 0.5, 0.75)) -> list[dict]:
    """Measured and theoretical frequencies of both branches at a few q a / pi."""
    rows = []
    count = branches["q"].size
    for fraction in fractions:
        p = max(1, int(round(fraction * (count + 1)))) - 1
        rows.append({key: float(branches[key][p]) for key in
                     ("q", "p_measured", "p_theory", "s_measured", "s_theory")})
    return rows


def format_report(speeds: dict[str, float], branches: dict[str, Any], spacing: float = 1.0) -> str:
    """The measured speeds and branches as text."""
    lines = [
        f"P wave: measured {speeds['p_speed_measured']:.4g} m/s, sqrt((lambda + 2 mu) / rho) = "
        f"{speeds['p_speed_theory']:.4g} m/s ({speeds['p_speed_relative_error']:+.2%})",
        f"S wave: measured {speeds['s_speed_measured']:.4g} m/s, sqrt(mu / rho) = "
        f"{speeds['s_speed_theory']:.4g} m/s ({speeds['s_speed_relative_error']:+.2%})",
        "",
        "branches along y (q_x = 0), rad/s:",
        f"{'q a / pi':>9s} {'P measured':>11s} {'P theory':>9s} {'S measured':>11s} "
        f"{'S theory':>9s}",
    ]
    for row in branch_checkpoints(branches):
        lines.append(f"{row['q'] * spacing / math.pi:9.3f} {row['p_measured']:11.5g} "
                     f"{row['p_theory']:9.5g} {row['s_measured']:11.5g} {row['s_theory']:9.5g}")
    return "\n".join(lines)
