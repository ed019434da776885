"""Independent theory for the tests: the linearised lattice built by hand, spring by spring.

Nothing here imports the simulation's force code; it assembles the stiffness matrix of a
rectangular lattice with wall anchors from the spring list written out in loops, so the tests
compare the simulation with an independent computation.
"""

from __future__ import annotations

import numpy as np


def lattice_springs(nx: int, ny: int):
    """Yield (first, second, axis) for every spring; an index of -1 is a wall anchor.

    Particles are numbered p = j * nx + i; axis 0 is horizontal, 1 vertical.
    """
    for j in range(ny):
        for i in range(nx + 1):
            left = j * nx + i - 1 if i > 0 else -1
            right = j * nx + i if i < nx else -1
            yield left, right, 0
    for j in range(ny + 1):
        for i in range(nx):
            lower = (j - 1) * nx + i if j > 0 else -1
            upper = j * nx + i if j < ny else -1
            yield lower, upper, 1


def stiffness_matrix(nx: int, ny: int, dim: int, stiffness: float, tension_over_spacing: float):
    """(n*dim, n*dim) stiffness matrix K of the lattice linearised about rest (K u = -force);
    degrees of freedom ordered particle-major: index p * dim + component."""
    n = nx * ny
    matrix = np.zeros((n * dim, n * dim))
    for first, second, axis in lattice_springs(nx, ny):
        block = np.full(dim, tension_over_spacing)
        block[axis] = stiffness
        block = np.diag(block)
        for a, b in ((first, second), (second, first)):
            if a < 0:
                continue
            matrix[a * dim : (a + 1) * dim, a * dim : (a + 1) * dim] += block
            if b >= 0:
                matrix[a * dim : (a + 1) * dim, b * dim : (b + 1) * dim] -= block
    return matrix


def exact_linear_motion(stiffness_matrix, masses_per_dof, displacement0, velocity0, time):
    """Exact solution u(t) of M u'' = -K u from u(0), u'(0) by normal modes (flat arrays)."""
    inverse_sqrt = 1.0 / np.sqrt(masses_per_dof)
    symmetric = stiffness_matrix * np.outer(inverse_sqrt, inverse_sqrt)
    omega_squared, modes = np.linalg.eigh(symmetric)
    omega = np.sqrt(np.maximum(omega_squared, 0.0))
    q0 = modes.T @ (displacement0 / inverse_sqrt)
    p0 = modes.T @ (velocity0 / inverse_sqrt)
    with np.errstate(divide="ignore", invalid="ignore"):
        sine_term = np.where(omega > 0, np.sin(omega * time) / omega, time)
    q = q0 * np.cos(omega * time) + p0 * sine_term
    p = -q0 * omega * np.sin(omega * time) + p0 * np.cos(omega * time)
    return (modes @ q) * inverse_sqrt, (modes @ p) * inverse_sqrt
