"""The immutable description of a lattice: sizes, masses, springs, damping, gravity, flags.

A ``Model`` says *what* is simulated and never changes; changing a parameter mid-run builds a new
model with ``Model.replace``.  Geometry conventions (used everywhere in the project):

* ``nx`` columns by ``ny`` rows of particles, spacing ``spacing`` (m); particle ``p = j * nx + i``
  for column ``i`` and row ``j``, the order of the ``(ny, nx)`` arrays;
* the lattice is centred on the origin: particle (i, j) rests at
  ``((i - (nx - 1) / 2) * spacing, (j - (ny - 1) / 2) * spacing, 0)``; row 0 is at the bottom and
  "down" is -y;
* every particle has a spring to each of its 4 nearest neighbours; a neighbour missing at the
  boundary is a fixed wall anchor one spacing away (Dirichlet boundary), so a 1x1 lattice is a
  single particle held by 4 springs;
* springs are listed horizontal ones first, row by row (``ny * (nx + 1)``, spring ``i`` of a row
  joins particle ``i - 1`` or the left anchor to particle ``i`` or the right anchor), then vertical
  ones (``(ny + 1) * nx``, spring ``j`` of a column joins row ``j - 1`` or the bottom anchor to row
  ``j`` or the top anchor).  ``Model.springs`` gives both ends as indices into
  ``concatenate([particles, anchors])``; anchors are numbered left (ny), right (ny), bottom (nx),
  top (nx).

Size limits: ``nx`` and ``ny`` are at most ``MAX_SIDE`` and the lattice has at most
``MAX_PARTICLES`` particles; ``Model.create`` also refuses a lattice whose simulation would not fit
in the memory available now (``estimated_bytes``, checked before any array is allocated).
"""

from __future__ import annotations

import dataclasses
import math
from functools import cached_property
from typing import Any

import numpy as np
import psutil

from sim.model import boundaries, schema
from sim.model.boundaries import Boundary


class ModelError(ValueError):
    """An invalid lattice parameter (the message says which one and why)."""


MAX_SIDE = 20_000
"""Largest nx or ny (a 20,000-particle chain; the paper's largest run is 682x383)."""

MAX_PARTICLES = 20_000_000
"""Largest nx * ny: about 5 GB for a 2-D simulation (see ``estimated_bytes``), and still about 4
RK4 steps per second."""


def estimated_bytes(nx: int, ny: int, dim: int) -> int:
    """Memory (bytes) a ``Simulation`` of an nx x ny lattice in ``dim`` dimensions needs at its
    peak, a slightly generous estimate (measured peaks: 225 bytes per particle in 2-D, 330 in 3-D).

    Per particle, in float64 (8 bytes) per component (dim of them):
      2 state (positions, velocities) + 2 blow-up checkpoint + 2 scene initial condition
      + 1 rest positions + 2 integrator work arrays (Verlet; RK4 and Heun keep a few rows only)
      + 3 temporaries of the energy and strain evaluations  = 12 arrays: 96 * dim bytes;
    plus masses and inverse masses (16 bytes) and about 2 springs per particle, each with two
    int64 end indices and a float64 strain (48 bytes).  2-D: 256 bytes, 3-D: 352 bytes.
    """
    particles = nx * ny
    springs = ny * (nx + 1) + (ny + 1) * nx
    return particles * (96 * dim + 16) + springs * 24


def available_memory() -> int | None:
    """Bytes of memory available now to a new process without swapping (``psutil``: Linux's
    MemAvailable); None when it cannot be read."""
    try:
        return int(psutil.virtual_memory().available)
    except (OSError, RuntimeError, AttributeError, NotImplementedError):
        return None


