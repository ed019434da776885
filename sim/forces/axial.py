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
def _fpu_factor(stretch, alpha, beta):
    """1 + alpha s + beta s^2: the FPU law's force over Hooke's (``sim.forces.fpu``); alpha or
    beta None: that term absent, compiled out."""
    factor = type(stretch)(1.0)
    if alpha is not None:
        factor += alpha * stretch
    if beta is not None:
        factor += beta * stretch * stretch
    return factor


@njit(**_JIT)
def _fpu_energy(stretch, alpha, beta):
    """alpha s^3 / 3 + beta s^4 / 4 (m^2): the FPU law's energy beyond Hooke's, over k."""
    energy = 0.0
    if alpha is not None:
        energy += alpha * stretch * stretch * stretch / 3.0
    if beta is not None:
        energy += beta * stretch * stretch * stretch * stretch / 4.0
    return energy


@njit(**_JIT)
def tension_factor(squared, inverse_length, parameters):
    """f such that f d is the force (N) on the first end of a spring of squared length
    ``squared`` (m^2, 1/|d| = ``inverse_length``): k (|d| - L) / |d|, times the FPU law's
    factor."""
    stiffness, rest_length = parameters.stiffness, parameters.rest_length
    hooke = stiffness - stiffness * rest_length * inverse_length
    stretch = squared * inverse_length - rest_length
    return hooke * _fpu_factor(stretch, parameters.spring_alpha, parameters.spring_beta)


@njit(**_JIT)
def along_force(stretch, parameters):
    """Force (N) along a spring of the linearised law stretched by ``stretch`` (m) along its
    rest direction: k s, times the FPU law's factor."""
    return parameters.stiffness * stretch * _fpu_factor(stretch, parameters.spring_alpha,
                                                        parameters.spring_beta)


@njit(**_JIT)
def axial_energy(stretch, parameters):
    """Energy (J) of a spring extended by ``stretch`` = |d| - L (m): k s^2 / 2, plus the FPU
    law's k (alpha s^3 / 3 + beta s^4 / 4)."""
    return parameters.stiffness * (0.5 * stretch * stretch + _fpu_energy(
        stretch, parameters.spring_alpha, parameters.spring_beta))
