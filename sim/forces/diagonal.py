"""The diagonal (next-nearest-neighbour) springs: particle (i, j) joined to (i +- 1, j + 1).

The nearest springs alone give a square lattice no shear stiffness beyond their rest tension;
the diagonal springs, of stiffness k2 (N/m, ``SpringParameters.diagonal_stiffness``; None
compiles them out), make it an elastic solid (``docs/continuum.md``).  They are unstressed in
the rest lattice: rest length sqrt(2) a, whatever the nearest springs' tension.  They have no
dashpot.  Walls: every site outside the lattice (the wall anchors, the corners included) is a
fixed rest site, so the lattice between walls is a piece of the infinite lattice held at rest
outside; a ring (``periodic``) wraps the columns; free row ends (``free_ends``) have no
diagonal spring to the left and right walls.

Law: force on the lower end F = k2 (|d| - sqrt(2) a) d / |d|, d = r_upper - r_lower; the
linearised law keeps the stiffness along the rest direction n = (s, 1) / sqrt(2) only
(s = +1: the spring leans right, from column i - 1 below to i above; s = -1: leans left,
from column i + 1 below), F = k2 ((d - d0) . n) n, and has nothing across it (an unstressed
spring has no tension).

The springs between rows j - 1 and j are computed in the same pass as the vertical springs
(``sim.forces.springs.vertical_springs``), into rows 3 .. 8 of the same buffer (``ROWS`` x nx):
rows 3 + c hold the net force (N) of these springs on the upper row's particles, rows 6 + c on
the lower row's.  So every loop shape that keeps the buffers below and above a row has the
diagonal springs' forces with no change but the buffer's size (``ROWS``).

``numpy_forces`` and ``numpy_energy`` are the same physics written with numpy over a padded
field, independently of the kernels, for the tests and the reference integrators.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sim.forces.term import ForceTerm, KernelField, LinearStiffness, Parameter

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

ROWS = 9
"""Rows of a vertical-spring buffer: the vertical springs' forces (3), the diagonal springs' net
force on the upper row's particles (3) and on the lower row's (3)."""
UPPER, LOWER = 3, 6
"""First buffer row of the diagonal springs' net force on the upper and on the lower row."""


@njit(**_JIT)
def _end(x, y, z, i, j, ny, parameters):
    """Position (x, y, z) of column i (-1 .. nx) in row j (-1 .. ny): a particle (row j kept at
    index j % rows), its ring image (``periodic``), or a fixed rest site outside the lattice."""
    T = type(parameters.spacing)
    zero = T(0.0)
    nx = x.shape[1]
    if j < 0 or j >= ny or ((i < 0 or i >= nx) and parameters.periodic is None):
        return (parameters.origin_x + T(i) * parameters.spacing,
                parameters.origin_y + T(j) * parameters.spacing, zero)
    shift = zero
    if i < 0:
        i += nx
        shift = -T(nx) * parameters.spacing
    elif i >= nx:
        i -= nx
        shift = T(nx) * parameters.spacing
    r = j % x.shape[0]
    if z is None:
        return (x[r, i] + shift, y[r, i], zero)
    return (x[r, i] + shift, y[r, i], z[r, i])


@njit(**_JIT)
def diagonal_force(lower, upper, lean, linearised, k2, parameters):
    """Force (fx, fy, fz) (N) on the lower end of one diagonal spring and its energy (J);
    ``lean`` +1 if the upper end is one column right of the lower, -1 if left."""
    T = type(parameters.spacing)
    a = parameters.spacing
    dx = upper[0] - lower[0]
    dy = upper[1] - lower[1]
    dz = upper[2] - lower[2]
    if linearised is not None:
        stretch = T(lean) * dx + dy - T(2.0) * a  # sqrt(2) x the stretch along the spring
        half = T(0.5) * k2 * stretch
        return T(lean) * half, half, T(0.0), T(0.25) * k2 * stretch * stretch
    squared = max(dx * dx + dy * dy + dz * dz, parameters.smallest_squared_length)
    length = np.sqrt(squared)
    stretch = length - T(math.sqrt(2.0)) * a
    factor = k2 * stretch / length
    return factor * dx, factor * dy, factor * dz, T(0.5) * k2 * stretch * stretch


