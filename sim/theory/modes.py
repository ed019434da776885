"""Normal modes of the lattice linearised about rest, and what they give exactly.

About its rest state the lattice is linear: each displacement component (polarisation) obeys
M u'' + C u' + K u = f with K = k_c D_columns + k_r D_rows (five-point stiffness with fixed walls;
x moves along the horizontal springs: k_c = k, k_r = T/a; y the other way round; z has T/a
both ways), C the same with the dashpot coefficient on the along-spring part plus ``drag`` on the
diagonal, and f the particles' weights.  This module diagonalises it:

* **equal masses**: the modes are separable sines, u = sum_pq c_pq sin(p pi i/(nx+1)) sin(q pi
  j/(ny+1)), found by the orthonormal type-I discrete sine transform (``sine_transform``, numpy's
  FFT; O(N log N)); K and C are both diagonal there, so every damping is exact;
* **unequal masses**: the eigenvectors of M^-1/2 K M^-1/2 (dense ``eigh``, up to
  ``DENSE_PARTICLE_LIMIT`` particles); there only uniform drag (C proportional to M) is exact;
* **periodic rows or free row ends** (``boundary="periodic"`` / ``"free"``): the same dense
  decomposition with each row closed into a ring or its ends freed (Fourier or cosine waves
  along the rows; the stability limit uses their separable frequencies at any size,
  ``sim.theory.observables.modes``).

``ModalBasis`` maps displacements/velocities to modal coordinates and back; ``static_offset``
solves K u = f for the sag under gravity (sine basis for any masses: K does not depend on them).
Used by the exact solver (``sim.theory.exact``), the error prediction (``sim.theory.prediction``) and the
energy scale of the energy-balance error.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sim.forces import registry
from sim.model.lattice import Model, ModelError

DENSE_PARTICLE_LIMIT = 2_000
"""Largest unequal-mass lattice (particles) decomposed with a dense eigen-solver (per
polarisation an (n, n) float64 matrix: 32 MB and about 2 s at this size)."""


def sine_transform(values: np.ndarray, axis: int) -> np.ndarray:
    """Orthonormal DST-I along ``axis`` (its own inverse): X_p = sqrt(2/(n+1)) sum_i x_i
    sin(p i pi/(n+1)), i, p = 1..n, computed with an FFT of the odd extension."""
    values = np.moveaxis(np.asarray(values, dtype=float), axis, -1)
    n = values.shape[-1]
    extended = np.zeros(values.shape[:-1] + (2 * (n + 1),))
    extended[..., 1 : n + 1] = values
    extended[..., n + 2 :] = -values[..., ::-1]
    transformed = -np.fft.rfft(extended, axis=-1).imag[..., 1 : n + 1] / 2.0
    return np.moveaxis(transformed * np.sqrt(2.0 / (n + 1)), -1, axis)


FEW_NONZERO = 8
"""Up to this many nonzero values (a few displaced particles) a 2-D sine transform is summed
directly, one product of two sine columns per value: cheaper than the two FFT passes."""


def _sparse_sine_transform(field: np.ndarray) -> np.ndarray:
    """The orthonormal 2-D DST-I of an (ny, nx) field (``sine_transform`` along both axes),
    summed over its nonzero values when they are few."""
    field = np.asarray(field, dtype=float)
    rows, columns = np.nonzero(field)
    if rows.size > FEW_NONZERO:
        return sine_transform(sine_transform(field, 0), 1)
    ny, nx = field.shape
    result = np.zeros((ny, nx))
    for j, i in zip(rows, columns, strict=True):
        result += field[j, i] * np.multiply.outer(_sine_column(ny, j + 1), _sine_column(nx, i + 1))
    return result


def _sine_column(n: int, index: int) -> np.ndarray:
    """sqrt(2/(n+1)) sin(p index pi/(n+1)), p = 1..n: the DST-I of a unit value at ``index``
    (1..n); the angle reduced in integers first, so it is exact for large lattices too."""
    turns = (np.arange(1, n + 1) * index) % (2 * (n + 1))
    return np.sqrt(2.0 / (n + 1)) * np.sin(turns * np.pi / (n + 1))


def second_difference_eigenvalues(n: int, ends: str = "walls") -> np.ndarray:
    """Eigenvalues of the second difference on n points, rising: 4 sin^2(p pi / (2 (n + 1))),
    p = 1..n, between fixed walls (sine modes, in mode order); 4 sin^2(p pi / n), p = 0..n-1,
    on a ring (``ends="ring"``, Fourier modes); 4 sin^2(p pi / (2 n)), p = 0..n-1, with free
    ends (``"free"``, cosine modes)."""
    if ends == "ring":
        return np.sort(4.0 * np.sin(np.arange(n) * np.pi / n) ** 2)
    if ends == "free":
        return 4.0 * np.sin(np.arange(n) * np.pi / (2.0 * n)) ** 2
    p = np.arange(1, n + 1)
    return 4.0 * np.sin(p * np.pi / (2.0 * (n + 1))) ** 2


def polarisations(model: Model) -> list[tuple[float, float, float, float]]:
    """(stiffness across columns, across rows, dashpot across columns, across rows) per
    displacement component (N/m, N s/m): x along the horizontal springs, y along the vertical
    ones, z across all (linearised springs; dashpots act along springs only)."""
    stiffness = registry.linear_stiffness(model)
    k, tension, c = stiffness.along, stiffness.tension / model.spacing, model.damping
    result = [(k, tension, c, 0.0), (tension, k, 0.0, c)]
    if model.dim == 3:
        result.append((tension, tension, 0.0, 0.0))
    return result


def stiffness_matrix(nx: int, ny: int, across_columns: float, across_rows: float,
                      ends: str = "walls") -> np.ndarray:
    """Dense (n, n) five-point matrix with fixed walls for one polarisation (row-major j*nx+i);
    with ``ends="ring"`` each row is a ring (its last particle joined to its first), with
    ``"free"`` the rows' end particles have no wall spring."""
    periodic = ends == "ring"
    n = nx * ny
    matrix = np.zeros((n, n))
    index = np.arange(n).reshape(ny, nx)
    matrix[np.arange(n), np.arange(n)] = 2.0 * across_columns + 2.0 * across_rows
    if periodic:  # every particle i joined to i + 1 mod nx, adding up repeated pairs
        for i in range(nx):
            a, b = index[:, i], index[:, (i + 1) % nx]
            matrix[a, b] -= across_columns
            matrix[b, a] -= across_columns
    else:
        left, right = index[:, :-1].ravel(), index[:, 1:].ravel()
        matrix[left, right] = matrix[right, left] = -across_columns
    if ends == "free":
        matrix[index[:, 0], index[:, 0]] -= across_columns
        matrix[index[:, -1], index[:, -1]] -= across_columns
    lower, upper = index[:-1, :].ravel(), index[1:, :].ravel()
    matrix[lower, upper] = matrix[upper, lower] = -across_rows
    return matrix


