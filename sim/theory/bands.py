"""The band structure of the lattice as it is set: omega(q) of every branch along the path
Gamma-X-M-Gamma of the square lattice's Brillouin zone, the continuum lines, group and phase
velocities, what an integrator's time step does to each frequency, and the density of the exact
normal modes.

Three kinds of lattice have plane-wave bands here (``BandStructure``):

* **equal masses, nearest springs**: each displacement component is its own scalar wave
  (``sim.theory.lattice_waves.polarisation``), branches "x", "y" (and "z" in 3-D);
* **equal masses with diagonal springs**: the in-plane components couple into the two branches
  of ``sim.theory.lattice_waves.in_plane_omegas``, "S" (lower) and "P" (upper), plus "z" in 3-D;
* **the ionic checkerboard** (masses M where column + row is even, m elsewhere, nearest springs):
  every neighbour of a heavy particle is light and the other way round, so a plane wave puts
  amplitude A on the heavy and B on the light sublattice and each component obeys, with kx, ky
  its stiffnesses across columns and rows (``sim.theory.modes.polarisations``), the mass-weighted
  2x2 dynamical matrix

      D = [[2 (kx + ky) / M,                      -2 (kx cos qx a + ky cos qy a) / sqrt(M m)],
           [-2 (kx cos qx a + ky cos qy a) / sqrt(M m),  2 (kx + ky) / m                    ]]

  (M omega^2 A = 2 (kx + ky) A - B (kx (e^{i qx a} + e^{-i qx a}) + ky (...)), likewise for B):
  branches "x acoustic", "x optical", ... per component.  At X = (pi/a, 0) with kx = ky the
  coupling vanishes: the gap lies between sqrt(2 (kx + ky) / M) and sqrt(2 (kx + ky) / m)
  (a chain: sqrt(2k/M) and sqrt(2k/m) at q = pi / (2a)).  The path is the plain square
  lattice's: M = (pi/a, pi/a) differs from Gamma by a reciprocal vector of the checkerboard, so
  the acoustic branch comes back to zero there (the extended-zone picture).

A single row (ny == 1, a chain between two walls above and below) has path Gamma-X only and
qy = pi / (2a), the one sine mode across the row: the walls' springs add 2 ky / m to omega^2.

The integrator's numerical dispersion (``numerical_omegas``): one step of the method on
u'' + omega^2 u = 0 is the amplification matrix G (``sim.integrators.amplification``); its
eigenvalues lambda turn a wave of frequency omega into one of omega_num = |arg lambda| / dt that
grows by |lambda| per step (velocity Verlet: omega_num = (2/dt) asin(omega dt / 2) up to
omega dt = 2, beyond which |lambda| > 1).

Units: a in m, masses in kg, stiffness in N/m, q in rad/m, omega in rad/s, speeds in m/s.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np

from sim.forces import registry
from sim.integrators.registry import describe
from sim.model.lattice import Model, ModelError
from sim.theory import small_matrices
from sim.theory.lattice_waves import COMPONENTS, dynamical_matrix, polarisation
from sim.theory.modes import ModalBasis, polarisations

GROWTH_TOLERANCE = 1e-9
"""|lambda| above 1 + this is a wave the integrator makes grow (unstable at that frequency)."""
DIFFERENCE_STEP = 1e-6
"""Central-difference step for the group velocity, as a fraction of pi / a."""
LONG_WAVE = 1e-4
"""|q| a at which the continuum line's speed omega / |q| is read off the branch."""


class BandError(ValueError):
    """A lattice whose bands are not plane waves of one cell (the message says why)."""


def ionic_pair(model: Model) -> tuple[float, float] | None:
    """(M, m) (kg) if ``model``'s masses are a checkerboard of two values (M at column + row
    even), else None."""
    masses = np.asarray(model.masses, dtype=float).reshape(model.ny, model.nx)
    if model.uniform_mass or masses.size < 2:
        return None
    rows, columns = np.indices(masses.shape)
    even = (rows + columns) % 2 == 0
    heavy, light = masses[even], masses[~even]
    if np.ptp(heavy) or np.ptp(light):
        return None
    return float(heavy[0]), float(light[0])


@dataclasses.dataclass(frozen=True)
class PathBands:
    """The bands sampled along the path: ``distance`` (rad/m, from Gamma along the path),
    ``qx``, ``qy`` (rad/m), ``corners`` ((label, distance) of Gamma, X, M, Gamma), and per
    branch (rows, in ``names`` order) ``omega`` and the continuum line ``continuum`` (rad/s;
    NaN where a branch has no continuum line: optical branches, branches pinned by walls)."""

    names: tuple[str, ...]
    distance: np.ndarray
    qx: np.ndarray
    qy: np.ndarray
    corners: tuple[tuple[str, float], ...]
    omega: np.ndarray
    continuum: np.ndarray