def check_size(nx: int, ny: int, dim: int) -> None:
    """Raise ``ModelError`` if the lattice exceeds ``MAX_SIDE`` / ``MAX_PARTICLES`` or if its
    simulation would need more memory than is available (``estimated_bytes``)."""
    for name, value in (("nx", nx), ("ny", ny)):
        if value > MAX_SIDE:
            raise ModelError(f"{name} must be at most {MAX_SIDE:,}, got {value:,}")
    if nx * ny > MAX_PARTICLES:
        raise ModelError(f"{nx}x{ny} = {nx * ny:,} particles is more than the {MAX_PARTICLES:,} allowed")
    needed = estimated_bytes(nx, ny, dim)
    available = available_memory()
    if available is not None and needed > available:
        raise ModelError(
            f"a {nx}x{ny} lattice in {dim}-D needs about {needed / 2**30:.2f} GB of memory "
            f"({needed / (nx * ny):.0f} bytes per particle), only {available / 2**30:.2f} GB "
            "are available; use a smaller nx/ny"
        )


def _finite_positive(name: str, value: Any, allow_zero: bool = False) -> float:
    """A lattice parameter: a number (not a string) within ``sim.model.schema.BOUNDS``."""
    number = schema.number(value, name, error=ModelError)
    if number < 0 or (number == 0 and not allow_zero):
        bound = "zero or positive" if allow_zero else "positive"
        raise ModelError(f"{name} must be {bound}, got {number}")
    return schema.parameter(number, name, error=ModelError)


def _whole_number(name: str, value: Any, smallest: int = 1) -> int:
    """A size or count: a whole number (not a string, never rounded) of at least ``smallest``."""
    return schema.whole_number(value, name, smallest, error=ModelError)


def _numeric_array(value: Any, name: str, wanted: str) -> np.ndarray:
    """``value`` as a float array if it holds numbers only (strings and booleans refused)."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = None
    if array is None or array.dtype.kind not in "fiu":
        raise ModelError(f"{name} must be {wanted}, got {schema.shown(value)}")
    return array.astype(float)


def read_only(array: np.ndarray) -> np.ndarray:
    """``array`` read-only (a read-only copy if it is writable), as kernels take the model's arrays:
    whether an argument is writable is part of a compiled kernel's signature."""
    if array.flags.writeable:
        array = array.copy()
        array.setflags(write=False)
    return array