_SPRING_DIRECTIONS = ((1, 0), (0, 1), (1, 1), (-1, 1))
"""Rest directions (columns, rows) of the springs: nearest along x and y, the two diagonals."""


def in_plane_stiffness(nx: int, ny: int, stiffness: float, tension_stiffness: float,
                       diagonal_stiffness: float, ends: str = "walls",
                       row_ring: bool = False) -> np.ndarray:
    """Dense (2n, 2n) stiffness (N/m) of the in-plane motion (x of particle p at 2p, y at
    2p + 1, p = j nx + i), with diagonal springs, built spring by spring: each adds
    K_s = K_along n n^T + K_across (1 - n n^T) between its ends (nearest: k along, T/a across;
    diagonal: k2 along, nothing across).  Every site outside the lattice is a fixed wall site;
    ``ends`` "ring" closes the rows, "free" drops every spring to the left and right walls;
    ``row_ring`` also closes the columns (a torus, whose modes are plane waves)."""
    n = nx * ny
    matrix = np.zeros((2 * n, 2 * n))

    def index(i: int, j: int) -> int | None:
        if ends == "ring":
            i %= nx
        if row_ring:
            j %= ny
        return j * nx + i if 0 <= i < nx and 0 <= j < ny else None

    for di, dj in _SPRING_DIRECTIONS:
        diagonal = di != 0 and dj != 0
        along, across = (diagonal_stiffness, 0.0) if diagonal else (stiffness, tension_stiffness)
        direction = np.array([di, dj], dtype=float) / np.hypot(di, dj)
        block = along * np.outer(direction, direction) + across * (
            np.eye(2) - np.outer(direction, direction))
        for j in range(-1, ny + 1):
            for i in range(-1, nx + 1):
                ends_columns = (i, i + di)
                if (ends == "ring" or ends == "free") and not all(
                        0 <= c < nx for c in ends_columns):
                    if ends == "free" or not 0 <= i < nx:
                        continue  # free: no wall spring; ring: each spring from its first end
                if row_ring and not 0 <= j < ny:
                    continue
                first, second = index(i, j), index(i + di, j + dj)
                for p in (first, second):
                    if p is not None:
                        matrix[2 * p:2 * p + 2, 2 * p:2 * p + 2] += block
                if first is not None and second is not None:
                    matrix[2 * first:2 * first + 2, 2 * second:2 * second + 2] -= block
                    matrix[2 * second:2 * second + 2, 2 * first:2 * first + 2] -= block
    return matrix