@njit(**_JIT)
def _springs_between(j, ny, x, y, z, linearised, k2, parameters, out):
    """The diagonal springs between rows j - 1 and j: their net forces into ``out`` (when not
    None) and their energy (J), returned."""
    nx = x.shape[1]
    ring = parameters.periodic is not None
    free = parameters.free_ends is not None
    energy = 0.0
    if out is not None:
        for c in range(UPPER, UPPER + 6):
            for i in range(nx):
                out[c, i] = 0.0
    for lean in (1, -1):
        # the spring whose upper end is column u and lower end column u - lean
        first, last = (0, nx) if lean == 1 else (-1, nx - 1)
        if ring:
            first, last = 0, nx - 1
        elif free:
            first, last = (1, nx - 1) if lean == 1 else (0, nx - 2)
        for u in range(first, last + 1):
            low = u - lean
            lower_site = j == 0 or (not ring and (low < 0 or low >= nx))
            if lower_site and (j == ny or (not ring and (u < 0 or u >= nx))):
                continue  # between two wall sites
            fx, fy, fz, e = diagonal_force(_end(x, y, z, low, j - 1, ny, parameters),
                                           _end(x, y, z, u, j, ny, parameters), lean,
                                           linearised, k2, parameters)
            energy += e
            if out is None:
                continue
            if j < ny and 0 <= u < nx:
                out[UPPER, u] -= fx
                out[UPPER + 1, u] -= fy
                out[UPPER + 2, u] -= fz
            if ring:
                low = low % nx
            if j > 0 and 0 <= low < nx:
                out[LOWER, low] += fx
                out[LOWER + 1, low] += fy
                out[LOWER + 2, low] += fz
    return energy


@njit(**_JIT)
def diagonal_springs(k2, j, ny, x, y, z, linearised, parameters, out):
    """Net forces of the diagonal springs between rows j - 1 and j into rows 3 .. 8 of ``out``
    (``ROWS``, nx) (j = 0: from the bottom wall's sites; j = ny: to the top wall's).  ``k2``
    None: no diagonal springs, compiled to nothing."""
    if k2 is None:
        return
    _springs_between(j, ny, x, y, z, linearised, k2, parameters, out)


@njit(**_JIT)
def diagonal_net(k2, below, above, i):
    """Net force (fx, fy, fz) of the diagonal springs on particle i of a row whose buffers below
    and above are ``below`` and ``above``; zeros (folded away by the compiler) when there are
    none (``k2`` None)."""
    if k2 is None:
        zero = below.dtype.type(0.0)
        return (zero, zero, zero)
    return (below[UPPER, i] + above[LOWER, i], below[UPPER + 1, i] + above[LOWER + 1, i],
            below[UPPER + 2, i] + above[LOWER + 2, i])


@njit(**_JIT)
def diagonal_energy(k2, x, y, z, linear, parameters):
    """Energy (J) of every diagonal spring of a state ((ny, nx) arrays), 0 without them."""
    if k2 is None:
        return 0.0
    ny = x.shape[0]
    energy = 0.0
    for j in range(ny + 1):
        energy += _energy_between(j, ny, x, y, z, linear, k2, parameters)
    return energy


@njit(**_JIT)
def _energy_between(j, ny, x, y, z, linear, k2, parameters):
    """Energy (J) of the diagonal springs between rows j - 1 and j, ``linear`` true for the
    linearised law (a run-time flag, made the compile-time choice ``_springs_between`` takes)."""
    if linear:
        return _springs_between(j, ny, x, y, z, True, k2, parameters, None)
    return _springs_between(j, ny, x, y, z, None, k2, parameters, None)


@njit(**_JIT)
def diagonal_energy_around(k2, j, x, y, z, linear, parameters):
    """Energy (J) of the diagonal springs between rows j - 1 and j + 1 (those of row j's
    particles, and others of those rows that they do not move): the diagonal springs' part of
    the energy around one particle of row j, for the difference a move of it makes (the
    driver's prescribed displacements).  0 without them (``k2`` None)."""
    if k2 is None:
        return 0.0
    ny = x.shape[0]
    return (_energy_between(j, ny, x, y, z, linear, k2, parameters)
            + _energy_between(j + 1, ny, x, y, z, linear, k2, parameters))


# --- the same physics in numpy, for the tests and the reference integrators -------------------


def _padded_positions(positions: np.ndarray, spacing: float, origin: tuple[float, float],
                      row_ends: str) -> np.ndarray:
    """(dim, ny + 2, nx + 2): the positions with a ring of rest sites around them (a ring's
    columns wrapped, shifted by nx a)."""
    dim, ny, nx = positions.shape
    padded = np.zeros((dim, ny + 2, nx + 2))
    padded[0] = (origin[0] + (np.arange(nx + 2) - 1) * spacing)[None, :]
    padded[1] = (origin[1] + (np.arange(ny + 2) - 1) * spacing)[:, None]
    padded[:, 1:-1, 1:-1] = positions
    if row_ends == "ring":
        padded[:, 1:-1, 0] = positions[:, :, -1]
        padded[:, 1:-1, -1] = positions[:, :, 0]
        padded[0, 1:-1, 0] -= nx * spacing
        padded[0, 1:-1, -1] += nx * spacing
    return padded


