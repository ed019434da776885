"""Stacks of small matrices, one per normal mode: their eigenvalues and their powers.

A prediction (``sim.theory.prediction``) holds one amplification matrix (2x2 or 3x3) per excited
mode, up to a million of them on the continuum-limit lattice.  numpy's batched ``eigvals`` and
``@`` run LAPACK or a small-matrix product once per matrix (about 1.3 us and 65 ns for a 3x3);
here each entry is an array over the stack, so every operation is one pass over contiguous
memory (5-10x faster):

* ``eigenvalues``: the roots of the characteristic polynomial, in closed form (the quadratic
  formula; for a 3x3 one real root by Cardano's formula refined by Newton's method, then the
  quadratic left, or LAPACK where that quadratic has a near-double root); other sizes go to
  numpy;
* ``power_apply``: G^n v by repeated squaring, the products written entry by entry.
"""

from __future__ import annotations

import numpy as np

NEAR_DOUBLE = 1e-4
"""A 3x3's closed-form roots are used where the real root's slope and the quadratic's
discriminant are at least this fraction of their terms' sizes (then they carry 12 of their 16
digits); nearer a double root, LAPACK's."""


def eigenvalues(matrices: np.ndarray) -> np.ndarray:
    """(m, s) complex eigenvalues of a stack of real (m, s, s) matrices, in no particular order
    (numpy's ``eigvals`` for s other than 2 and 3)."""
    matrices = np.asarray(matrices, dtype=float)
    size = matrices.shape[-1]
    if size == 2:
        a, b, c, d = (matrices[:, i, j] for i in range(2) for j in range(2))
        # the discriminant from the entries: ((a - d)/2)^2 + b c has no cancellation where
        # (a + d)^2/4 - det has (a step much shorter than a period, critical damping)
        pair = _quadratic_roots(-(a + d), a * d - b * c, (0.5 * (a - d)) ** 2 + b * c)
        return np.stack(pair, axis=1)
    if size == 3:
        return _cubic_eigenvalues(matrices)
    return np.linalg.eigvals(matrices)


