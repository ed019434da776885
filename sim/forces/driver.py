"""Numba kernels of the driver (``sim.model.forcing``): small passes over one particle, applied between
the integrator's steps.

Arrays are the state's ``(dim, ny, nx)`` fields (m, m/s), in float64 or float32; energies are
summed in float64.  Particles are given by flat index ``p = j * nx + i``.
"""

from __future__ import annotations

from numba import njit

from sim.forces.diagonal import diagonal_energy_around
from sim.forces.energy import spring_energy

_JIT = dict(cache=True, nogil=True, error_model="numpy")


@njit(**_JIT)
def kick_particle(velocity, j, i, dvx, dvy, dvz, mass):
    """Add (dvx, dvy, dvz) m/s to the velocity of particle (i, j); returns its kinetic energy
    gain (J), the work of the impulse."""
    dim = velocity.shape[0]
    before = float(velocity[0, j, i]) ** 2 + float(velocity[1, j, i]) ** 2
    velocity[0, j, i] += dvx
    velocity[1, j, i] += dvy
    after = float(velocity[0, j, i]) ** 2 + float(velocity[1, j, i]) ** 2
    if dim == 3:
        before += float(velocity[2, j, i]) ** 2
        velocity[2, j, i] += dvz
        after += float(velocity[2, j, i]) ** 2
    return 0.5 * mass * (after - before)


@njit(**_JIT)
def local_energy(position, velocity, j, i, mass, linear, parameters):
    """Kinetic energy of particle (i, j) plus the energy of its four nearest springs (J),
    measured from the rest lattice, as ``sim.forces.energy.energy_terms`` counts them, and of
    the diagonal springs around its row (``sim.forces.diagonal.diagonal_energy_around``: a move
    of the particle changes this sum by what it changes the lattice's energy);
    ``parameters`` the model's ``SpringParameters`` (float64), ``linear`` true for the linearised
    law.  The rows end in walls one spacing outside the lattice, rings (``periodic``) or free
    ends (``free_ends``)."""
    dim, ny, nx = position.shape
    spacing = parameters.spacing
    row_ends = 1 if parameters.periodic is not None else (
        2 if parameters.free_ends is not None else 0)
    x = float(position[0, j, i])
    y = float(position[1, j, i])
    z = float(position[2, j, i]) if dim == 3 else 0.0
    speed_squared = float(velocity[0, j, i]) ** 2 + float(velocity[1, j, i]) ** 2
    if dim == 3:
        speed_squared += float(velocity[2, j, i]) ** 2
    energy = 0.5 * mass * speed_squared
    k2 = parameters.diagonal_stiffness
    if dim == 3:
        energy += diagonal_energy_around(k2, j, position[0], position[1], position[2], linear,
                                         parameters)
    else:
        energy += diagonal_energy_around(k2, j, position[0], position[1], None, linear,
                                         parameters)
    for side in range(4):
        # neighbour offsets: left, right, below, above
        di = -1 if side == 0 else (1 if side == 1 else 0)
        dj = -1 if side == 2 else (1 if side == 3 else 0)
        ni = i + di
        nj = j + dj
        shift = 0.0
        if row_ends == 2 and (ni < 0 or ni >= nx):
            continue  # a free end has no spring there
        if row_ends == 1 and (ni < 0 or ni >= nx):
            shift = -nx * spacing if ni < 0 else nx * spacing
            ni = ni % nx
        if 0 <= ni < nx and 0 <= nj < ny:
            ox = float(position[0, nj, ni]) + shift
            oy = float(position[1, nj, ni])
            oz = float(position[2, nj, ni]) if dim == 3 else 0.0
        else:
            ox = parameters.origin_x + ni * spacing
            oy = parameters.origin_y + nj * spacing
            oz = 0.0
        # separation from the lower/left end to the upper/right end
        if di < 0 or dj < 0:
            dx, dy, dz = x - ox, y - oy, z - oz
        else:
            dx, dy, dz = ox - x, oy - y, oz - z
        axis = 0 if dj == 0 else 1
        energy += spring_energy(dx, dy, dz, axis, linear, parameters)
        if linear and row_ends == 2 and axis == 0:  # the rest tension's work (free ends)
            energy += parameters.tension_stiffness * spacing * (dx - spacing)
    return energy


@njit(**_JIT)
def place_particle(position, velocity, j, i, px, py, pz, vx, vy, vz):
    """Set the position (m) and velocity (m/s) of particle (i, j)."""
    position[0, j, i] = px
    position[1, j, i] = py
    velocity[0, j, i] = vx
    velocity[1, j, i] = vy
    if position.shape[0] == 3:
        position[2, j, i] = pz
        velocity[2, j, i] = vz
