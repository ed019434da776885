"""Runge-Kutta methods as data: a method is its Butcher table.

An explicit s-stage Runge-Kutta method on y' = f(y) is the table (A, b, c): stage i evaluates
k_i = f(y_0 + dt sum_j a_ij k_j) at time t + c_i dt, and the step is y_0 + dt sum_i b_i k_i.  The
compiled loops (``sim.loops.stage_updates``, ``sim.loops.wavefront``) run one generic stage update
(compiled once, the table's numbers a small array argument) for every table in the *low-storage*
form where each stage's input is y_0 + dt a_{i,i-1} k_{i-1}
(A zero except its sub-diagonal): a running sum, the next input and the state are all the work a
stage needs, which is what lets the stages stream over the rows as one wavefront.  Classic RK4,
Heun, Ralston's third-order method and the midpoint method have that form; a table whose A has
other entries is refused with ``ButcherTableError``.

Everything else about a method follows from its table: its order (the order conditions, checked up
to 4), its stability polynomial R(z) = sum_k (b . A^(k-1) 1) z^k, hence its amplification matrices
on the damped oscillator and its stability limit on an undamped lattice (the largest omega dt with
|R(i omega dt)| <= 1).  ``sim.integrators.registry`` registers one description per table.
"""

from __future__ import annotations

import dataclasses
import math
from fractions import Fraction

import numpy as np

from sim.integrators.amplification import AmplificationFunction, polynomial_amplification

_TOLERANCE = 1e-12
"""How far a table's numbers may miss an exact relation (consistency, order conditions)."""


class ButcherTableError(ValueError):
    """A table the compiled loops cannot run (not explicit, not low-storage, inconsistent)."""


def _number(value) -> float:
    """A table entry as a float; fractions written as strings ("1/6") are exact before rounding."""
    return float(Fraction(value)) if isinstance(value, str) else float(value)