def _quadratic_roots(p: np.ndarray, q: np.ndarray,
                     discriminant: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The roots of z^2 + p z + q, complex, given its discriminant p^2/4 - q, without the
    cancellation of the textbook formula: the larger real root first, the smaller from the
    product q."""
    half = -0.5 * p
    root = np.sqrt(np.abs(discriminant))
    real = discriminant >= 0
    large = half + np.where(half >= 0, root, -root)  # real roots: the one of larger size
    with np.errstate(divide="ignore", invalid="ignore"):
        small = np.where(large != 0, q / np.where(large != 0, large, 1.0), 0.0)
    first = np.where(real, large, half) + 1j * np.where(real, 0.0, root)
    second = np.where(real, small, half) - 1j * np.where(real, 0.0, root)
    return first, second


def _cubic_eigenvalues(matrices: np.ndarray) -> np.ndarray:
    """Eigenvalues of (m, 3, 3) matrices from z^3 - c2 z^2 + c1 z - c0 (trace, principal
    minors, determinant)."""
    e = [[matrices[:, i, j] for j in range(3)] for i in range(3)]
    c2 = e[0][0] + e[1][1] + e[2][2]
    c1 = (e[0][0] * e[1][1] - e[0][1] * e[1][0] + e[0][0] * e[2][2] - e[0][2] * e[2][0]
          + e[1][1] * e[2][2] - e[1][2] * e[2][1])
    c0 = (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1])
          - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
          + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))
    a2, a1, a0 = -c2, c1, -c0  # z^3 + a2 z^2 + a1 z + a0
    real_root, slope = _real_cubic_root(a2, a1, a0)
    # (z - r)(z^2 + p z + q): p = a2 + r, and q = a1 + r p or, better conditioned when r is the
    # large root, -a0 / r
    p = a2 + real_root
    by_product = np.abs(real_root) > np.abs(p)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = np.where(by_product, -a0 / np.where(by_product, real_root, 1.0),
                     a1 + real_root * p)
    discriminant = 0.25 * p * p - q
    first, second = _quadratic_roots(p, q, discriminant)
    roots = np.stack([real_root.astype(complex), first, second], axis=1)
    # near a double root (a step much shorter than a period, critical damping, a stability
    # limit) the real root's slope or the quadratic's discriminant is a small difference of
    # large numbers and has lost its digits: those matrices go to LAPACK
    size = 3.0 * real_root**2 + np.abs(2.0 * a2 * real_root) + np.abs(a1)
    lost = ((np.abs(slope) < NEAR_DOUBLE * size)
            | (np.abs(discriminant) < NEAR_DOUBLE * (0.25 * p * p + np.abs(q)))
            | ~np.isfinite(real_root))
    if lost.any():
        roots[lost] = np.linalg.eigvals(matrices[lost])
    return roots


def _real_cubic_root(a2: np.ndarray, a1: np.ndarray,
                     a0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(a real root of z^3 + a2 z^2 + a1 z + a0, the polynomial's slope there): Cardano's root
    when it is the only one, else of the three (the trigonometric form) the one farthest from
    the others (the largest slope); refined by Newton's method."""
    shift = a2 / 3.0
    p = a1 - a2 * shift  # depressed cubic t^3 + p t + q, z = t - shift
    q = 2.0 * shift**3 - shift * a1 + a0
    discriminant = (q / 2.0) ** 2 + (p / 3.0) ** 3
    one_real = discriminant >= 0
    root = np.sqrt(np.abs(discriminant))
    u = np.cbrt(-q / 2.0 + np.where(-q >= 0, root, -root))  # no cancellation
    with np.errstate(divide="ignore", invalid="ignore"):
        cardano = u - np.where(u != 0, p / (3.0 * np.where(u != 0, u, 1.0)), 0.0)
        radius = 2.0 * np.sqrt(np.maximum(-p / 3.0, 0.0))
        cosine = np.clip(np.where(radius > 0, 3.0 * q / (p * np.where(radius > 0, radius, 1.0)),
                                  0.0), -1.0, 1.0)
    angle = np.arccos(cosine) / 3.0
    # the three real roots radius cos(angle - 2 pi k/3); the depressed cubic's slope 3 t^2 + p
    three = radius * np.cos(angle - (2.0 * np.pi / 3.0) * np.arange(3)[:, None])
    farthest = np.argmax(np.abs(3.0 * three**2 + p), axis=0)
    trigonometric = np.take_along_axis(three, farthest[None, :], axis=0)[0]
    z = np.where(one_real, cardano, trigonometric) - shift
    for _ in range(3):
        value = ((z + a2) * z + a1) * z + a0
        slope = (3.0 * z + 2.0 * a2) * z + a1
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(slope != 0, value / np.where(slope != 0, slope, 1.0), 0.0)
        z = np.where(np.isfinite(step) & (np.abs(step) < 1e-3 * (1.0 + np.abs(z))), z - step, z)
    return z, (3.0 * z + 2.0 * a2) * z + a1
def power_apply(matrices: np.ndarray, power: int, vectors: np.ndarray,
                limit: float = 1e150) -> np.ndarray:
    """G^power v for a stack of matrices (m, s, s) and vectors (m, s), by squaring; entries
    clipped to +-``limit`` (limit^2 must be finite) so that unstable matrices stay finite."""
    base = np.ascontiguousarray(np.moveaxis(np.asarray(matrices, dtype=float), 0, -1))  # (s, s, m)
    result = np.ascontiguousarray(np.asarray(vectors, dtype=float).T)  # (s, m)
    size = base.shape[0]
    product, term = np.empty_like(base), np.empty_like(base[0, 0])
    while power > 0:
        if power & 1:
            applied = np.zeros_like(result)
            for i in range(size):
                for j in range(size):
                    np.multiply(base[i, j], result[j], out=term)
                    applied[i] += term
            result = np.clip(applied, -limit, limit, out=applied)
        power >>= 1
        if power:
            for i in range(size):
                for j in range(size):
                    np.multiply(base[i, 0], base[0, j], out=product[i, j])
                    for k in range(1, size):
                        np.multiply(base[i, k], base[k, j], out=term)
                        product[i, j] += term
            base, product = product, base
            np.clip(base, -limit, limit, out=base)
    return np.ascontiguousarray(result.T)