@dataclasses.dataclass(frozen=True)
class ModalBasis:
    """The modes of one model.  Per polarisation c: ``omega_squared[c]`` (rad^2/s^2) and
    ``damping_rate[c]`` (1/s; each mode obeys q'' + beta q' + omega^2 q = 0), shaped (ny, nx)
    for sine modes (entry [q-1, p-1]) or (n,) for eigenvectors.  ``damping_exact`` says whether
    the damping is diagonal in these modes (else the rates are Rayleigh quotients)."""

    model: Model
    separable: bool
    omega_squared: tuple[np.ndarray, ...]
    damping_rate: tuple[np.ndarray, ...]
    damping_exact: bool
    vectors: tuple[np.ndarray, ...] | None = None
    """Unequal masses: M^-1/2-scaled eigenvectors per polarisation, columns are modes."""

    @classmethod
    def of(cls, model: Model) -> ModalBasis:
        """The modes of ``model``; unequal masses above ``DENSE_PARTICLE_LIMIT`` raise ModelError."""
        nx, ny = model.nx, model.ny
        if registry.linear_stiffness(model).diagonal:
            raise ModelError("diagonal springs couple x and y, so the modes are not one "
                             "polarisation at a time; the normal-mode solution (exact "
                             "integrator, predicted errors) has no diagonal springs yet")
        if model.uniform_mass and model.row_ends == "walls":
            mass = float(model.masses.flat[0])
            columns = second_difference_eigenvalues(nx)[None, :]
            rows = second_difference_eigenvalues(ny)[:, None]
            omega, rate = [], []
            for k_columns, k_rows, c_columns, c_rows in polarisations(model):
                omega.append((k_columns * columns + k_rows * rows) / mass)
                rate.append((c_columns * columns + c_rows * rows + model.drag) / mass)
            return cls(model, True, tuple(omega), tuple(rate), True)
        if model.n_particles > DENSE_PARTICLE_LIMIT:
            what = "an unequal-mass" if model.row_ends == "walls" else f"a {model.boundary}-ended"
            raise ModelError(
                f"the modes of {what} lattice are computed up to {DENSE_PARTICLE_LIMIT:,} "
                f"particles (dense eigen-decomposition); this one has {model.n_particles:,}"
            )
        scale = 1.0 / np.sqrt(np.asarray(model.masses, dtype=float).ravel())
        omega, rate, vectors = [], [], []
        for k_columns, k_rows, c_columns, c_rows in polarisations(model):
            stiffness = stiffness_matrix(nx, ny, k_columns, k_rows, model.row_ends)
            values, eigenvectors = np.linalg.eigh(stiffness * np.outer(scale, scale))
            damping = stiffness_matrix(nx, ny, c_columns, c_rows, model.row_ends)
            damping = damping * np.outer(scale, scale)
            damping += np.diag(model.drag * scale**2)
            omega.append(values)
            rate.append(np.einsum("im,ij,jm->m", eigenvectors, damping, eigenvectors))
            vectors.append(eigenvectors)
        # with unequal masses neither the dashpots nor a uniform drag (M^-1 drag in acceleration
        # units) is diagonal in these modes: only undamped lattices are exact
        exact = model.damping == 0.0 and model.drag == 0.0
        if model.uniform_mass:  # rings or free ends, equal masses: uniform drag is diagonal too
            exact = model.damping == 0.0
        return cls(model, False, tuple(omega), tuple(rate), exact, tuple(vectors))

    # --- transforms: fields are (ny, nx) per polarisation --------------------------------------

    def to_modes(self, field: np.ndarray, polarisation: int) -> np.ndarray:
        """Modal coordinates (in mass-weighted units: energy = 1/2 (q'^2 + omega^2 q^2)) of one
        displacement or velocity component (ny, nx)."""
        model = self.model
        if not np.any(field):  # at rest, or no velocity: often most of a state
            return np.zeros(model.ny * model.nx if not self.separable else (model.ny, model.nx))
        if self.separable:
            root_mass = np.sqrt(float(model.masses.flat[0]))
            return _sparse_sine_transform(field) * root_mass
        root_masses = np.sqrt(np.asarray(model.masses, dtype=float).ravel())
        assert self.vectors is not None
        return self.vectors[polarisation].T @ (np.asarray(field).ravel() * root_masses)

    def from_modes(self, coordinates: np.ndarray, polarisation: int) -> np.ndarray:
        """The (ny, nx) field of modal coordinates (inverse of ``to_modes``)."""
        model = self.model
        if self.separable:
            root_mass = np.sqrt(float(model.masses.flat[0]))
            return sine_transform(sine_transform(coordinates, 0), 1) / root_mass
        root_masses = np.sqrt(np.asarray(model.masses, dtype=float).ravel())
        assert self.vectors is not None
        return (self.vectors[polarisation] @ coordinates / root_masses).reshape(model.ny, model.nx)


