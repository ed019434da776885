"""The nearest springs' law along their length: the one place its force and energy are written.

A spring of length |d| and rest length L has the extension s = |d| - L; Hooke's law gives the
force k s along it (on the first end, towards the second: f d with f = k s / |d|) and the
energy k s^2 / 2.  ``tension_factor`` is f, which ``sim.forces.springs`` multiplies by d
(``along_force``: the same law along the rest direction, for the linearised springs, about the
rest extension); ``axial_energy`` the energy (``along_energy`` the linearised law's), which
``sim.forces.energy`` and the driver's local energy (``sim.forces.driver``) sum.  Terms of the
law along the spring (``ForceTerm.numpy_axial``) add to both here, their parameters read from
the ``SpringParameters`` record (None: absent, compiled out).
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
def _along_factor(stretch, rest, alpha, beta):
    """1 + alpha (2 s0 + u) + beta (3 s0^2 + 3 s0 u + u^2): the FPU law's F(s0 + u) - F(s0) over
    k u, u = ``stretch``, s0 = ``rest``; alpha or beta None: that term absent, compiled out."""
    factor = type(stretch)(1.0)
    if alpha is not None:
        factor += alpha * (2 * rest + stretch)
    if beta is not None:
        factor += beta * (3 * rest * rest + 3 * rest * stretch + stretch * stretch)
    return factor


@njit(**_JIT)
def _along_energy(stretch, rest, alpha, beta):
    """alpha (s0 u^2 + u^3 / 3) + beta (3/2 s0^2 u^2 + s0 u^3 + u^4 / 4) (m^2): the FPU law's
    W(s0 + u) - W(s0) - F(s0) u beyond Hooke's, over k."""
    energy = 0.0
    if alpha is not None:
        energy += alpha * (rest * stretch * stretch + stretch * stretch * stretch / 3.0)
    if beta is not None:
        energy += beta * (1.5 * rest * rest * stretch * stretch + rest * stretch * stretch * stretch
                          + 0.25 * stretch * stretch * stretch * stretch)
    return energy


@njit(**_JIT)
def along_force(stretch, parameters):
    """Force (N) along a spring of the linearised law stretched by u = ``stretch`` (m) along its
    rest direction beyond its rest extension s0 = a - L, less the rest tension (which the
    linearised law carries across): F(s0 + u) - F(s0); k u for Hooke's law, times
    ``_along_factor`` with the FPU law (written without the difference)."""
    rest = parameters.spacing - parameters.rest_length
    return parameters.stiffness * stretch * _along_factor(
        stretch, rest, parameters.spring_alpha, parameters.spring_beta)


@njit(**_JIT)
def along_energy(stretch, parameters):
    """Energy (J) of a spring of the linearised law stretched by u = ``stretch`` (m) beyond its
    rest extension s0, less the rest tension's work: W(s0 + u) - W(s0) - F(s0) u (the integral
    of ``along_force``), k u^2 / 2 for Hooke's law."""
    rest = parameters.spacing - parameters.rest_length
    return parameters.stiffness * (0.5 * stretch * stretch + _along_energy(
        stretch, rest, parameters.spring_alpha, parameters.spring_beta))


@njit(**_JIT)
def axial_energy(stretch, parameters):
    """Energy (J) of a spring extended by ``stretch`` = |d| - L (m): k s^2 / 2, plus the FPU
    law's k (alpha s^3 / 3 + beta s^4 / 4)."""
    return parameters.stiffness * (0.5 * stretch * stretch + _fpu_energy(
        stretch, parameters.spring_alpha, parameters.spring_beta))
