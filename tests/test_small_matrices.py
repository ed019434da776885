"""The closed-form eigenvalues and powers of stacks of small matrices (``sim.theory.small_matrices``)
against LAPACK, numpy's matrix power and the integrators' analytic amplification factors; the
few-value sine transform (``sim.theory.modes``) against the FFT and the definition."""

import math

import numpy as np
import pytest

from sim.integrators.registry import INTEGRATORS, describe
from sim.theory import small_matrices
from sim.theory.modes import _sparse_sine_transform, sine_transform


def _nearest_distance(ours: np.ndarray, reference: np.ndarray) -> float:
    """The largest distance from a reference eigenvalue to the nearest of ours, per matrix."""
    return float(np.abs(reference[:, :, None] - ours[:, None, :]).min(axis=2).max())


@pytest.mark.parametrize("size", [2, 3])
def test_eigenvalues_of_random_matrices_match_lapack(size):
    matrices = np.random.default_rng(size).normal(size=(20_000, size, size))
    ours = small_matrices.eigenvalues(matrices)
    reference = np.linalg.eigvals(matrices)
    assert _nearest_distance(ours, reference) < 1e-11
    assert _nearest_distance(reference, ours) < 1e-11  # and no root twice in place of two


def test_eigenvalues_of_triangular_matrices_are_the_diagonal():
    rng = np.random.default_rng(7)
    matrices = np.triu(rng.normal(size=(500, 3, 3)))
    matrices[:100, 1, 1] = matrices[:100, 0, 0]  # repeated roots
    ours = small_matrices.eigenvalues(matrices)
    diagonal = np.diagonal(matrices, axis1=1, axis2=2)
    assert _nearest_distance(ours, diagonal.astype(complex)) < 1e-7  # a double root: sqrt(eps)
    assert _nearest_distance(ours[100:], diagonal[100:].astype(complex)) < 1e-12


@pytest.mark.parametrize("name", [name for name in INTEGRATORS
                                  if describe(name).amplification is not None])
@pytest.mark.parametrize("beta", [0.0, 0.01, 0.7])
def test_amplification_eigenvalues_match_lapack(name, beta):
    omega = np.linspace(0.0, 3.2, 4001)
    matrices = describe(name).amplification(omega**2, np.full_like(omega, beta), 1.0)
    ours = small_matrices.eigenvalues(matrices)
    reference = np.linalg.eigvals(matrices)
    # away from double roots (critical damping, the stability limit) to round-off
    gaps = np.abs(reference[:, :, None] - reference[:, None, :]) + np.eye(reference.shape[1]) * 9
    simple = gaps.min(axis=(1, 2)) > 1e-2
    assert simple.mean() > 0.9
    assert _nearest_distance(ours[simple], reference[simple]) < 1e-10
    assert np.abs(np.abs(ours).max(1) - np.abs(reference).max(1)).max() < 1e-7


def test_undamped_verlet_keeps_every_wave_on_the_unit_circle_below_its_limit():
    """Velocity Verlet on u'' = -w^2 u: eigenvalues cos(theta) +- i sin(theta), cos(theta) =
    1 - (w h)^2 / 2, for w h < 2, and a spurious 0 from the cached acceleration."""
    wh = np.linspace(0.01, 1.99, 199)
    matrices = describe("verlet").amplification(wh**2, np.zeros_like(wh), 1.0)
    values = small_matrices.eigenvalues(matrices)
    dominant = values[np.arange(len(wh)), np.argmax(np.abs(values), axis=1)]
    assert np.abs(np.abs(dominant) - 1.0).max() < 1e-13
    assert np.abs(np.abs(np.angle(dominant)) - np.arccos(1 - wh**2 / 2)).max() < 1e-12
    assert np.abs(values).min(axis=1).max() < 1e-12


def test_rk4_eigenvalues_are_its_stability_polynomial():
    """An explicit Runge-Kutta method multiplies the mode exp(i w t) by R(i w h) per step."""
    wh = np.linspace(0.0, 2.9, 300)
    matrices = describe("rk4").amplification(wh**2, np.zeros_like(wh), 1.0)
    values = small_matrices.eigenvalues(matrices)
    z = 1j * wh
    expected = sum(z**k / math.factorial(k) for k in range(5))
    assert _nearest_distance(values, np.stack([expected, expected.conj()], axis=1)) < 1e-13


@pytest.mark.parametrize("size, power", [(2, 1), (2, 37), (3, 0), (3, 1), (3, 1000)])
def test_power_apply_matches_numpy(size, power):
    rng = np.random.default_rng(power)
    matrices = rng.normal(size=(300, size, size)) / (size + 1)
    vectors = rng.normal(size=(300, size))
    expected = np.einsum("mij,mj->mi", np.linalg.matrix_power(matrices, power), vectors)
    ours = small_matrices.power_apply(matrices, power, vectors)
    assert np.allclose(ours, expected, rtol=1e-10, atol=1e-300)


def test_power_apply_keeps_unstable_matrices_finite():
    matrices = np.full((4, 2, 2), 10.0)
    result = small_matrices.power_apply(matrices, 10_000, np.ones((4, 2)))
    assert np.all(np.isfinite(result)) and np.all(np.abs(result) > 1e100)


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (8, 12), (383, 682)])
def test_few_value_sine_transform_matches_the_fft_and_the_definition(shape):
    rng = np.random.default_rng(sum(shape))
    field = np.zeros(shape)
    for _ in range(3):
        field[rng.integers(shape[0]), rng.integers(shape[1])] = rng.normal()
    ours = _sparse_sine_transform(field)
    fft = sine_transform(sine_transform(field, 0), 1)
    assert np.abs(ours - fft).max() <= 1e-13 * np.abs(fft).max()
    ny, nx = shape
    rows = np.sqrt(2 / (ny + 1)) * np.sin(np.outer(np.arange(1, ny + 1), np.arange(1, ny + 1))
                                          * np.pi / (ny + 1))
    columns = np.sqrt(2 / (nx + 1)) * np.sin(np.outer(np.arange(1, nx + 1),
                                                      np.arange(1, nx + 1)) * np.pi / (nx + 1))
    if ny * nx <= 100:
        assert np.allclose(ours, rows @ field @ columns.T, atol=1e-14)


@pytest.mark.parametrize("name", ["verlet", "euler", "rk4"])
def test_a_step_far_shorter_than_a_period_keeps_damped_modes_inside_the_circle(name):
    """At h = 1e-9 / omega the eigenvalues crowd at 1 (a near-double root): a damped mode must
    still come out with |lambda| < 1, as the damped stability search needs."""
    omega = np.linspace(0.5, 7.0, 200)
    beta = np.linspace(0.1, 5.0, 200)
    matrices = describe(name).amplification(omega**2, beta, 1e-9 / omega.max())
    radius = np.abs(small_matrices.eigenvalues(matrices)).max(axis=1)
    assert np.all(radius < 1.0)
    assert np.abs(radius - np.abs(np.linalg.eigvals(matrices)).max(axis=1)).max() < 1e-13
