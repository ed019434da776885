"""Amplification matrices of the integrators as implemented in the step loops (``sim.loops.row_sweep``):
one step of each method on the damped oscillator u'' + beta u' + omega^2 u = 0, as a matrix.

``sim.theory.observables`` finds the stability limit of a damped lattice from them; each integrator's
``IntegratorDescription.amplification`` (``sim.integrators.registry``) names its function.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

AmplificationFunction = Callable[[np.ndarray, np.ndarray, float], np.ndarray]
"""(omega_squared (n_modes,), damping_rate (n_modes,), dt) -> (n_modes, s, s) matrices G with
z_{n+1} = G z_n for u'' + beta u' + omega^2 u = 0, the integrator as implemented."""


def taylor_amplification(terms: int) -> AmplificationFunction:
    """G = sum_{k <= terms} (dt A)^k / k! on z = (u, u'): explicit Euler (1), and a Runge-Kutta
    method of as many stages as its order (up to 4) reduce to this on a linear system."""
    return polynomial_amplification(tuple(1.0 / math.factorial(k) for k in range(terms + 1)))


def polynomial_amplification(coefficients: Sequence[float]) -> AmplificationFunction:
    """G = sum_k coefficients[k] (dt A)^k on z = (u, u'): one step of a Runge-Kutta method whose
    stability polynomial has these coefficients (``sim.integrators.butcher``), on a linear system."""
    coefficients = tuple(float(x) for x in coefficients)

    def amplification(omega_squared, damping_rate, dt: float) -> np.ndarray:
        omega_squared = np.asarray(omega_squared, dtype=float)
        count = omega_squared.shape[0]
        system = np.zeros((count, 2, 2))
        system[:, 0, 1] = 1.0
        system[:, 1, 0] = -omega_squared
        system[:, 1, 1] = -np.asarray(damping_rate, dtype=float)
        step = dt * system
        power = np.broadcast_to(np.eye(2), step.shape).copy()
        result = coefficients[0] * power
        for coefficient in coefficients[1:]:
            power = power @ step
            result = result + coefficient * power
        return result

    return amplification


def verlet_amplification(omega_squared, damping_rate, dt: float) -> np.ndarray:
    """Velocity Verlet with the predicted velocity v + dt a in the damping force, on
    z = (u, u', cached acceleration)."""
    omega_squared = np.asarray(omega_squared, dtype=float)
    beta = np.asarray(damping_rate, dtype=float)
    count = omega_squared.shape[0]
    h = dt
    # v_pred = w + h a; w_half = w + h/2 a; u' = u + h w_half; a' = -omega^2 u' - beta v_pred;
    # w' = w_half + h/2 a'
    matrices = np.zeros((count, 3, 3))
    u_new = np.stack([np.ones(count), np.full(count, h), np.full(count, h * h / 2)], axis=1)
    v_pred = np.stack([np.zeros(count), np.ones(count), np.full(count, h)], axis=1)
    a_new = -omega_squared[:, None] * u_new - beta[:, None] * v_pred
    w_half = np.stack([np.zeros(count), np.ones(count), np.full(count, h / 2)], axis=1)
    matrices[:, 0, :] = u_new
    matrices[:, 1, :] = w_half + (h / 2) * a_new
    matrices[:, 2, :] = a_new
    return matrices