class BandStructure:
    """The plane-wave bands of ``model`` (see the module docstring for the three kinds)."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.spacing = float(model.spacing)
        self.chain = model.ny == 1
        self.pair = ionic_pair(model)
        components = COMPONENTS[: model.dim]
        diagonal = registry.linear_stiffness(model).diagonal
        if diagonal and self.chain:
            raise BandError("a single row with diagonal springs to its walls is not a piece of "
                            "the infinite lattice: no bands drawn")
        if diagonal and not model.uniform_mass:
            raise BandError("diagonal springs with unequal masses: no bands drawn (equal masses "
                            "or the nearest-spring ionic checkerboard only)")
        if not model.uniform_mass and self.pair is None:
            raise BandError("the masses are neither equal nor an ionic checkerboard: the "
                            "lattice has no repeating cell, so no bands")
        if self.pair is not None:
            self.kind = "ionic"
            self.names = tuple(f"{c} {b}" for c in components for b in ("acoustic", "optical"))
        elif diagonal:
            self.kind = "diagonal"
            self.names = ("S", "P") + (("z",) if model.dim == 3 else ())
        else:
            self.kind = "nearest"
            self.names = tuple(components)
            self._waves = [polarisation(model, c) for c in components]

    # --- omega(q) ------------------------------------------------------------------------------

    def omegas(self, qx, qy) -> np.ndarray:
        """omega (rad/s) of every branch at (qx, qy) (rad/m), shaped (branches, *q's shape);
        a chain takes its own qy = pi / (2a) whatever ``qy`` says."""
        qx, qy = np.broadcast_arrays(np.asarray(qx, dtype=float), np.asarray(qy, dtype=float))
        if self.chain:
            qy = np.full_like(qx, 0.5 * math.pi / self.spacing)
        if self.kind == "nearest":
            return np.stack([wave.omega(qx, qy) for wave in self._waves])
        if self.kind == "diagonal":
            values = np.linalg.eigvalsh(dynamical_matrix(self.model, qx, qy))
            rows = [np.sqrt(np.maximum(values[..., 0], 0.0)),
                    np.sqrt(np.maximum(values[..., 1], 0.0))]
            if self.model.dim == 3:
                rows.append(polarisation(self.model, "z").omega(qx, qy))
            return np.stack(rows)
        rows = []
        for matrix in self.ionic_matrices(qx, qy):
            values = np.linalg.eigvalsh(matrix)
            rows += [np.sqrt(np.maximum(values[..., 0], 0.0)),
                     np.sqrt(np.maximum(values[..., 1], 0.0))]
        return np.stack(rows)

    def ionic_matrices(self, qx, qy) -> list[np.ndarray]:
        """The ionic checkerboard's mass-weighted dynamical matrices (rad^2/s^2), one
        (..., 2, 2) array per component (the module docstring's D)."""
        assert self.pair is not None
        heavy, light = self.pair
        a = self.spacing
        matrices = []
        for across_columns, across_rows, _, _ in polarisations(self.model):
            coupling = -2.0 * (across_columns * np.cos(qx * a) + across_rows * np.cos(qy * a)) \
                / math.sqrt(heavy * light)
            matrix = np.empty(np.shape(qx) + (2, 2))
            matrix[..., 0, 0] = 2.0 * (across_columns + across_rows) / heavy
            matrix[..., 1, 1] = 2.0 * (across_columns + across_rows) / light
            matrix[..., 0, 1] = matrix[..., 1, 0] = coupling
            matrices.append(matrix)
        return matrices

    def branch(self, name: str) -> int:
        """The row of branch ``name`` in ``omegas``."""
        if name not in self.names:
            raise BandError(f"branch must be one of {', '.join(self.names)}, got {name!r}")
        return self.names.index(name)

    # --- velocities ----------------------------------------------------------------------------

    def group_velocities(self, qx: float, qy: float) -> np.ndarray:
        """d omega / d q (m/s) of every branch at (qx, qy), shaped (branches, 2), by central
        differences of ``omegas`` (a chain: the y entry is 0)."""
        h = DIFFERENCE_STEP * math.pi / self.spacing
        vx = (self.omegas(qx + h, qy) - self.omegas(qx - h, qy)) / (2 * h)
        vy = np.zeros_like(vx) if self.chain else \
            (self.omegas(qx, qy + h) - self.omegas(qx, qy - h)) / (2 * h)
        return np.stack([vx, vy], axis=-1)

    def long_wave_speeds(self, angle: float) -> np.ndarray:
        """Each branch's long-wave speed (m/s) with q along ``angle`` (rad from +x): the slope
        of its continuum line omega = c |q|; NaN for a branch that does not start at omega = 0
        (optical branches, waves the walls of a chain pin)."""
        at_rest = self.omegas(0.0, 0.0)
        q = LONG_WAVE / self.spacing
        speeds = self.omegas(q * math.cos(angle), q * math.sin(angle)) / q
        top = max(float(np.max(self.omegas(math.pi / self.spacing, math.pi / self.spacing))),
                  1e-300)
        speeds[at_rest > 1e-6 * top] = np.nan
        return speeds

    # --- the path ------------------------------------------------------------------------------

    def corners(self) -> list[tuple[str, float, float]]:
        """(label, qx, qy) (rad/m) of the path's corners: Gamma, X, M, Gamma (a chain: Gamma, X)."""
        edge = math.pi / self.spacing
        if self.chain:
            return [("Γ", 0.0, 0.0), ("X", edge, 0.0)]
        return [("Γ", 0.0, 0.0), ("X", edge, 0.0), ("M", edge, edge), ("Γ", 0.0, 0.0)]

    def _legs(self) -> list[tuple[tuple[str, float, float], tuple[str, float, float], float]]:
        """(start corner, end corner, length (rad/m)) of each leg of the path."""
        return [(a, b, math.hypot(b[1] - a[1], b[2] - a[2]))
                for a, b in itertools.pairwise(self.corners())]

    def path(self, samples: int = 301) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple]:
        """(distance, qx, qy, corners) of ``samples`` points along the path (rad/m), each leg
        sampled in proportion to its length, every corner included."""
        legs = self._legs()
        total = sum(length for _, _, length in legs)
        distance, qx, qy = [np.zeros(1)], [np.zeros(1)], [np.zeros(1)]
        start = 0.0
        marks = [(legs[0][0][0], 0.0)]
        for (_, xa, ya), (label_b, xb, yb), length in legs:
            count = max(2, round((samples - 1) * length / total))
            fraction = np.arange(1, count + 1) / count
            distance.append(start + length * fraction)
            qx.append(xa + (xb - xa) * fraction)
            qy.append(ya + (yb - ya) * fraction)
            start += length
            marks.append((label_b, start))
        return (np.concatenate(distance), np.concatenate(qx), np.concatenate(qy), tuple(marks))

    def point(self, fraction: float) -> tuple[float, float, float]:
        """(distance, qx, qy) (rad/m) at ``fraction`` (0 to 1) of the way along the path."""
        legs = self._legs()
        wanted = min(max(float(fraction), 0.0), 1.0) * sum(length for _, _, length in legs)
        start = 0.0
        for index, ((_, xa, ya), (_, xb, yb), length) in enumerate(legs):
            if wanted <= start + length or index == len(legs) - 1:
                part = min(max((wanted - start) / length, 0.0), 1.0)
                return wanted, xa + (xb - xa) * part, ya + (yb - ya) * part
            start += length
        raise AssertionError("unreachable")

    def along_path(self, samples: int = 301) -> PathBands:
        """Every branch and its continuum line sampled along the path."""
        distance, qx, qy, marks = self.path(samples)
        omega = self.omegas(qx, qy)
        continuum = np.full_like(omega, np.nan)
        size = np.hypot(qx, qy)
        angles = np.arctan2(qy, qx)
        for angle in np.unique(np.round(angles, 12)):
            here = np.isclose(angles, angle, atol=1e-12)
            continuum[:, here] = self.long_wave_speeds(float(angle))[:, None] * size[here]
        return PathBands(self.names, distance, qx, qy, marks, omega, continuum)

    def wave(self, name: str, qx: float, qy: float) -> dict[str, float]:
        """The plane wave of branch ``name`` at (qx, qy): |q| (rad/m), wavelength (m), omega
        (rad/s), frequency (Hz), phase speed omega / |q| and group velocity (m/s)."""
        index = self.branch(name)
        if self.chain:
            qy = 0.0
        omega = float(self.omegas(qx, qy)[index])
        size = math.hypot(qx, qy)
        vx, vy = (float(v) for v in self.group_velocities(qx, qy)[index])
        return dict(q=size, qx=qx, qy=qy, wavelength=2 * math.pi / size if size else math.inf,
                    omega=omega, frequency=omega / (2 * math.pi),
                    phase_speed=omega / size if size else math.nan,
                    group_vx=vx, group_vy=vy, group_speed=math.hypot(vx, vy))


def band_structure(model: Model) -> BandStructure:
    """``BandStructure(model)`` (raises ``BandError`` for lattices without bands)."""
    return BandStructure(model)


# --- the integrator ----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class NumericalDispersion:
    """What integrator ``integrator`` at time step ``dt`` (s) makes of each frequency:
    ``omega`` (rad/s) in, ``omega_numerical`` (rad/s) out, ``growth`` |lambda| per step,
    ``stable`` where growth <= 1 + ``GROWTH_TOLERANCE``; ``exact``: a method without time-step
    error (omega_numerical = omega)."""

    integrator: str
    dt: float
    omega: np.ndarray
    omega_numerical: np.ndarray
    growth: np.ndarray
    stable: np.ndarray
    exact: bool = False


def numerical_omegas(integrator: str, omega, dt: float) -> NumericalDispersion | None:
    """The numerical dispersion of ``integrator`` at ``dt`` for the frequencies ``omega``
    (rad/s): omega_num = max |arg lambda| / dt over the eigenvalues lambda of the amplification
    matrix at (omega^2, no damping, dt).  None when the method's matrices are not known."""
    description = describe(integrator)
    omega = np.asarray(omega, dtype=float)
    if description.order == 0:  # no time-step error: every wave keeps its frequency
        ones = np.ones_like(omega)
        return NumericalDispersion(description.name, dt, omega, omega.copy(), ones,
                                   np.ones(omega.shape, bool), exact=True)
    if description.amplification is None:
        return None
    flat = omega.ravel()
    matrices = description.amplification(flat**2, np.zeros_like(flat), float(dt))
    values = small_matrices.eigenvalues(matrices)
    sizes = np.abs(values)
    growth = sizes.max(axis=-1)
    # a method carrying more than (u, u') (Verlet's cached acceleration) has eigenvalues near 0
    # that are not the wave: their angle is noise
    angles = np.where(sizes > 1e-6 * growth[:, None], np.abs(np.angle(values)), 0.0)
    turned = angles.max(axis=-1).reshape(omega.shape) / dt
    growth = growth.reshape(omega.shape)
    return NumericalDispersion(description.name, float(dt), omega, turned, growth,
                               growth <= 1.0 + GROWTH_TOLERANCE)


def verlet_omega(omega, dt: float) -> np.ndarray:
    """Velocity Verlet's numerical frequency (rad/s), (2/dt) asin(omega dt / 2); NaN beyond
    omega dt = 2 (no oscillation: the wave grows)."""
    argument = np.asarray(omega, dtype=float) * dt / 2.0
    with np.errstate(invalid="ignore"):
        return np.where(argument <= 1.0, 2.0 / dt * np.arcsin(np.minimum(argument, 1.0)), np.nan)


# --- density of states -------------------------------------------------------------------------


def mode_frequencies(model: Model) -> np.ndarray:
    """Every exact normal-mode angular frequency (rad/s) of ``model`` linearised about rest,
    all polarisations together, rising (``sim.theory.modes.ModalBasis``: any size for equal
    masses between walls, dense eigen-solutions up to ``DENSE_PARTICLE_LIMIT`` particles
    otherwise; diagonal springs raise ``ModelError``)."""
    basis = ModalBasis.of(model)
    values = np.concatenate([np.ravel(omega_squared) for omega_squared in basis.omega_squared])
    return np.sort(np.sqrt(np.maximum(values, 0.0)))


def density_of_states(model: Model, bins: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """(bin centres (rad/s), modes per rad/s in each bin) of the exact mode frequencies; the
    densities times the bin width add up to the number of modes (particles x dimensions)."""
    return density_from(mode_frequencies(model), bins)


def density_from(frequencies: np.ndarray, bins: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """``density_of_states`` of these mode frequencies (rad/s)."""
    frequencies = np.asarray(frequencies, dtype=float)
    top = float(frequencies.max()) if frequencies.size else 0.0
    if top <= 0.0:
        raise ModelError("every mode has zero frequency: no density of states")
    counts, edges = np.histogram(frequencies, bins=bins, range=(0.0, top * (1 + 1e-9)))
    width = edges[1] - edges[0]
    return 0.5 * (edges[1:] + edges[:-1]), counts / width