def static_offset(model: Model) -> np.ndarray:
    """(dim, ny, nx) displacement of the linearised lattice's equilibrium under gravity (m):
    the solution of K u = m g per component, through the sine transform (K is separable for any
    masses).  Zeros without gravity."""
    offset = np.zeros((model.dim, model.ny, model.nx))
    if not model.has_gravity and not _pulls_free_ends(model):
        return offset
    if model.row_ends != "walls":
        return _ring_static_offset(model, offset)
    columns = second_difference_eigenvalues(model.nx)[None, :]
    rows = second_difference_eigenvalues(model.ny)[:, None]
    masses = np.asarray(model.masses, dtype=float).reshape(model.ny, model.nx)
    for component, (k_columns, k_rows, _, _) in enumerate(polarisations(model)):
        g = float(model.gravity[component])
        if g == 0.0:
            continue
        force = sine_transform(sine_transform(masses * g, 0), 1)
        offset[component] = sine_transform(
            sine_transform(force / (k_columns * columns + k_rows * rows), 0), 1
        )
    return offset


def _ring_static_offset(model: Model, offset: np.ndarray) -> np.ndarray:
    """``static_offset`` of a periodic or free-ended lattice by a dense least-squares solve (a
    pull along the rows may have no restoring force there: the smallest solution is taken)."""
    if model.n_particles > DENSE_PARTICLE_LIMIT:
        raise ModelError(f"the sag of a {model.boundary} lattice is solved up to {DENSE_PARTICLE_LIMIT:,} "
                         f"particles; this one has {model.n_particles:,}")
    masses = np.asarray(model.masses, dtype=float).ravel()
    for component, (k_columns, k_rows, _, _) in enumerate(polarisations(model)):
        g = float(model.gravity[component])
        force = (masses * g).reshape(model.ny, model.nx)
        if component == 0 and _pulls_free_ends(model):
            # each free end's one spring pulls it inward with the rest tension T
            force[:, 0] += model.tension
            force[:, -1] -= model.tension
        if not np.any(force):
            continue
        matrix = stiffness_matrix(model.nx, model.ny, k_columns, k_rows, model.row_ends)
        solution = np.linalg.lstsq(matrix, force.ravel(), rcond=None)[0]
        offset[component] = solution.reshape(model.ny, model.nx)
    return offset


def _pulls_free_ends(model: Model) -> bool:
    """Whether the rest tension pulls free row ends inward (free ends of a pre-tensioned
    lattice: the linearised law's constant term T no longer cancels there)."""
    return model.row_ends == "free" and model.tension != 0.0


def gravity_release_energy(model: Model) -> float:
    """Energy (J) gravity releases as the linearised lattice sags from rest to equilibrium,
    1/2 f . K^-1 f (half of it ends in the springs); zero without gravity.  A lattice without
    stiffness in some direction of the pull (or is compressed) gives +inf: no small sag."""
    if not model.has_gravity:
        return 0.0
    if any(
        model.gravity[component] != 0.0
        and (k_columns < 0.0 or k_rows < 0.0 or k_columns + k_rows == 0.0)
        for component, (k_columns, k_rows, _, _) in enumerate(polarisations(model))
    ):
        return float("inf")
    masses = np.asarray(model.masses, dtype=float).reshape(model.ny, model.nx)
    try:
        offset = static_offset(model)
    except ModelError:  # a large periodic lattice: no sag computed, fall back on its size
        return float("inf")
    work = 0.0
    for component in range(model.dim):
        work += float((masses * model.gravity[component] * offset[component]).sum())
    return 0.5 * work