@dataclasses.dataclass(frozen=True)
class ButcherTable:
    """The Butcher table of an explicit Runge-Kutta method: ``a`` the s x s matrix A (rows of
    numbers or fraction strings such as "1/6"), ``b`` (s,) the weights, ``c`` (s,) the nodes;
    ``label`` names the method in messages."""

    label: str
    a: tuple
    b: tuple
    c: tuple

    def __post_init__(self) -> None:
        s = len(self.b)
        name = self.label
        if s < 2:
            raise ButcherTableError(
                f"{name}: a table needs at least 2 stages (explicit Euler has a loop of its own)")
        try:
            a = tuple(tuple(_number(x) for x in row) for row in self.a)
            b = tuple(_number(x) for x in self.b)
            c = tuple(_number(x) for x in self.c)
        except (TypeError, ValueError, ZeroDivisionError) as error:
            raise ButcherTableError(f"{name}: every entry must be a number ({error})") from None
        if len(c) != s or len(a) != s or any(len(row) != s for row in a):
            raise ButcherTableError(f"{name}: A must be {s} x {s} and c have {s} entries")
        if not all(math.isfinite(x) for x in (*b, *c, *(x for row in a for x in row))):
            raise ButcherTableError(f"{name}: every entry must be finite")
        for i in range(s):
            for j in range(s):
                if j != i - 1 and a[i][j] != 0.0:
                    kind = "implicit" if j >= i else "not low-storage"
                    raise ButcherTableError(
                        f"{name}: a[{i + 1}][{j + 1}] = {a[i][j]:g} ({kind}): the compiled loops "
                        "run tables whose A is zero except its sub-diagonal a[i+1][i] (each "
                        "stage's input is x0 + dt a[i+1][i] k[i])")
            if abs(c[i] - sum(a[i])) > _TOLERANCE:
                raise ButcherTableError(
                    f"{name}: c[{i + 1}] = {c[i]:g} must equal the sum of row {i + 1} of A "
                    f"({sum(a[i]):g})")
        if abs(sum(b) - 1.0) > _TOLERANCE:
            raise ButcherTableError(f"{name}: the weights b must sum to 1, not {sum(b):g}")
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "b", b)
        object.__setattr__(self, "c", c)

    @property
    def stages(self) -> int:
        """Number of stages: force evaluations per step."""
        return len(self.b)

    @property
    def matrix(self) -> np.ndarray:
        """A as an (s, s) array."""
        return np.array(self.a, dtype=float)

    @property
    def coefficients(self) -> np.ndarray:
        """The numbers the compiled loops take (``sim.loops.stage_updates.stage_update``), a
        (3, s) float64 array: row 0 the nodes c, row 1 the sub-diagonal a_{i+1,i} (0 after the
        last stage), row 2 the weights b.  An array, not a tuple: numba's parallel loops take
        arrays into their threads, and one compiled loop serves every stage count."""
        table = np.zeros((3, self.stages))
        table[0] = self.c
        table[1, :-1] = [self.a[i + 1][i] for i in range(self.stages - 1)]
        table[2] = self.b
        return table

    @property
    def order(self) -> int:
        """The order of accuracy: the highest p <= 4 whose order conditions all hold."""
        a, b, c = self.matrix, np.array(self.b), np.array(self.c)
        conditions = (
            (b.sum() - 1.0,),
            (b @ c - 1 / 2,),
            (b @ c**2 - 1 / 3, b @ a @ c - 1 / 6),
            (b @ c**3 - 1 / 4, b @ (c * (a @ c)) - 1 / 8, b @ a @ c**2 - 1 / 12,
             b @ a @ a @ c - 1 / 24),
        )
        order = 0
        for residuals in conditions:
            if max(abs(r) for r in residuals) > _TOLERANCE:
                break
            order += 1
        return order

    @property
    def stability_polynomial(self) -> tuple[float, ...]:
        """Coefficients gamma_0 .. gamma_s of R(z) = sum_k gamma_k z^k, one step on y' = lambda y
        with z = lambda dt: gamma_0 = 1, gamma_k = b . A^(k-1) 1."""
        a, b = self.matrix, np.array(self.b)
        coefficients, vector = [1.0], np.ones(self.stages)
        for _ in range(self.stages):
            coefficients.append(float(b @ vector))
            vector = a @ vector
        return tuple(coefficients)

    @property
    def amplification(self) -> AmplificationFunction:
        """One step on the damped oscillator u'' + beta u' + omega^2 u = 0 as a matrix: R(dt M)
        with M the oscillator's first-order system (the method is exact arithmetic of R there)."""
        return polynomial_amplification(self.stability_polynomial)

    @property
    def stability_factor(self) -> float | None:
        """The largest omega dt with |R(i omega dt)| <= 1 from 0 up to it: an undamped lattice is
        stable iff omega_max dt <= factor.  None when |R(i y)| > 1 for every small y > 0 (the
        energy grows at every step)."""
        gamma = np.array(self.stability_polynomial)
        rotated = gamma * (1j ** np.arange(gamma.size))  # R(i y) as a polynomial in y
        square = np.polynomial.polynomial.polymul(rotated, np.conj(rotated)).real
        square[0] -= 1.0  # |R(i y)|^2 - 1, even in y: a polynomial in w = y^2
        in_w = square[::2]
        nonzero = np.flatnonzero(np.abs(in_w) > _TOLERANCE)
        if nonzero.size == 0:
            return math.inf
        lowest = in_w[nonzero[0]:]  # divided by the power of w at w = 0
        if lowest[0] > 0:
            return None
        roots = np.polynomial.polynomial.polyroots(lowest)
        positive = [r.real for r in roots if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0]
        return math.sqrt(min(positive)) if positive else math.inf


CLASSIC_RK4 = ButcherTable(
    label="classic Runge-Kutta 4",
    a=((0, 0, 0, 0), ("1/2", 0, 0, 0), (0, "1/2", 0, 0), (0, 0, 1, 0)),
    b=("1/6", "1/3", "1/3", "1/6"), c=(0, "1/2", "1/2", 1),
)
HEUN = ButcherTable(label="Heun", a=((0, 0), (1, 0)), b=("1/2", "1/2"), c=(0, 1))
"""Heun's predictor-corrector: an Euler prediction, then the trapezoid of the two slopes."""
RALSTON3 = ButcherTable(
    label="Ralston RK3",
    a=((0, 0, 0), ("1/2", 0, 0), (0, "3/4", 0)),
    b=("2/9", "1/3", "4/9"), c=(0, "1/2", "3/4"),
)
"""Ralston's third-order method: the third-order table of least truncation-error bound."""
MIDPOINT = ButcherTable(label="explicit midpoint", a=((0, 0), ("1/2", 0)), b=(0, 1),
                        c=(0, "1/2"))
