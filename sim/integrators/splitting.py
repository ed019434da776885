"""Splitting methods as data: a symplectic method is its kick and drift weights.

A splitting (symplectic partitioned) method for x' = v, v' = a(x) composes exact kicks
(v += b dt a(x)) and drifts (x += a dt v): one step is

    kick b_1, drift a_1, kick b_2, drift a_2, ..., drift a_s, kick b_(s+1)

(``SplittingTable``: ``drifts`` a_1 .. a_s, ``kicks`` b_1 .. b_(s+1), both summing to 1).  The last
kick of a step and the first of the next use the same forces, so a step costs s force
evaluations.  Velocity Verlet is the table (a = (1), b = (1/2, 1/2)).  The compiled loops run one
generic sequence of (kick, drift) sweeps for every table (``sim.integrators.steppers.Splitting``,
``sim.loops.leapfrog``).

Everything else follows from the table, as for a Butcher table (``sim.integrators.butcher``): its
order (the order conditions, from the logarithm of the composition in the free algebra of the two
flows, checked up to 4), its force evaluations, its matrix on the harmonic oscillator (a product
of kick and drift matrices), hence its stability limit and its numerical dispersion.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from sim.integrators.amplification import AmplificationFunction

_TOLERANCE = 1e-12
MAX_CHECKED_ORDER = 4


class SplittingTableError(ValueError):
    """A table that is not a consistent splitting method."""


@dataclasses.dataclass(frozen=True)
class SplittingTable:
    """A splitting method: ``drifts`` (s,) and ``kicks`` (s + 1,) weights in the order they act
    (kick first); ``label`` names it; ``source`` says where its numbers come from."""

    label: str
    drifts: tuple[float, ...]
    kicks: tuple[float, ...]
    source: str = ""

    def __post_init__(self) -> None:
        drifts = tuple(float(a) for a in self.drifts)
        kicks = tuple(float(b) for b in self.kicks)
        object.__setattr__(self, "drifts", drifts)
        object.__setattr__(self, "kicks", kicks)
        if len(kicks) != len(drifts) + 1 or not drifts:
            raise SplittingTableError(f"{self.label}: a table has s drifts and s + 1 kicks")
        for name, weights in (("drifts", drifts), ("kicks", kicks)):
            if abs(sum(weights) - 1.0) > _TOLERANCE:
                raise SplittingTableError(f"{self.label}: the {name} sum to {sum(weights)!r}, "
                                          "not 1")

    @property
    def stages(self) -> int:
        """Drifts per step."""
        return len(self.drifts)

    @property
    def force_evaluations(self) -> int:
        """Force evaluations per step (the last kick's forces serve the next step's first)."""
        return self.stages

    @property
    def symmetric(self) -> bool:
        return (np.allclose(self.drifts, self.drifts[::-1], atol=_TOLERANCE)
                and np.allclose(self.kicks, self.kicks[::-1], atol=_TOLERANCE))

    @property
    def order(self) -> int:
        """The largest p <= ``MAX_CHECKED_ORDER`` such that the composition's logarithm equals
        dt (A + B) up to terms of degree p + 1 (A the drift, B the kick flow)."""
        logarithm = _free_log(self._factors())
        order = 1
        for degree in range(2, MAX_CHECKED_ORDER + 1):
            if any(abs(c) > 1e-10 for word, c in logarithm.items() if len(word) == degree):
                break
            order = degree
        return order

    def _factors(self) -> list[tuple[str, float]]:
        factors = []
        for index, b in enumerate(self.kicks):
            factors.append(("B", b))
            if index < self.stages:
                factors.append(("A", self.drifts[index]))
        return factors

    def harmonic_matrix(self, h: float) -> np.ndarray:
        """One step on u'' = -u with dt = h, on z = (u, u')."""
        matrix = np.eye(2)
        for kind, weight in self._factors():
            step = np.array([[1.0, 0.0], [-weight * h, 1.0]]) if kind == "B" else \
                np.array([[1.0, weight * h], [0.0, 1.0]])
            matrix = step @ matrix
        return matrix

    def _half_trace(self) -> np.polynomial.Polynomial:
        """tr M(h) / 2 as a polynomial in h."""
        P = np.polynomial.Polynomial
        matrix = [[P([1.0]), P([0.0])], [P([0.0]), P([1.0])]]
        for kind, weight in self._factors():
            if kind == "B":
                step = [[P([1.0]), P([0.0])], [P([0.0, -weight]), P([1.0])]]
            else:
                step = [[P([1.0]), P([0.0, weight])], [P([0.0]), P([1.0])]]
            matrix = [[sum((step[i][k] * matrix[k][j] for k in range(2)), P([0.0]))
                       for j in range(2)] for i in range(2)]
        return (matrix[0][0] + matrix[1][1]) / 2.0

    @property
    def stability_factor(self) -> float:
        """The largest omega dt up to which every smaller one is stable (|tr M| / 2 <= 1, det M =
        1): an undamped lattice is stable iff omega_max dt <= factor."""
        excess = self._half_trace() ** 2 - 1.0
        roots = [r.real for r in excess.roots()
                 if abs(r.imag) <= 1e-7 * max(1.0, abs(r)) and r.real > 1e-6]
        candidates = sorted(roots)
        for root in candidates:  # the first root past which |tr / 2| exceeds 1
            if excess(root * (1 + 1e-6)) > 1e-12:
                return float(root)
        return math.inf

    @property
    def amplification(self) -> AmplificationFunction:
        """One step on u'' + omega^2 u = 0 as a matrix on z = (u, u'), per mode (the methods run
        undamped lattices only: the damping rates must be zero)."""
        def amplification(omega_squared, damping_rate, dt: float) -> np.ndarray:
            omega_squared = np.asarray(omega_squared, dtype=float)
            count = omega_squared.shape[0]
            result = np.broadcast_to(np.eye(2), (count, 2, 2)).copy()
            for kind, weight in self._factors():
                step = np.broadcast_to(np.eye(2), (count, 2, 2)).copy()
                if kind == "B":
                    step[:, 1, 0] = -weight * dt * omega_squared
                else:
                    step[:, 0, 1] = weight * dt
                result = step @ result
            return result

        return amplification

    def sweeps(self, steps: int, dt: float) -> np.ndarray:
        """(steps * s, 2) (kick, drift) weights times dt of the sweeps that run ``steps`` steps
        after the first kick: sweep k kicks with the forces at the positions it starts from,
        then drifts.  The first sweep's kick is b_1 dt; each step's last kick b_(s+1) dt joins
        the next step's first; the caller kicks b_(s+1) dt once more at the end."""
        s = self.stages
        kicks = np.tile(np.asarray(self.kicks[:s]), steps)
        kicks[s::s] += self.kicks[-1]
        drifts = np.tile(np.asarray(self.drifts), steps)
        return np.stack([kicks, drifts], axis=1) * dt


# --- the free algebra of two flows, up to degree MAX_CHECKED_ORDER ------------------------------

Element = dict[str, float]


def _multiply(x: Element, y: Element) -> Element:
    product: Element = {}
    for u, cu in x.items():
        for w, cw in y.items():
            if len(u) + len(w) <= MAX_CHECKED_ORDER:
                product[u + w] = product.get(u + w, 0.0) + cu * cw
    return product


def _add(x: Element, y: Element, scale: float = 1.0) -> Element:
    total = dict(x)
    for word, c in y.items():
        total[word] = total.get(word, 0.0) + scale * c
    return total


def _free_log(factors: Sequence[tuple[str, float]]) -> Element:
    """log(prod exp(w X)) - (A + B), truncated: the product runs right to left as flows act
    (the first factor acts first)."""
    product: Element = {"": 1.0}
    for letter, weight in factors:
        exponential: Element = {"": 1.0}
        for k in range(1, MAX_CHECKED_ORDER + 1):
            exponential[letter * k] = weight**k / math.factorial(k)
        product = _multiply(exponential, product)
    excess = {word: c for word, c in product.items() if word}
    logarithm: Element = {}
    power: Element = {"": 1.0}
    for k in range(1, MAX_CHECKED_ORDER + 1):
        power = _multiply(power, excess)
        logarithm = _add(logarithm, power, (-1.0) ** (k + 1) / k)
    logarithm = _add(logarithm, {"A": 1.0, "B": 1.0}, -1.0)
    return logarithm


VELOCITY_VERLET = SplittingTable("velocity Verlet", drifts=(1.0,), kicks=(0.5, 0.5),
                                 source="Verlet (1967); Swope, Andersen, Berens, Wilson (1982)")
_CUBE_ROOT = 2.0 ** (1.0 / 3.0)
_W1 = 1.0 / (2.0 - _CUBE_ROOT)
_W0 = -_CUBE_ROOT / (2.0 - _CUBE_ROOT)
YOSHIDA4 = SplittingTable(
    "Yoshida's triple jump (order 4)", drifts=(_W1, _W0, _W1),
    kicks=(_W1 / 2, (_W1 + _W0) / 2, (_W0 + _W1) / 2, _W1 / 2),
    source="Yoshida, Phys. Lett. A 150 (1990) 262; Forest and Ruth (1990): three Verlet steps "
           "of w1, w0, w1 dt")
_A1, _A2 = 0.245298957184271, 0.604872665711080
_B1, _B2, _B3 = 0.0829844064174052, 0.396309801498368, -0.0390563049223486
BLANES_MOAN = SplittingTable(
    "Blanes-Moan SRKN6b (order 4)",
    drifts=(_A1, _A2, 0.5 - (_A1 + _A2), 0.5 - (_A1 + _A2), _A2, _A1),
    kicks=(_B1, _B2, _B3, 1.0 - 2.0 * (_B1 + _B2 + _B3), _B3, _B2, _B1),
    source="Blanes and Moan, J. Comput. Appl. Math. 142 (2002) 313-330, table 3, SRKN6b")