@dataclasses.dataclass(frozen=True, eq=False)
class Model:
    """Immutable lattice description.  Build with ``Model.create`` (validates), not the constructor.

    Attributes (SI units in the presets):
        nx, ny: particles per row and per column.
        dim: 2 (motion in the plane) or 3 (also out of the plane, z).
        spacing: lattice spacing a (m), also the distance to the wall anchors.
        masses: (ny, nx) particle masses (kg), read-only.
        stiffness: spring constant k (N/m) of every nearest-neighbour spring.
        diagonal_stiffness: k2 (N/m) of the diagonal springs (``sim.forces.diagonal``), 0: none.
        rest_length: spring rest length L (m); L < a pre-tensions the lattice with T = k (a - L).
        damping: dashpot coefficient c (N s/m) beside every spring, on the along-spring velocity.
        drag: drag coefficient (N s/m) on every particle's absolute velocity.
        gravity: (3,) acceleration vector (m/s^2); the z component only acts when dim == 3.
        linear: use the springs linearised about the rest lattice instead of the full law.
        driver: a ``sim.model.forcing.Driver`` (a sinusoidal force or displacement on one particle),
            or None.
        boundary: the name of a boundary of the registry ``sim.model.boundaries`` (``walls`` gives
            the ``Boundary`` itself): "fixed" (walls of anchors), "periodic" (each row a ring:
            its last particle joined to its first, top and bottom walls kept; a chain becomes a
            ring, a lattice a cylinder), "free" (no springs to the left and right walls: the
            rows' ends are free; top and bottom walls kept) or "absorbing" (the walls behind a
            sponge layer ``sponge_width`` particles deep on the walls ``sponge_sides``, peak
            damping rate ``sponge_strength`` * omega_0; see ``sim.model.forcing``).
    """

    nx: int
    ny: int
    dim: int
    spacing: float
    masses: np.ndarray
    stiffness: float
    rest_length: float
    damping: float
    drag: float
    gravity: tuple[float, float, float]
    linear: bool
    driver: Any = None
    sources: tuple = ()
    barriers: tuple = ()
    boundary: str = "fixed"
    sponge_width: int = boundaries.DEFAULT_LAYER_WIDTH
    sponge_strength: float = boundaries.DEFAULT_LAYER_STRENGTH
    sponge_sides: tuple[str, ...] = ()
    diagonal_stiffness: float = 0.0

    @classmethod
    def create(
        cls,
        nx: int = 1,
        ny: int = 1,
        *,
        dim: int = 2,
        spacing: float = 1.0,
        mass: float | np.ndarray = 1.0,
        stiffness: float = 1.0,
        rest_length: float | None = None,
        damping: float = 0.0,
        drag: float = 0.0,
        gravity: float | tuple[float, ...] | np.ndarray = 0.0,
        linear: bool = False,
        driver: Any = None,
        sources: Any = (),
        barriers: Any = (),
        boundary: str = "fixed",
        sponge_width: int = boundaries.DEFAULT_LAYER_WIDTH,
        sponge_strength: float | None = None,
        sponge_sides: Any = "auto",
        diagonal_stiffness: float = 0.0,
    ) -> Model:
        """Validate the parameters and build a model.

        ``mass`` is a scalar or an (ny, nx) array; ``rest_length`` defaults to ``spacing``
        (unstressed); ``gravity`` is a vector of 2 or 3 components, or a scalar g meaning
        (0, -g, 0) ("downwards").  Raises ``ModelError`` with a clear message on invalid values.
        """
        nx = _whole_number("nx", nx)
        ny = _whole_number("ny", ny)
        if dim not in (2, 3) or isinstance(dim, bool):
            raise ModelError(f"dim must be 2 (in-plane motion) or 3 (also out of plane), got {dim!r}")
        check_size(nx, ny, int(dim))
        spacing = _finite_positive("spacing", spacing)
        stiffness = _finite_positive("stiffness", stiffness)
        rest_length = spacing if rest_length is None else _finite_positive("rest_length", rest_length)
        damping = _finite_positive("damping", damping, allow_zero=True)
        drag = _finite_positive("drag", drag, allow_zero=True)
        diagonal_stiffness = _finite_positive("diagonal_stiffness", diagonal_stiffness, True)
        masses = _mass_array(mass, nx, ny)
        gravity_vector = _gravity_vector(gravity)
        linear = schema.flag(linear, "linear", error=ModelError)
        from sim.model import forcing
        from sim.model import sources as sources_module

        if sponge_strength is None:
            sponge_strength = boundaries.DEFAULT_LAYER_STRENGTH
        try:
            boundary, sponge_width, sponge_strength = forcing.check_boundary(
                boundary, sponge_width, sponge_strength
            )
            driver = None if driver is None or driver is False else forcing.Driver.create(driver)
            sources = forcing.check_sources(sources)
            barriers = sources_module.check_barriers(barriers)
            sources_module.check_in_lattice(sources, barriers, nx, ny, int(dim))
        except (forcing.ForcingError, sources_module.SourceError) as error:
            raise ModelError(str(error)) from None
        if driver is not None and driver.row == sources_module.ALL_ROWS:
            driver = dataclasses.replace(driver, row=0) if ny == 1 else driver
            if ny > 1:
                raise ModelError('the driver drives one particle; a whole column (row "all") '
                                 "is a source (scene key sources)")
        if driver is not None and not (driver.column < nx and driver.row < ny):
            raise ModelError(f"the driven particle (column {driver.column}, row {driver.row}) is "
                             f"outside the {nx}x{ny} lattice")
        if driver is not None and dim == 2 and driver.direction[2] != 0.0:
            raise ModelError("a planar (2-D) lattice cannot be driven out of the plane (z)")
        sides: tuple[str, ...] = ()
        if boundaries.get(boundary).absorbing and diagonal_stiffness > 0:
            raise ModelError("the absorbing layer has no diagonal springs yet; use fixed walls "
                             "far away (boundary fixed) or diagonal_stiffness 0")
        if boundaries.get(boundary).absorbing:
            try:
                if sponge_sides is None or (not isinstance(sponge_sides, str)
                                            and len(sponge_sides) == 0):
                    sponge_sides = "auto"  # a fixed model's empty sides, when it turns absorbing
                sides = forcing.check_sides(sponge_sides, nx, ny, sponge_width)
            except forcing.ForcingError as error:
                raise ModelError(str(error)) from None
        return cls(
            nx=nx, ny=ny, dim=int(dim), spacing=spacing, masses=masses, stiffness=stiffness,
            rest_length=rest_length, damping=damping, drag=drag, gravity=gravity_vector,
            linear=bool(linear), driver=driver, sources=sources, barriers=barriers,
            boundary=boundary, sponge_width=sponge_width, sponge_strength=sponge_strength,
            sponge_sides=sides, diagonal_stiffness=diagonal_stiffness,
        )

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Unpickled (a worker, a child compiling kernels): its arrays read-only again, as built."""
        for name, value in state.items():
            object.__setattr__(self, name, read_only(value) if isinstance(value, np.ndarray) else value)

    def replace(self, **changes: Any) -> Model:
        """A new validated model with some parameters changed (``mass=`` replaces the masses)."""
        parameters = self.parameters()
        parameters["mass"] = self.masses
        parameters.update(changes)
        return Model.create(**parameters)

    def parameters(self) -> dict[str, Any]:
        """The scalar parameters as keyword arguments of ``create`` (masses excluded)."""
        return dict(
            nx=self.nx, ny=self.ny, dim=self.dim, spacing=self.spacing, stiffness=self.stiffness,
            rest_length=self.rest_length, damping=self.damping, drag=self.drag,
            gravity=self.gravity, linear=self.linear, driver=self.driver, sources=self.sources,
            barriers=self.barriers, boundary=self.boundary, sponge_width=self.sponge_width,
            sponge_strength=self.sponge_strength, sponge_sides=self.sponge_sides,
            diagonal_stiffness=self.diagonal_stiffness,
        )

    @property
    def walls(self) -> Boundary:
        """The boundary called ``boundary``, from the registry ``sim.model.boundaries``."""
        return boundaries.get(self.boundary)

    @property
    def has_forcing(self) -> bool:
        """Whether a driver or an absorbing layer acts between the steps (``sim.model.forcing``)."""
        return self.driver is not None or bool(self.sources or self.barriers) or self.walls.absorbing

    @property
    def driven(self) -> bool:
        """Whether a driver or a source feeds energy in (its work is ``State.driven``)."""
        return self.driver is not None or bool(self.sources)

    @property
    def periodic(self) -> bool:
        """Whether each row is a ring (``boundary="periodic"``)."""
        return self.walls.periodic

    @property
    def row_ends(self) -> str:
        """How the rows end at the left and right: "walls", "ring" or "free"."""
        return self.walls.row_ends

    # --- derived quantities ---------------------------------------------------------------------

    @property
    def n_particles(self) -> int:
        return self.nx * self.ny

    @property
    def n_springs(self) -> int:
        return self.ny * (self.nx + 1) + (self.ny + 1) * self.nx

    @property
    def n_anchors(self) -> int:
        return 2 * (self.nx + self.ny)

    @property
    def tension(self) -> float:
        """Spring tension T = k (a - L) in the rest lattice (N); negative means compression."""
        return self.stiffness * (self.spacing - self.rest_length)

    @property
    def tension_stiffness(self) -> float:
        """Stiffness across a spring in the linearised model, T / a (N/m)."""
        return self.tension / self.spacing

    @cached_property
    def kernel_parameters(self):
        """The spring constants as the compiled kernels take them (``sim.forces.springs.SpringParameters``,
        float64; ``.as_type(np.float32)`` for single precision), built once per model."""
        from sim.forces.springs import SpringParameters

        origin_x, origin_y = self.origin
        return SpringParameters(
            float(self.stiffness), float(self.rest_length), float(self.tension_stiffness),
            float(self.spacing), float(origin_x), float(origin_y),
            periodic=True if self.periodic else None,
            free_ends=True if self.walls.free_ends else None,
            diagonal_stiffness=float(self.diagonal_stiffness) or None,
        )

    @property
    def is_damped(self) -> bool:
        return self.damping > 0 or self.drag > 0

    @property
    def has_gravity(self) -> bool:
        return any(component != 0.0 for component in self.gravity[: self.dim])

    @property
    def uniform_mass(self) -> bool:
        return bool(np.all(self.masses == self.masses.flat[0]))

    @property
    def origin(self) -> tuple[float, float]:
        """Rest position (x, y) of particle (0, 0), the bottom-left one (m)."""
        return (-(self.nx - 1) / 2 * self.spacing, -(self.ny - 1) / 2 * self.spacing)

    @cached_property
    def inverse_masses(self) -> np.ndarray:
        """(ny, nx) array of 1 / m (1/kg), what the kernels use."""
        inverse = 1.0 / self.masses
        inverse.setflags(write=False)
        return inverse

    @cached_property
    def rest_positions(self) -> np.ndarray:
        """(n_particles, dim) rest positions (m), read-only."""
        origin_x, origin_y = self.origin
        columns, rows = np.meshgrid(np.arange(self.nx), np.arange(self.ny))
        positions = np.zeros((self.n_particles, self.dim))
        positions[:, 0] = origin_x + columns.ravel() * self.spacing
        positions[:, 1] = origin_y + rows.ravel() * self.spacing
        positions.setflags(write=False)
        return positions

    @cached_property
    def anchor_positions(self) -> np.ndarray:
        """(n_anchors, dim) wall anchor positions (m): left, right, bottom, top."""
        origin_x, origin_y = self.origin
        a = self.spacing
        rows_y = origin_y + np.arange(self.ny) * a
        columns_x = origin_x + np.arange(self.nx) * a
        anchors = np.zeros((self.n_anchors, self.dim))
        anchors[: self.ny, 0] = origin_x - a
        anchors[: self.ny, 1] = rows_y
        anchors[self.ny : 2 * self.ny, 0] = origin_x + self.nx * a
        anchors[self.ny : 2 * self.ny, 1] = rows_y
        bottom = slice(2 * self.ny, 2 * self.ny + self.nx)
        top = slice(2 * self.ny + self.nx, 2 * self.ny + 2 * self.nx)
        anchors[bottom, 0] = columns_x
        anchors[bottom, 1] = origin_y - a
        anchors[top, 0] = columns_x
        anchors[top, 1] = origin_y + self.ny * a
        anchors.setflags(write=False)
        return anchors

    @cached_property
    def springs(self) -> np.ndarray:
        """(n_springs, 2) end indices into concatenate([particles, anchors]), in strain order."""
        nx, ny, n = self.nx, self.ny, self.n_particles
        left_anchor = n + np.arange(ny)
        right_anchor = n + ny + np.arange(ny)
        bottom_anchor = n + 2 * ny + np.arange(nx)
        top_anchor = n + 2 * ny + nx + np.arange(nx)
        grid = np.arange(n).reshape(ny, nx)
        left_end = np.concatenate([left_anchor[:, None], grid], axis=1)  # (ny, nx + 1)
        right_end = np.concatenate([grid, right_anchor[:, None]], axis=1)
        lower_end = np.concatenate([bottom_anchor[None, :], grid], axis=0)  # (ny + 1, nx)
        upper_end = np.concatenate([grid, top_anchor[None, :]], axis=0)
        springs = np.concatenate(
            [
                np.stack([left_end.ravel(), right_end.ravel()], axis=1),
                np.stack([lower_end.ravel(), upper_end.ravel()], axis=1),
            ]
        )
        springs.setflags(write=False)
        return springs

    def describe(self) -> str:
        """One line a person can read."""
        extras = []
        if self.damping:
            extras.append(f"dashpots c={self.damping:g}")
        if self.drag:
            extras.append(f"drag {self.drag:g}")
        if self.has_gravity:
            extras.append("gravity (" + ", ".join(f"{g:g}" for g in self.gravity[: self.dim]) + ")")
        if self.diagonal_stiffness:
            extras.append(f"diagonal springs k2={self.diagonal_stiffness:g}")
        if self.linear:
            extras.append("linearised springs")
        if self.periodic:
            extras.append("rows joined into rings (periodic in x)")
        if self.walls.free_ends:
            extras.append("free left and right ends")
        if self.walls.absorbing:
            extras.append(f"absorbing walls: {'/'.join(self.sponge_sides)} "
                          f"({self.sponge_width}-particle sponge)")
        if self.driver is not None:
            extras.append(self.driver.describe())
        extras.extend(source.describe().replace("driven", "source", 1) for source in self.sources)
        extras.extend(barrier.describe() for barrier in self.barriers)
        masses = (
            f"m={self.masses.flat[0]:g}"
            if self.uniform_mass
            else f"m in [{self.masses.min():g}, {self.masses.max():g}]"
        )
        text = (
            f"{self.nx}x{self.ny} lattice in {self.dim}-D, a={self.spacing:g}, {masses}, "
            f"k={self.stiffness:g}, L={self.rest_length:g}"
        )
        return text + ("; " + ", ".join(extras) if extras else "")


def _mass_array(mass: float | np.ndarray, nx: int, ny: int) -> np.ndarray:
    array = _numeric_array(mass, "mass", "a number or an (ny, nx) array of numbers")
    if array.ndim == 0:
        array = np.full((ny, nx), float(array))
    elif array.shape == (ny * nx,):
        array = array.reshape(ny, nx).copy()
    elif array.shape != (ny, nx):
        raise ModelError(f"mass array must have shape (ny, nx) = ({ny}, {nx}), got {array.shape}")
    else:
        array = array.copy()
    if not np.all(np.isfinite(array)):
        raise ModelError("every mass must be finite (found NaN or infinity)")
    if np.any(array <= 0):
        raise ModelError(f"every mass must be positive, found {float(array.min()):g}")
    low, high = schema.BOUNDS["mass"]
    if array.min() < low or array.max() > high:
        raise ModelError(f"every mass must be in [{low:g}, {high:g}] kg, found "
                         f"{array.min():g} to {array.max():g}")
    array.setflags(write=False)
    return array


def _gravity_vector(gravity: float | tuple[float, ...] | np.ndarray) -> tuple[float, float, float]:
    array = _numeric_array(gravity, "gravity", "a number (downwards) or a 2- or 3-vector")
    if array.ndim == 0:
        vector = (0.0, -float(array), 0.0)
    elif array.shape in ((2,), (3,)):
        vector = tuple(float(component) for component in array) + (0.0,) * (3 - array.shape[0])
    else:
        raise ModelError(f"gravity must be a number (downwards) or a 2- or 3-vector, got {gravity!r}")
    if not all(math.isfinite(component) for component in vector):
        raise ModelError(f"gravity must be finite, got {vector}")
    for component in vector:
        schema.parameter(component, "gravity", error=ModelError)
    return vector  # type: ignore[return-value]