POLARISATION_NAMES = ("x", "y", "z")
"""Displacement components: in-plane x (along rows), in-plane y (along columns), out of plane z."""


def mode_energies(model: Model, positions: np.ndarray, velocities: np.ndarray,
                  basis: ModalBasis | None = None) -> list[np.ndarray]:
    """Energy (J) in each normal mode of the lattice linearised about its equilibrium, per
    polarisation: (ny, nx) arrays indexed [n-1, m-1] for mode (m, n) with equal masses (m
    half-waves along x, n along y), (n_particles,) arrays in rising frequency otherwise.

    positions, velocities: (n_particles, dim) m, m/s.  For a linear scene the energies add up to
    kinetic + potential energy minus the potential energy of the equilibrium (without gravity:
    kinetic + spring energy), to round-off, and each is constant without damping."""
    basis = basis or ModalBasis.of(model)
    shape = (model.dim, model.ny, model.nx)
    displacement = (np.asarray(positions, float) - model.rest_positions).T.reshape(shape)
    displacement = displacement - static_offset(model)
    velocity = np.asarray(velocities, float).T.reshape(shape)
    energies = []
    for component in range(model.dim):
        q = basis.to_modes(displacement[component], component)
        v = basis.to_modes(velocity[component], component)
        energies.append(0.5 * (v**2 + basis.omega_squared[component] * q**2))
    return energies


def _sine_modes_only(model: Model) -> None:
    if model.row_ends == "free":
        raise ModelError("the modes of free-ended rows are cosine waves, not the sine modes "
                         "(m, n) of fixed walls; use mode_energies, which lists them in rising "
                         "frequency")
    if model.periodic:
        raise ModelError("the modes of a ring are Fourier waves (cos and sin of 2 pi m i / nx), "
                         "not the sine modes (m, n) of fixed walls; use mode_energies, which "
                         "lists them in rising frequency")


def mode_shape(model: Model, m: int, n: int) -> np.ndarray:
    """(ny, nx) displacement pattern of the equal-mass sine mode (m, n), largest entry 1:
    sin(m pi i / (nx + 1)) sin(n pi j / (ny + 1)) for column i, row j (1-based)."""
    _sine_modes_only(model)
    if not (1 <= m <= model.nx and 1 <= n <= model.ny):
        raise ModelError(f"mode (m, n) must have 1 <= m <= {model.nx} and 1 <= n <= {model.ny}, "
                         f"got ({m}, {n})")
    columns = np.sin(m * np.pi * np.arange(1, model.nx + 1) / (model.nx + 1))
    rows = np.sin(n * np.pi * np.arange(1, model.ny + 1) / (model.ny + 1))
    shape = np.outer(rows, columns)
    return shape / np.abs(shape).max()


def mode_frequency(model: Model, m: int, n: int, polarisation: int) -> float:
    """Angular frequency (rad/s) of the equal-mass sine mode (m, n) of one polarisation."""
    _sine_modes_only(model)
    k_columns, k_rows, _, _ = polarisations(model)[polarisation]
    mass = float(np.asarray(model.masses).mean())
    value = (k_columns * second_difference_eigenvalues(model.nx)[m - 1]
             + k_rows * second_difference_eigenvalues(model.ny)[n - 1]) / mass
    return float(np.sqrt(max(value, 0.0)))


def excited_state(model: Model, m: int, n: int, polarisation: int,
                  amplitude: float) -> tuple[np.ndarray, np.ndarray]:
    """(positions, velocities) as (n_particles, dim) arrays: the lattice at its equilibrium with
    the equal-mass mode (m, n) of one polarisation displaced by ``amplitude`` (m) at its largest
    point, at rest: that mode alone carries the energy (linear scenes, equal masses)."""
    _sine_modes_only(model)
    if not model.uniform_mass:
        raise ModelError("a single sine mode is a normal mode only when all masses are equal")
    if not 0 <= polarisation < model.dim:
        raise ModelError(f"polarisation must be one of {POLARISATION_NAMES[: model.dim]}")
    displacement = static_offset(model)
    displacement[polarisation] += amplitude * mode_shape(model, m, n)
    positions = model.rest_positions + displacement.reshape(model.dim, -1).T
    return positions, np.zeros_like(positions)
