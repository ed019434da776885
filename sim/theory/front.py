"""When the wave front of a scene's sources has passed a column of the lattice.

A source switched on at ``start`` and ramped up over ``ramp`` seconds sends waves at its driving
frequency; their energy travels at the lattice's group velocity at that frequency
(``sim.theory.lattice_waves``: d omega / d q of the wave whose group velocity points along the path,
slower than the long-wave speed on a discrete lattice).  The full-amplitude wave has reached a
point once ``start + ramp + path / speed`` has passed.  The path to a column runs from the source
to the column's farthest row (a whole-column source sends a plane wave: straight along x); with a
column barrier with openings between them it runs to the nearest opening first and from there to
the column's farthest row (the slits are the screen's sources).  Observing a state changes
nothing; this only reads a model.
"""

from __future__ import annotations

import math

import numpy as np

from sim.model.lattice import Model
from sim.theory import lattice_waves

COMPONENTS = ("x", "y", "z")


RAY_SAMPLES = 4096
"""Wave vectors sampled round the frequency contour to find the group speed along a path."""


def _speeds(wave: lattice_waves.Polarisation, omega: float):
    """A function (dx, dy) -> group speed (m/s) at ``omega`` of the wave whose energy travels
    along (dx, dy): the contour sampled at ``RAY_SAMPLES`` wave vectors, the one whose group
    velocity points closest to the path taken."""
    angles = np.linspace(-math.pi, math.pi, RAY_SAMPLES, endpoint=False)
    qx, qy, _ = wave.contour(omega, angles)
    keep = np.isfinite(qx)
    if not np.any(keep):
        raise lattice_waves.WaveError(
            f"omega = {omega:.4g} rad/s is above every frequency the lattice carries")
    velocities = np.array([wave.group_velocity(x, y) for x, y in zip(qx[keep], qy[keep],
                                                                     strict=True)])
    directions = np.arctan2(velocities[:, 1], velocities[:, 0])
    speeds = np.hypot(velocities[:, 0], velocities[:, 1])

    def speed(dx: float, dy: float) -> float:
        offsets = np.abs(np.angle(np.exp(1j * (directions - math.atan2(dy, dx)))))
        return float(speeds[int(np.argmin(offsets))])

    return speed


def _column_barrier(model: Model, source_x: float, column_x: float):
    """The first column barrier with openings strictly between x = source_x and column_x."""
    low, high = sorted((source_x, column_x))
    for barrier in model.barriers:
        x = model.origin[0] + barrier.index * model.spacing
        if barrier.axis == "column" and barrier.openings and low < x < high:
            return barrier, x
    return None


def arrival_times(model: Model, column: int) -> np.ndarray | None:
    """(ny,) times (s) after which the full-amplitude wave of every source (and the driver) has
    reached each row of ``column``; None without a source.  Raises
    ``sim.theory.lattice_waves.WaveError`` when the lattice carries no wave at a source's frequency."""
    drivers = ((model.driver,) if model.driver is not None else ()) + tuple(model.sources)
    if not drivers:
        return None
    a = float(model.spacing)
    x0, y0 = (float(v) for v in model.origin[:2])
    column_x = x0 + column * a
    rows_y = y0 + a * np.arange(model.ny)
    latest = np.full(model.ny, -math.inf)
    for driver in drivers:
        direction = driver.direction
        component = COMPONENTS[max(range(model.dim), key=lambda c: abs(direction[c]))]
        speed = _speeds(lattice_waves.polarisation(model, component),
                        2.0 * math.pi * float(driver.frequency))

        def time(dx: float, dy: float, speed=speed) -> float:
            return math.hypot(dx, dy) / speed(dx, dy) if (dx or dy) else 0.0

        source_x = x0 + driver.column * a
        plane = driver.row == "all"
        source_y = None if plane else y0 + int(driver.row) * a
        barrier = _column_barrier(model, source_x, column_x)
        if barrier is None:
            starts = [] if plane else [(source_y, 0.0)]
        else:  # to each opening, then on from the openings (the screen's sources)
            found, barrier_x = barrier
            centres = [y0 + 0.5 * (first + last) * a for first, last in found.openings]
            starts = [(y, time(barrier_x - source_x, 0.0 if plane else y - source_y))
                      for y in centres]
            source_x = barrier_x
        dx = column_x - source_x
        if not starts:  # a plane wave straight along x
            reached = np.full(model.ny, time(dx, 0.0))
        else:
            reached = np.array([min(start + time(dx, row_y - y) for y, start in starts)
                                for row_y in rows_y])
        latest = np.maximum(latest, float(driver.start) + float(driver.ramp) + reached)
    return latest
