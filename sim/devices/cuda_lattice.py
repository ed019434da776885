"""The GPU kernel of the planar lattice's velocity Verlet step: nearest springs and fixed walls.

One thread per particle.  ``leapfrog_kernel`` reads the positions of one buffer (``x_in``,
``y_in``), computes the particle's acceleration from its four springs, kicks its velocity by
``kick`` * a and writes its drifted position, x + ``drift`` * v, into the other buffer
(``x_out``, ``y_out``): no thread reads a position another thread writes, so a step is one
launch and the host swaps the buffers.  A step of velocity Verlet is then the leapfrog that
``sim.loops.leapfrog`` runs on the CPU: a first (dt/2, dt) launch, (dt, dt) launches, and a
closing half kick (``drift`` = 0, positions left where they are).

The spring law is the CPU's (``sim.forces.axial.tension_factor`` for Hooke's law; the wall
anchors are the rest sites one spacing outside the lattice, as ``sim.forces.springs.site``), and
the forces on a particle are summed in the CPU's order (right - left + above - below), so the
two devices agree to round-off.  Arrays are (ny, nx), float64 or float32; ``law`` holds the
scalars in the arrays' precision (``law_record``).  The kernel of each precision is made once;
this module is imported only when ``device="cuda"`` is asked for.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numba
import numpy as np
from numba import cuda


class Law(NamedTuple):
    """The scalars the kernel takes, in the arrays' precision: k (N/m), L (m), a (m), the rest
    site of particle (0, 0) (m) and the smallest squared length (m^2)."""

    stiffness: float
    rest_length: float
    spacing: float
    origin_x: float
    origin_y: float
    smallest_squared_length: float


def law_record(parameters, dtype) -> Law:
    """The ``Law`` of a ``sim.forces.springs.SpringParameters`` record in ``dtype``."""
    scalar = np.dtype(dtype).type
    return Law(*(scalar(value) for value in (
        parameters.stiffness, parameters.rest_length, parameters.spacing, parameters.origin_x,
        parameters.origin_y, parameters.smallest_squared_length)))


@functools.cache
def leapfrog_kernel(dtype_name: str):
    """The kernel for arrays of ``dtype_name`` ("float64", "float32"): its arithmetic stays in
    that precision (numba would take an integer times a float32 to float64)."""
    scalar = numba.from_dtype(np.dtype(dtype_name))

    @cuda.jit(device=True, inline=True)
    def factor(dx, dy, law):
        """f such that f (dx, dy) is the force on the first end of a spring with d = (dx, dy):
        k (|d| - L) / |d|, zero-length springs clamped as on the CPU."""
        squared = max(dx * dx + dy * dy, law.smallest_squared_length)
        inverse_length = scalar(1.0) / math.sqrt(squared)
        return law.stiffness - law.stiffness * law.rest_length * inverse_length

    @cuda.jit(device=True, inline=True)
    def end(x, y, i, j, law):
        """The position of column i, row j: a particle, or a wall anchor's rest site outside."""
        ny, nx = x.shape
        if i < 0 or i >= nx or j < 0 or j >= ny:
            return (law.origin_x + scalar(i) * law.spacing,
                    law.origin_y + scalar(j) * law.spacing)
        return x[j, i], y[j, i]

    @cuda.jit
    def kernel(x_in, y_in, x_out, y_out, vx, vy, inverse_mass, law, kick, drift, moves):
        """v += kick a(x_in); x_out = x_in + drift v where ``moves`` (else the positions stay
        in ``x_in``, ``y_in`` and the out buffers are not written)."""
        i, j = cuda.grid(2)
        ny, nx = x_in.shape
        if i >= nx or j >= ny:
            return
        px = x_in[j, i]
        py = y_in[j, i]
        # the force on the left (lower) end of each of the particle's four springs, as the CPU
        # has it
        qx, qy = end(x_in, y_in, i - 1, j, law)
        f = factor(px - qx, py - qy, law)
        left_x, left_y = f * (px - qx), f * (py - qy)
        qx, qy = end(x_in, y_in, i + 1, j, law)
        f = factor(qx - px, qy - py, law)
        right_x, right_y = f * (qx - px), f * (qy - py)
        qx, qy = end(x_in, y_in, i, j - 1, law)
        f = factor(px - qx, py - qy, law)
        below_x, below_y = f * (px - qx), f * (py - qy)
        qx, qy = end(x_in, y_in, i, j + 1, law)
        f = factor(qx - px, qy - py, law)
        above_x, above_y = f * (qx - px), f * (qy - py)
        m = inverse_mass[j, i]
        ax = (right_x - left_x + above_x - below_x) * m
        ay = (right_y - left_y + above_y - below_y) * m
        wx = vx[j, i] + kick * ax
        wy = vy[j, i] + kick * ay
        vx[j, i] = wx
        vy[j, i] = wy
        if moves:
            x_out[j, i] = px + drift * wx
            y_out[j, i] = py + drift * wy

    return kernel


BLOCK = (32, 8)
"""Threads per block (columns, rows): a warp along a row, whose loads are then contiguous."""


def launch_shape(nx: int, ny: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """(blocks, threads per block) covering an nx by ny lattice; blocks no larger than it."""
    threads = (min(BLOCK[0], nx), min(BLOCK[1], ny))
    return ((nx + threads[0] - 1) // threads[0], (ny + threads[1] - 1) // threads[1]), threads
