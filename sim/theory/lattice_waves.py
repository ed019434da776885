"""Plane waves on the square lattice: each polarisation's dispersion relation, the wavelength and
the phase and group velocities along any direction, and the phase a wave of one frequency gathers
between two points (what interference patterns are made of).

For small displacements every component of the displacement obeys, on its own, a scalar lattice
wave equation with one spring constant across columns (kx) and one across rows (ky)
(``sim.theory.modes.polarisations``): x feels the springs' stiffness along x and their tension across
them, y the reverse, z (out of the plane of a 3-D lattice) the tension both ways.  A plane wave
u = exp(i (qx x + qy y - omega t)) of such a component has

    omega^2 = (4 / m) (kx sin^2(qx a / 2) + ky sin^2(qy a / 2))        (a: spacing, m: mass)

so the lattice is **anisotropic** whenever kx != ky (the in-plane components of a pre-tensioned
lattice: a point source draws an ellipse, not a circle) and, even when kx == ky (u_z), isotropic
only for wavelengths long against the spacing.  Waves of one frequency travel along rays in the
direction of the group velocity d omega / dq, not of q; the phase gathered from a source to a
point r is q . r for the q whose group velocity points along r (stationary phase), which for
kx == ky and long waves is the familiar 2 pi |r| / lambda.

Units: a in m, m in kg, k in N/m, omega in rad/s, q in rad/m, lengths in m, speeds in m/s.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.forces import registry
from sim.model.lattice import Model
from sim.theory.modes import polarisations

COMPONENTS = ("x", "y", "z")
CONTOUR_SAMPLES = 720
"""Angles of q at which a frequency's contour is sampled to find a ray."""
ZOOM_SAMPLES, ZOOM_ROUNDS = 41, 4
"""Each finer sampling of the contour around the best angle: samples and rounds."""


class WaveError(ValueError):
    """A frequency or direction the lattice cannot carry (the message says why)."""


