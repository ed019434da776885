"""The nearest springs' law along their length: the one place its force and energy are written.

A spring of length |d| and rest length L has the extension s = |d| - L; Hooke's law gives the
force k s along it (on the first end, towards the second: f d with f = k s / |d|) and the
energy k s^2 / 2.  ``tension_factor`` is f, which ``sim.forces.springs`` multiplies by d (``along_force``: the
same law along the rest direction, for the linearised springs);
``axial_energy`` the energy, which ``sim.forces.energy`` and the driver's local energy
(``sim.forces.driver``) sum.  Terms of the law along the spring (``ForceTerm.numpy_axial``)
add to both here, their parameters read from the ``SpringParameters`` record (None: absent,
compiled out).
"""

from __future__ import annotations

from numba import njit

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def tension_factor(squared, inverse_length, parameters):
    """f such that f d is the force (N) on the first end of a spring of squared length
    ``squared`` (m^2, 1/|d| = ``inverse_length``): k (|d| - L) / |d|."""
    stiffness = parameters.stiffness
    return stiffness - stiffness * parameters.rest_length * inverse_length


@njit(**_JIT)
def along_force(stretch, parameters):
    """Force (N) along a spring of the linearised law stretched by ``stretch`` (m) along its
    rest direction: k s."""
    return parameters.stiffness * stretch


@njit(**_JIT)
def axial_energy(stretch, parameters):
    """Energy (J) of a spring extended by ``stretch`` = |d| - L (m): k s^2 / 2."""
    return 0.5 * parameters.stiffness * stretch * stretch
