"""The exact continuum solution of a body (``sim.scenes.bodies``) and the lattice's frequencies beside it.

The wave equation u_tt = c^2 (laplacian u) with fixed ends (the paper's eq. 10), released at rest
from the shape f, is solved by the sine series of f:

    string:    u(s, t) = sum_n b_n cos(c n pi t / L0) sin(n pi s / L0)
    membrane:  u(x, y, t) = sum_pq b_p b_q / A cos(c pi sqrt(p^2 + q^2) t / L0) sin(p pi x / L0)
               sin(q pi y / L0)          (A the amplitude: the shape is f(x) f(y) / A)

``ContinuumSolution(body, particles)`` evaluates it at the particles' rest positions
s = a, 2a, ..., n a.  There a mode n' > n is the same as a lower one (sin(n' pi i / (n + 1))
folds back), so the series is first folded onto the n lattice modes and then summed by one sine
transform (O(terms + n log n) per time).  The number of terms is doubled until the field at the
particles changes by less than ``tolerance`` (relative L2) at the start and at one crossing
time; ``terms`` and ``change`` say how converged it is.

``lattice_frequencies`` and ``continuum_frequencies`` give omega for mode numbers of a side: the
lattice's 2 sqrt(k/m) sin(n pi / (2 (n_particles + 1))) = (2c / a) sin(q a / 2), q = n pi / L0,
against the continuum's c q.
"""

from __future__ import annotations

import math

import numpy as np

from sim.scenes.bodies import Body
from sim.theory.modes import sine_transform

DEFAULT_TOLERANCE = 1e-7
MAX_TERMS = {1: 1 << 20, 2: 1 << 11}
"""Largest number of terms per side tried (string, membrane: the membrane's are squared)."""


def continuum_frequencies(body: Body, modes: np.ndarray) -> np.ndarray:
    """omega = c n pi / L0 (rad/s) of the string's modes n (any array)."""
    return body.speed * math.pi * np.asarray(modes, dtype=float) / body.length


def lattice_frequencies(body: Body, particles: int, modes: np.ndarray) -> np.ndarray:
    """omega (rad/s) of the lattice's sine modes n along a side: (2 c / a) sin(n pi a / (2 L0)),
    i.e. 2 sqrt(k/m) sin(n pi / (2 (particles + 1)))."""
    a = body.spacing(particles)
    return 2.0 * body.speed / a * np.sin(np.asarray(modes, dtype=float) * math.pi * a / (2 * body.length))


def _fold(coefficients: np.ndarray, particles: int) -> tuple[np.ndarray, np.ndarray]:
    """For mode numbers 1..terms: the lattice mode (0-based index, -1 for none) each one is at
    the particles, and the sign: sin(n pi i/(N+1)) = sign * sin(r pi i/(N+1))."""
    period = 2 * (particles + 1)
    n = np.arange(1, coefficients.shape[-1] + 1)
    r = n % period
    sign = np.where(r <= particles + 1, 1.0, -1.0)
    r = np.where(r <= particles + 1, r, period - r)
    vanishing = (r == 0) | (r == particles + 1)
    return np.where(vanishing, -1, r - 1), np.where(vanishing, 0.0, sign)


def _fold_vector(values: np.ndarray, index: np.ndarray, sign: np.ndarray, particles: int) -> np.ndarray:
    """(particles,) sum of the (terms,) ``values`` onto the lattice modes."""
    keep = index >= 0
    return np.bincount(index[keep], weights=values[keep] * sign[keep], minlength=particles)


def _fold_matrix(index: np.ndarray, sign: np.ndarray, particles: int) -> np.ndarray:
    """(terms, particles) matrix P with P[n, r] = sign where mode n folds onto lattice mode r."""
    matrix = np.zeros((index.shape[0], particles))
    keep = np.flatnonzero(index >= 0)
    matrix[keep, index[keep]] = sign[keep]
    return matrix


class ContinuumSolution:
    """The continuum solution of ``body`` at the rest positions of ``particles`` per side.

    ``at(t)`` gives the (ny, nx) displacement (m) of the wave component, like
    ``Body.field``; ``terms`` is the number of series terms per side used, ``change`` the
    relative L2 change of the field at the particles when they were last doubled.
    """

    def __init__(self, body: Body, particles: int, tolerance: float = DEFAULT_TOLERANCE) -> None:
        self.body = body
        self.particles = int(particles)
        self.tolerance = float(tolerance)
        terms = 16
        limit = MAX_TERMS[body.dimensions]
        self._set_terms(terms)
        previous = [self.at(0.0), self.at(body.crossing_time)]
        while True:
            terms *= 2
            self._set_terms(terms)
            current = [self.at(0.0), self.at(body.crossing_time)]
            self.change = max(
                float(np.linalg.norm(now - before) / max(np.linalg.norm(now), 1e-300))
                for now, before in zip(current, previous, strict=True)
            )
            if self.change < self.tolerance or terms >= limit:
                break
            previous = current
        self.converged = self.change < self.tolerance

    def _set_terms(self, terms: int) -> None:
        self.terms = terms
        shape = self.body.shape
        self._b = shape.coefficients(terms)
        self._index, self._sign = _fold(self._b, self.particles)
        q = math.pi * np.arange(1, terms + 1) / self.body.length
        if self.body.dimensions == 1:
            self._omega = self.body.speed * q
        else:
            self._omega = self.body.speed * np.sqrt(q[:, None] ** 2 + q[None, :] ** 2)

    def at(self, time: float) -> np.ndarray:
        """(ny, nx) continuum displacement (m) at the particles' rest positions at ``time`` (s)."""
        n = self.particles
        scale = math.sqrt((n + 1) / 2.0)  # sine_transform is orthonormal
        if self.body.dimensions == 1:
            modal = _fold_vector(self._b * np.cos(self._omega * time), self._index, self._sign, n)
            return (sine_transform(modal, 0) * scale)[None, :]
        weights = np.outer(self._b, self._b) / self.body.shape.amplitude * np.cos(self._omega * time)
        fold = _fold_matrix(self._index, self._sign, n)
        modal = fold.T @ weights @ fold  # [p, q] on the lattice modes
        field = sine_transform(sine_transform(modal, 0), 1) * scale * scale  # [p, q] -> [x, y]
        return field.T  # (ny, nx): rows are y