def _numpy_springs(positions, stiffness, spacing, origin, row_ends, linear):
    """Per lean: (force on the lower ends, energy, mask of the springs that exist), each over the
    (ny + 1, nx + 1) springs of the padded field that join a lattice particle."""
    padded = _padded_positions(positions, spacing, origin, row_ends)
    dim, ny, nx = positions.shape
    result = []
    for lean in (1, -1):
        if lean == 1:  # lower (i - 1, j - 1) -> upper (i, j), padded columns 0..nx / 1..nx+1
            lower, upper = padded[:, :-1, :-1], padded[:, 1:, 1:]
        else:
            lower, upper = padded[:, :-1, 1:], padded[:, 1:, :-1]
        d = upper - lower
        if linear:
            stretch = lean * d[0] + d[1] - 2 * spacing
            force = np.zeros_like(d)
            force[0] = 0.5 * stiffness * stretch * lean
            force[1] = 0.5 * stiffness * stretch
            energy = 0.25 * stiffness * stretch**2
        else:
            length = np.sqrt((d**2).sum(axis=0))
            stretch = length - np.sqrt(2) * spacing
            force = stiffness * stretch / length * d
            energy = 0.5 * stiffness * stretch**2
        # a spring exists when one end is a particle (a ring's wrapped columns are springs once)
        rows = np.arange(ny + 1)[:, None]
        columns = np.arange(nx + 1)[None, :]
        lower_column = columns if lean == 1 else columns + 1  # padded column of the lower end
        upper_column = columns + 1 if lean == 1 else columns
        inside = lambda column: (column >= 1) & (column <= nx)  # noqa: E731
        joined = ((rows >= 1) & inside(lower_column)) | ((rows <= ny - 1) & inside(upper_column))
        if row_ends == "ring":  # a wrapped column is a particle's image: each spring once
            joined = inside(upper_column) & (rows >= 0)
        elif row_ends == "free":
            joined = joined & inside(upper_column) & inside(lower_column)
        result.append((force * joined, energy * joined, lower_column, upper_column))
    return result


def numpy_forces(positions: np.ndarray, stiffness: float, spacing: float,
                 origin: tuple[float, float], row_ends: str = "walls",
                 linear: bool = False) -> np.ndarray:
    """(dim, ny, nx) net force (N) of the diagonal springs on every particle; ``positions``
    (dim, ny, nx) m, ``row_ends`` "walls", "ring" or "free"."""
    dim, ny, nx = positions.shape
    total = np.zeros((dim, ny + 2, nx + 2))
    for force, _, lower_column, upper_column in _numpy_springs(positions, stiffness, spacing,
                                                              origin, row_ends, linear):
        for j in range(ny + 1):
            np.add.at(total, (slice(None), j, lower_column[0]), force[:, j])
            np.add.at(total, (slice(None), j + 1, upper_column[0]), -force[:, j])
    if row_ends == "ring":
        total[:, :, 1] += total[:, :, -1]
        total[:, :, -2] += total[:, :, 0]
    return total[:, 1:-1, 1:-1]


def numpy_energy(positions: np.ndarray, stiffness: float, spacing: float,
                 origin: tuple[float, float], row_ends: str = "walls",
                 linear: bool = False) -> float:
    """Energy (J) of every diagonal spring, as ``numpy_forces``."""
    return float(sum(energy.sum() for _, energy, _, _ in _numpy_springs(
        positions, stiffness, spacing, origin, row_ends, linear)))


TERM = ForceTerm(
    "diagonal springs",
    "next-nearest springs from each particle to the diagonal neighbours above it",
    parameters=(Parameter("diagonal_stiffness", "k₂", "N/m", "Diagonal springs",
                          "spring constant of the diagonal springs (0: none); k₂ = k/2 makes an "
                          "isotropic elastic solid", 0.0, 1e9, 0.0, page=(0.0, 100.0, 0.5)),),
    fields=(KernelField("diagonal_stiffness", "springs", "number",
                        lambda model: model.diagonal_stiffness or None),),
    present=lambda model: model.diagonal_stiffness > 0,
    describe=lambda model: f"diagonal springs k2={model.diagonal_stiffness:g}",
    example={"diagonal_stiffness": 17.5},
    leapfrog=False,
    absorbing_layer=False,
    numpy_force=lambda model, positions, velocities: numpy_forces(
        positions, model.diagonal_stiffness, model.spacing, model.origin, model.row_ends,
        model.linear),
    numpy_energy=lambda model, positions: numpy_energy(
        positions, model.diagonal_stiffness, model.spacing, model.origin, model.row_ends,
        model.linear),
    linear_stiffness=lambda model: LinearStiffness(diagonal=model.diagonal_stiffness),
)