@dataclasses.dataclass(frozen=True)
class Polarisation:
    """One displacement component's wave equation on a lattice of equal masses.

    ``across_columns`` (kx) and ``across_rows`` (ky): effective spring constants (N/m);
    ``mass`` (kg) and ``spacing`` (m).
    """

    across_columns: float
    across_rows: float
    mass: float
    spacing: float
    _contours: dict = dataclasses.field(default_factory=dict, compare=False, repr=False)

    def omega(self, qx: np.ndarray | float, qy: np.ndarray | float) -> np.ndarray:
        """Angular frequency (rad/s) of the plane wave with wave vector (qx, qy) (rad/m)."""
        half = 0.5 * self.spacing
        squared = 4.0 / self.mass * (
            self.across_columns * np.sin(np.asarray(qx) * half) ** 2
            + self.across_rows * np.sin(np.asarray(qy) * half) ** 2
        )
        return np.sqrt(squared)

    def group_velocity(self, qx: float, qy: float) -> tuple[float, float]:
        """d omega / d q (m/s) at wave vector (qx, qy): the velocity of a wave packet."""
        omega = float(self.omega(qx, qy))
        if omega == 0.0:
            return self.long_wave_speeds()
        a = self.spacing
        factor = a / (self.mass * omega)
        return (factor * self.across_columns * math.sin(qx * a),
                factor * self.across_rows * math.sin(qy * a))

    def long_wave_speeds(self) -> tuple[float, float]:
        """Speeds (m/s) of long waves along x and along y: a sqrt(kx / m), a sqrt(ky / m)."""
        return (self.spacing * math.sqrt(self.across_columns / self.mass),
                self.spacing * math.sqrt(self.across_rows / self.mass))

    def highest_omega(self, angle: float) -> float:
        """The largest angular frequency (rad/s) a wave with q along ``angle`` (rad from +x)
        reaches inside the first zone |qx|, |qy| <= pi / a."""
        q_edge = self._zone_edge(angle)
        return float(self.omega(q_edge * math.cos(angle), q_edge * math.sin(angle)))

    def wavenumber(self, omega: float, angle: float) -> float:
        """|q| (rad/m) of the wave of angular frequency ``omega`` whose wave vector points along
        ``angle`` (rad from +x), found by bisection (omega grows with |q| inside the zone)."""
        if not (math.isfinite(omega) and omega > 0.0):
            raise WaveError(f"the angular frequency must be positive and finite, got {omega!r}")
        q_edge = self._zone_edge(angle)
        cos, sin = math.cos(angle), math.sin(angle)
        if omega > float(self.omega(q_edge * cos, q_edge * sin)) * (1.0 + 1e-12):
            raise WaveError(
                f"omega = {omega:.4g} rad/s is above the highest frequency the lattice carries "
                f"along {math.degrees(angle):.0f} deg ({self.highest_omega(angle):.4g} rad/s)"
            )
        low, high = 0.0, q_edge
        for _ in range(200):
            middle = 0.5 * (low + high)
            if float(self.omega(middle * cos, middle * sin)) < omega:
                low = middle
            else:
                high = middle
            if high - low <= 1e-15 * q_edge:
                break
        return 0.5 * (low + high)

    def wavelength(self, omega: float, angle: float = 0.0) -> float:
        """Wavelength (m) of the wave of angular frequency ``omega`` with q along ``angle``."""
        return 2.0 * math.pi / self.wavenumber(omega, angle)

    def phase_velocity(self, omega: float, angle: float = 0.0) -> float:
        """omega / |q| (m/s) along ``angle``."""
        return omega / self.wavenumber(omega, angle)

    def ray(self, omega: float, direction: float) -> tuple[float, float]:
        """The wave vector (qx, qy) (rad/m) on the frequency-``omega`` contour whose group
        velocity points along ``direction`` (rad from +x): the wave a source sends that way.

        The contour is sampled at ``CONTOUR_SAMPLES`` angles of q (once per frequency); around
        the sample whose group velocity is closest in direction, ``ZOOM_ROUNDS`` finer samplings
        narrow the angle down to about 1e-8 rad.
        """
        angles, directions = self._contour(float(omega))
        offsets = np.abs(_angles_between(directions, direction))
        if np.all(np.isnan(offsets)):
            raise WaveError(f"omega = {omega:.4g} rad/s is above every frequency the lattice carries")
        best = int(np.nanargmin(offsets))
        half_width = 2.0 * math.pi / CONTOUR_SAMPLES
        centre = float(angles[best])
        for _ in range(ZOOM_ROUNDS):
            fine = np.linspace(centre - half_width, centre + half_width, ZOOM_SAMPLES)
            fine_directions = self._ray_directions(omega, fine)
            offsets = np.abs(_angles_between(fine_directions, direction))
            centre = float(fine[int(np.nanargmin(offsets))])
            half_width *= 2.0 / (ZOOM_SAMPLES - 1)
        q = float(self._wavenumbers(omega, np.array([centre]))[0])
        return q * math.cos(centre), q * math.sin(centre)

    def contour(self, omega: float, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                 np.ndarray]:
        """(qx, qy) (rad/m) of the frequency-``omega`` waves whose wave vectors point along
        ``angles`` (rad from +x), and the directions (rad) of their group velocities (the rays);
        NaN where the lattice carries no such wave.  All at once (no search per ray)."""
        angles = np.asarray(angles, dtype=float)
        q = self._wavenumbers(float(omega), angles)
        return q * np.cos(angles), q * np.sin(angles), self._ray_directions(float(omega), angles)

    def _contour(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """Angles of q (rad) round the frequency-``omega`` contour and the directions (rad) of
        the group velocity there (NaN where the lattice carries no such wave); cached."""
        cached = self._contours.get(omega)
        if cached is None:
            angles = np.linspace(-math.pi, math.pi, CONTOUR_SAMPLES, endpoint=False)
            cached = (angles, self._ray_directions(omega, angles))
            self._contours[omega] = cached
        return cached

    def _wavenumbers(self, omega: float, angles: np.ndarray) -> np.ndarray:
        """|q| (rad/m) along each of ``angles`` at ``omega`` by bisection, all at once (NaN
        where omega is above the highest frequency along that angle)."""
        cos, sin = np.cos(angles), np.sin(angles)
        edge = math.pi / self.spacing / np.maximum(np.abs(cos), np.abs(sin))
        low, high = np.zeros_like(edge), edge.copy()
        for _ in range(60):
            middle = 0.5 * (low + high)
            below = self.omega(middle * cos, middle * sin) < omega
            low = np.where(below, middle, low)
            high = np.where(below, high, middle)
        q = 0.5 * (low + high)
        q[self.omega(edge * cos, edge * sin) < omega * (1.0 - 1e-12)] = np.nan
        return q

    def _ray_directions(self, omega: float, angles: np.ndarray) -> np.ndarray:
        """Directions (rad) of the group velocity at the contour points along ``angles``."""
        q = self._wavenumbers(omega, angles)
        a = self.spacing
        vx = self.across_columns * np.sin(q * np.cos(angles) * a)
        vy = self.across_rows * np.sin(q * np.sin(angles) * a)
        return np.arctan2(vy, vx)

    def phase(self, omega: float, dx: float, dy: float) -> float:
        """Phase (rad) a wave of angular frequency ``omega`` gathers from a point source to the
        point (dx, dy) (m) away from it, far from the source: q . r for the wave vector q whose
        group velocity points at the point (stationary phase)."""
        if dx == 0.0 and dy == 0.0:
            return 0.0
        qx, qy = self.ray(omega, math.atan2(dy, dx))
        return qx * dx + qy * dy

    def _zone_edge(self, angle: float) -> float:
        """|q| (rad/m) where the ray from the origin along ``angle`` leaves the first zone."""
        edge = math.pi / self.spacing
        largest = max(abs(math.cos(angle)), abs(math.sin(angle)))
        return edge / largest


def _angles_between(angles: np.ndarray, reference: float) -> np.ndarray:
    """angles - reference wrapped into [-pi, pi) (rad)."""
    return (angles - reference + math.pi) % (2.0 * math.pi) - math.pi


def polarisation(model: Model, component: str) -> Polarisation:
    """The wave equation of displacement ``component`` ("x", "y" or "z") of ``model``'s lattice
    (which must have equal masses; "z" needs a 3-D lattice)."""
    if component not in COMPONENTS:
        raise WaveError(f"component must be one of {', '.join(COMPONENTS)}, got {component!r}")
    index = COMPONENTS.index(component)
    if index >= model.dim:
        raise WaveError(f"a {model.dim}-D lattice has no {component} displacement")
    masses = np.asarray(model.masses)
    if not np.allclose(masses, masses.flat[0]):
        raise WaveError("plane waves of one wavelength need equal masses")
    across_columns, across_rows, _, _ = polarisations(model)[index]
    return Polarisation(float(across_columns), float(across_rows), float(masses.flat[0]),
                        float(model.spacing))


# --- in-plane waves with diagonal springs: two coupled branches ---------------------------------


def dynamical_matrix(model: Model, qx, qy, mass: float | None = None) -> np.ndarray:
    """The in-plane dynamical matrix D(q) (rad^2/s^2), shaped (..., 2, 2), of a lattice of equal
    masses: m D = sum over the springs' directions n of 2 (1 - cos q . d) (K_along n n^T +
    K_across (1 - n n^T)), d the spring's rest vector; with nearest springs (k, T/a) and diagonal
    ones (k2, 0):

        m D_xx = 2 k (1 - cx) + 2 (T/a) (1 - cy) + 2 k2 (1 - cx cy)
        m D_yy = 2 (T/a) (1 - cx) + 2 k (1 - cy) + 2 k2 (1 - cx cy)
        m D_xy = 2 k2 sx sy,        cx = cos(qx a), sx = sin(qx a), likewise y.

    Its eigenvalues are omega^2 of the two in-plane branches (``in_plane_omegas``).  ``mass``
    (kg) defaults to the lattice's (equal) mass."""
    qx, qy = np.broadcast_arrays(np.asarray(qx, dtype=float), np.asarray(qy, dtype=float))
    a, stiffness = model.spacing, registry.linear_stiffness(model)
    k, tension, k2 = stiffness.along, stiffness.tension / a, stiffness.diagonal
    cx, cy, sx, sy = np.cos(qx * a), np.cos(qy * a), np.sin(qx * a), np.sin(qy * a)
    both = 2 * k2 * (1 - cx * cy)
    matrix = np.empty(qx.shape + (2, 2))
    matrix[..., 0, 0] = 2 * k * (1 - cx) + 2 * tension * (1 - cy) + both
    matrix[..., 1, 1] = 2 * tension * (1 - cx) + 2 * k * (1 - cy) + both
    matrix[..., 0, 1] = matrix[..., 1, 0] = 2 * k2 * sx * sy
    return matrix / (float(np.asarray(model.masses).flat[0]) if mass is None else mass)


def in_plane_omegas(model: Model, qx, qy) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) angular frequencies (rad/s) of the two in-plane branches at (qx, qy)
    (rad/m); along an axis of an isotropic solid the lower is the S (transverse) wave and the
    upper the P (longitudinal) one."""
    values = np.linalg.eigvalsh(dynamical_matrix(model, qx, qy))
    values = np.sqrt(np.maximum(values, 0.0))
    return values[..., 0], values[..., 1]


def elastic_constants(model: Model) -> dict[str, float]:
    """The lattice's 2-D elastic constants (N/m) from its springs, and the long waves' speeds
    (m/s) along x: C11 = k + k2, C12 = C44 = k2 (Lame lambda = C12, mu = C44, isotropic when
    C11 - C12 = 2 C44, k2 = k / 2), the sheet's density rho = m / a^2 (kg/m^2),
    P speed sqrt(C11 / rho), S speed sqrt((C44 + T/a) / rho) (the rest tension T of the nearest
    springs stiffens shear like a string's)."""
    a, stiffness = model.spacing, registry.linear_stiffness(model)
    k, k2, prestress = stiffness.along, stiffness.diagonal, stiffness.tension / a
    rho = float(np.asarray(model.masses).flat[0]) / a**2
    constants = dict(C11=k + k2, C12=k2, C44=k2, lame_lambda=k2, lame_mu=k2, density=rho,
                     prestress=prestress)
    constants["p_speed"] = math.sqrt(constants["C11"] / rho)
    constants["s_speed"] = math.sqrt(max(k2 + prestress, 0.0) / rho)
    return constants


def diagonal_mode_sample(model: Model, sample: int = 144) -> tuple[np.ndarray, np.ndarray, bool]:
    """(omega^2 (rad^2/s^2), damping rates (1/s), exact) of plane waves sampling the zone, for
    the stability limit of a lattice with diagonal springs: the in-plane branches (eigenvalues
    of ``dynamical_matrix``, damping rates the Rayleigh quotients of the dashpots' and drag's
    matrix on their eigenvectors) and, in 3-D, the out-of-plane waves (tension only).  The
    walls' modes are not plane waves, but the lattice between fixed sites is a piece of the
    infinite one, so no mode is higher than the zone's highest wave, which the sample includes
    (q up to pi / a): omega_max is an upper bound, tight to O(1 / n^2).  Unequal masses: the
    lightest one (a bound again); ``exact`` is False then, or when damped."""
    a = model.spacing
    mass = float(np.asarray(model.masses).min())
    q = np.linspace(0.0, math.pi / a, min(max(model.nx, model.ny), sample) + 1)[1:]
    qx, qy = np.meshgrid(q, q)
    values, vectors = np.linalg.eigh(dynamical_matrix(model, qx, qy, mass))
    cx, cy = np.cos(qx * a), np.cos(qy * a)
    damping = np.zeros(qx.shape + (2, 2))
    damping[..., 0, 0] = 2 * model.damping * (1 - cx) + model.drag
    damping[..., 1, 1] = 2 * model.damping * (1 - cy) + model.drag
    rates = np.einsum("...im,...ij,...jm->...m", vectors, damping, vectors) / mass
    omega_squared, rate = [values.ravel()], [rates.ravel()]
    if model.dim == 3:
        tension = model.tension / a
        omega_squared.append((2 * tension * (2 - cx - cy) / mass).ravel())
        rate.append(np.full(qx.size, model.drag / mass))
    exact = model.uniform_mass and not model.is_damped
    return np.concatenate(omega_squared), np.concatenate(rate), exact
