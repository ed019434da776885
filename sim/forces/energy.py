"""The energy of a state in one compiled pass: kinetic, and that of every spring (the nearest
springs' law as in ``sim.forces.axial``, the diagonal springs' from ``sim.forces.diagonal``),
measured from the rest lattice.  A NaN or infinity anywhere in the state makes the result
non-finite, so the pass doubles as the blow-up check.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from sim.forces.axial import along_energy, axial_energy
from sim.forces.diagonal import diagonal_energy

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def spring_energy(dx, dy, dz, axis, linear, parameters):
    """Energy (J) of one nearest spring with separation (dx, dy, dz), measured from the rest
    lattice; ``axis`` 0 for a horizontal spring, 1 for a vertical one (used by the linearised
    law, ``linear`` true); ``parameters`` a ``SpringParameters`` record."""
    spacing = parameters.spacing
    if linear:
        if axis == 0:
            stretch = dx - spacing
            across = dy * dy + dz * dz
        else:
            stretch = dy - spacing
            across = dx * dx + dz * dz
        return along_energy(stretch, parameters) + 0.5 * parameters.tension_stiffness * across
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    rest_length = parameters.rest_length
    return (axial_energy(length - rest_length, parameters)
            - axial_energy(spacing - rest_length, parameters))


@njit(**_JIT)
def energy_terms(x, y, z, vx, vy, vz, masses, linear, parameters):
    """(kinetic, spring) energy in J of a state, in one pass; (ny, nx) arrays, z/vz None in 2-D.

    The spring energy is measured from the rest lattice.  A NaN or infinity anywhere in the
    state makes the result non-finite, so this doubles as the blow-up check.
    """
    tension_stiffness, spacing = parameters.tension_stiffness, parameters.spacing
    origin_x, origin_y = parameters.origin_x, parameters.origin_y
    ny, nx = x.shape
    kinetic = 0.0
    spring = 0.0
    dz = 0.0
    for j in range(ny):
        row_y_rest = origin_y + j * spacing
        for i in range(nx):
            speed_squared = vx[j, i] * vx[j, i] + vy[j, i] * vy[j, i]
            if vz is not None:
                speed_squared += vz[j, i] * vz[j, i]
            kinetic += 0.5 * masses[j, i] * speed_squared
            # the spring to the left neighbour (or the left wall anchor, or the ring's closing
            # spring from the last particle of the row)
            if i == 0 and parameters.periodic is not None:
                dx = x[j, 0] - (x[j, nx - 1] - nx * spacing)
                dy = y[j, 0] - y[j, nx - 1]
                if z is not None:
                    dz = z[j, 0] - z[j, nx - 1]
            elif i == 0:
                dx = x[j, 0] - (origin_x - spacing)
                dy = y[j, 0] - row_y_rest
                if z is not None:
                    dz = z[j, 0]
            else:
                dx = x[j, i] - x[j, i - 1]
                dy = y[j, i] - y[j, i - 1]
                if z is not None:
                    dz = z[j, i] - z[j, i - 1]
            if i > 0 or parameters.free_ends is None:
                spring += spring_energy(dx, dy, dz, 0, linear, parameters)
            if i > 0 and linear and parameters.free_ends is not None:
                # the rest tension's work T (dx - a), which sums to zero between two walls
                spring += tension_stiffness * spacing * (dx - spacing)
            # the spring to the neighbour below (or the bottom wall anchor)
            if j == 0:
                dx = x[0, i] - (origin_x + i * spacing)
                dy = y[0, i] - (origin_y - spacing)
                if z is not None:
                    dz = z[0, i]
            else:
                dx = x[j, i] - x[j - 1, i]
                dy = y[j, i] - y[j - 1, i]
                if z is not None:
                    dz = z[j, i] - z[j - 1, i]
            spring += spring_energy(dx, dy, dz, 1, linear, parameters)
        if parameters.periodic is None and parameters.free_ends is None:
            # the spring from the last particle of the row to the right wall anchor
            dx = (origin_x + nx * spacing) - x[j, nx - 1]
            dy = row_y_rest - y[j, nx - 1]
            if z is not None:
                dz = -z[j, nx - 1]
            spring += spring_energy(dx, dy, dz, 0, linear, parameters)
    for i in range(nx):  # the springs from the top row to the top wall anchors
        dx = (origin_x + i * spacing) - x[ny - 1, i]
        dy = (origin_y + ny * spacing) - y[ny - 1, i]
        if z is not None:
            dz = -z[ny - 1, i]
        spring += spring_energy(dx, dy, dz, 1, linear, parameters)
    spring += diagonal_energy(parameters.diagonal_stiffness, x, y, z, linear, parameters)
    return kinetic, spring
