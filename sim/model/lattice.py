"""The immutable description of a lattice: sizes, masses, springs, force terms, walls, flags.

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

Size limits (``sim.model.limits``): ``nx`` and ``ny`` are at most ``MAX_SIDE`` and the lattice
has at most ``MAX_PARTICLES`` particles; ``Model.create`` also refuses a lattice whose simulation
would not fit in the memory available now (``estimated_bytes``, checked before any array is
allocated).  The force terms' parameters (dashpots, drag, gravity, diagonal springs, ...) are
declared by the terms (``sim.forces.registry``) and stored in ``Model.term_values``.
"""

from __future__ import annotations

import dataclasses
from functools import cached_property
from typing import Any

import numpy as np

from sim.forces import registry
from sim.model import boundaries, schema
from sim.model.boundaries import Boundary
from sim.model.limits import (  # re-exported: the lattice's size limits
    MAX_PARTICLES,
    MAX_SIDE,
    ModelError,
    available_memory,
    check_size,
    estimated_bytes,
)

__all__ = ["MAX_PARTICLES", "MAX_SIDE", "Model", "ModelError", "available_memory", "check_size",
           "estimated_bytes", "read_only"]


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
        rest_length: spring rest length L (m); L < a pre-tensions the lattice with T = k (a - L).
        term_values: the parameters of the force terms (``sim.forces.registry``), each answered
            as an attribute: ``damping`` c (N s/m) of the dashpots, ``drag`` (N s/m),
            ``gravity`` (3,) m/s^2 (z acts only when dim == 3), ``diagonal_stiffness`` k2 (N/m);
            a term's default (the term absent) when not given.
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
    linear: bool
    driver: Any = None
    sources: tuple = ()
    barriers: tuple = ()
    boundary: str = "fixed"
    sponge_width: int = boundaries.DEFAULT_LAYER_WIDTH
    sponge_strength: float = boundaries.DEFAULT_LAYER_STRENGTH
    sponge_sides: tuple[str, ...] = ()
    term_values: dict = dataclasses.field(default_factory=dict)

    def __getattr__(self, name: str) -> Any:
        """A force term's parameter (``term_values``, else the term's default)."""
        if name.startswith("_") or name == "term_values":
            raise AttributeError(name)
        values = self.__dict__.get("term_values", {})
        if name in values:
            return values[name]
        default = _TERM_DEFAULTS.get(name, _MISSING)
        if default is _MISSING:
            raise AttributeError(f"a Model has no attribute {name!r}")
        return default

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
        linear: bool = False,
        driver: Any = None,
        sources: Any = (),
        barriers: Any = (),
        boundary: str = "fixed",
        sponge_width: int = boundaries.DEFAULT_LAYER_WIDTH,
        sponge_strength: float | None = None,
        sponge_sides: Any = "auto",
        **term_values: Any,
    ) -> Model:
        """Validate the parameters and build a model.

        ``mass`` is a scalar or an (ny, nx) array; ``rest_length`` defaults to ``spacing``
        (unstressed); ``term_values``: the force terms' parameters (``sim.forces.registry``:
        ``damping``, ``drag``, ``gravity`` (a vector of 2 or 3 components, or a scalar g
        meaning (0, -g, 0), "downwards"), ``diagonal_stiffness``, ...).  Raises ``ModelError``
        with a clear message on invalid values.
        """
        nx = _whole_number("nx", nx)
        ny = _whole_number("ny", ny)
        if dim not in (2, 3) or isinstance(dim, bool):
            raise ModelError(f"dim must be 2 (in-plane motion) or 3 (also out of plane), got {dim!r}")
        check_size(nx, ny, int(dim))
        spacing = _finite_positive("spacing", spacing)
        stiffness = _finite_positive("stiffness", stiffness)
        rest_length = spacing if rest_length is None else _finite_positive("rest_length", rest_length)
        term_values = _term_values(term_values)
        masses = _mass_array(mass, nx, ny)
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
        if boundaries.get(boundary).absorbing:
            try:
                if sponge_sides is None or (not isinstance(sponge_sides, str)
                                            and len(sponge_sides) == 0):
                    sponge_sides = "auto"  # a fixed model's empty sides, when it turns absorbing
                sides = forcing.check_sides(sponge_sides, nx, ny, sponge_width)
            except forcing.ForcingError as error:
                raise ModelError(str(error)) from None
        model = cls(
            nx=nx, ny=ny, dim=int(dim), spacing=spacing, masses=masses, stiffness=stiffness,
            rest_length=rest_length, linear=bool(linear), driver=driver, sources=sources,
            barriers=barriers, boundary=boundary, sponge_width=sponge_width,
            sponge_strength=sponge_strength, sponge_sides=sides, term_values=term_values,
        )
        conflicts = registry.conflicts(model)
        if conflicts:
            raise ModelError("; ".join(conflicts))
        return model

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
            rest_length=self.rest_length, linear=self.linear, driver=self.driver,
            sources=self.sources, barriers=self.barriers, boundary=self.boundary,
            sponge_width=self.sponge_width, sponge_strength=self.sponge_strength,
            sponge_sides=self.sponge_sides,
            **{name: getattr(self, name) for name in _TERM_DEFAULTS},
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
        """Spring tension T in the rest lattice (N), k (a - L) and what the law's other terms add
        at that extension (``sim.forces.registry.linear_stiffness``); negative means
        compression."""
        return registry.linear_stiffness(self).tension

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
            **registry.kernel_values("springs", self),
        )

    @property
    def is_damped(self) -> bool:
        """Whether a term depends on the velocities (dashpots, drag: ``sim.forces.registry``)."""
        return registry.velocity_dependent(self)

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
        extras = [term.describe(self) for term in registry.present(self) if term.describe]
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


_MISSING = object()
_TERM_DEFAULTS: dict[str, Any] = {
    row.name: row.default for row in registry.parameters()
    if row.name not in {field.name for field in dataclasses.fields(Model)}
}
"""The force terms' parameters a model stores in ``term_values`` (those that are not fields of
its own, as k and L are), with their defaults."""


def _term_values(given: dict[str, Any]) -> dict[str, Any]:
    """The force terms' parameters checked (``ForceTerm.check``, then the rows' bounds); those
    equal to their default are left out.  An unknown name is refused, naming the known ones."""
    values = {}
    for name, value in given.items():
        term = registry.owner(name)
        if term is None or name not in _TERM_DEFAULTS:
            raise ModelError(f"unknown lattice parameter {name!r}; the force terms' are "
                             f"{', '.join(_TERM_DEFAULTS)}")
        if term.check is not None:
            try:
                value = term.check(name, value)
            except ValueError as error:
                raise ModelError(str(error)) from None
        if isinstance(value, tuple):
            value = tuple(schema.parameter(c, name, error=ModelError) for c in value)
        else:
            value = (_finite_positive(name, value, allow_zero=True) if schema.BOUNDS[name][0] >= 0
                     else schema.parameter(value, name, error=ModelError))
        if value != _TERM_DEFAULTS[name]:
            values[name] = value
    return values
