"""A sinusoidal driver and an absorbing boundary layer (sponge): what a scene may add to the
lattice besides its springs, and how they act between the integrator's steps.

Both act by operator splitting, so the compiled step loops stay exactly as they are for scenes
without them (``Simulation`` only takes this path when the model has a driver or a sponge):

    half sponge, half driver  ->  one step of the integrator  ->  half driver, half sponge

* **Sponge** (``boundary="absorbing"``): a layer ``sponge_width`` particles deep along the walls,
  a perfectly matched layer of the lattice (``sim.forces.absorbing_layer``): graded damping of the
  springs' stretch and of the forces along each wall's normal, with rate
  ``sponge_strength`` * omega_0 * d^2 at depth d (0 at the inner edge, 1 at the wall),
  omega_0 = sqrt(k / m_mean).  It acts between the integrator's steps over the border rows and
  columns only, with exact exponentials, so it never limits the stable step; a wave of any
  wavelength enters it without reflecting (``docs/instruments.md`` measures the reflection
  against wavelength at normal and oblique incidence).
* **Driver**: one particle (column i, row j) driven along ``direction``, either by a force
  A k sin(2 pi f t) (``kind="force"``, A in m so that the force is that of a spring stretched by
  A) applied as two half kicks of impulse F dt / 2 around each step (Strang splitting,
  second order in dt), or by a prescribed displacement A sin(2 pi f t) from its rest position
  (``kind="displacement"``, the paper's mouse, automated): its position and velocity are set to
  the prescribed ones at the start of every step.  Both start at ``start`` (s) and ramp up over
  ``ramp`` (s) with a smooth envelope (1 - cos) / 2, so the drive does not kick the lattice.

Energy accounting: the energy the sponge takes out adds to ``State.dissipated`` and the work the
driver does adds to ``State.driven``, both measured exactly as the change of kinetic (and, for the
prescribed displacement, the particle's spring) energy each action makes, so
kinetic + potential + dissipated - driven stays constant to the integrator's accuracy.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sim.forces import absorbing_layer as matched_layer
from sim.forces import driver as forcing_kernels
from sim.model import boundaries, schema, sources

DRIVER_KINDS = ("force", "displacement")
SPONGE_POWER = matched_layer.POWER

_DIRECTIONS = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


class ForcingError(ValueError):
    """An invalid driver or boundary parameter (the message says which and why)."""


def _number(name: str, value: Any, *, positive: bool = False, allow_zero: bool = True) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ForcingError(f"driver {name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ForcingError(f"driver {name} must be finite, got {value!r}")
    if positive and (number < 0 or (number == 0 and not allow_zero)):
        raise ForcingError(f"driver {name} must be {'positive' if not allow_zero else '>= 0'}, "
                           f"got {number:g}")
    return number


@dataclasses.dataclass(frozen=True)
class Driver:
    """A sinusoidal drive on particle (``column``, ``row``).

    ``direction``: unit 3-vector (given as x, y, z or a 2-/3-vector, normalised);
    ``amplitude`` A (m); ``frequency`` f (Hz); ``kind`` "force" (F = A k sin(2 pi f t + phase),
    N) or "displacement" (u = A sin(2 pi f t + phase), m); ``start`` (s) and ``ramp`` (s) of the
    envelope; ``phase`` (rad).  ``row`` may be "all" (a source driving its whole column,
    ``sim.model.sources``).
    """

    column: int = 0
    row: int | str = 0
    direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    amplitude: float = 0.05
    frequency: float = 1.0
    kind: str = "force"
    start: float = 0.0
    ramp: float = 2.0
    phase: float = 0.0

    FIELDS = ("column", "row", "direction", "amplitude", "frequency", "kind", "start", "ramp",
              "phase")

    @classmethod
    def create(cls, value: Any) -> Driver:
        """A validated driver from a ``Driver``, a mapping of its fields, or a text
        "key=value,key=value" (``direction`` as x, y, z or "dx dy dz")."""
        if isinstance(value, Driver):
            fields = dataclasses.asdict(value)
        elif isinstance(value, str):
            fields = parse_driver_text(value)
        elif isinstance(value, dict):
            fields = dict(value)
        else:
            raise ForcingError(
                f"driver must be a Driver, a table of its fields or 'key=value,...', got {value!r}"
            )
        unknown = set(fields) - set(cls.FIELDS)
        if unknown:
            raise ForcingError(f"unknown driver field(s) {', '.join(sorted(unknown))}; "
                               f"accepted: {', '.join(cls.FIELDS)}")
        merged = {**dataclasses.asdict(cls()), **fields}
        for name in ("column", "row"):
            raw = merged[name]
            if name == "row" and isinstance(raw, str) and raw.strip().lower() == "all":
                merged[name] = "all"
                continue
            number = _number(name, raw)
            if isinstance(raw, bool) or not number.is_integer() or number < 0:
                raise ForcingError(f"driver {name} must be a whole number >= 0, got {raw!r}")
            merged[name] = int(number)
        kind = str(merged["kind"]).strip().lower()
        if kind not in DRIVER_KINDS:
            raise ForcingError(f"driver kind must be one of {', '.join(DRIVER_KINDS)}, got {kind!r}")
        return cls(
            column=int(merged["column"]), row=merged["row"],
            direction=_unit_vector(merged["direction"]),
            amplitude=schema.number(_number("amplitude", merged["amplitude"], positive=True),
                                    "driver amplitude (m)", *schema.BOUNDS["amplitude"],
                                    error=ForcingError),
            frequency=_number("frequency", merged["frequency"], positive=True, allow_zero=False),
            kind=kind,
            start=_number("start", merged["start"], positive=True),
            ramp=_number("ramp", merged["ramp"], positive=True),
            phase=_number("phase", merged["phase"]),
        )

    @property
    def angular_frequency(self) -> float:
        """omega = 2 pi f (rad/s)."""
        return 2.0 * math.pi * self.frequency

    def envelope(self, time: float) -> tuple[float, float]:
        """(s, ds/dt) of the start-up envelope at ``time`` (0 before ``start``, 1 after the ramp)."""
        elapsed = time - self.start
        if elapsed < 0.0:
            return 0.0, 0.0
        if self.ramp <= 0.0 or elapsed >= self.ramp:
            return 1.0, 0.0
        phase = math.pi * elapsed / self.ramp
        return 0.5 * (1.0 - math.cos(phase)), 0.5 * math.pi / self.ramp * math.sin(phase)

    def signal(self, time: float) -> tuple[float, float]:
        """(value, rate) of the drive at ``time``: s(t) sin(omega (t - start) + phase) and its rate
        (times A for a displacement in m, times A k for a force in N)."""
        envelope, envelope_rate = self.envelope(time)
        if envelope == 0.0:
            return 0.0, 0.0
        omega = self.angular_frequency
        phase = omega * (time - self.start) + self.phase
        return (envelope * math.sin(phase),
                envelope_rate * math.sin(phase) + envelope * omega * math.cos(phase))

    def as_table(self) -> dict[str, Any]:
        """The fields as plain values (for scene files and JSON)."""
        table = dataclasses.asdict(self)
        table["direction"] = list(self.direction)
        return table

    def describe(self) -> str:
        what = "force A k" if self.kind == "force" else "displacement"
        axis = next((name for name, vector in _DIRECTIONS.items() if vector == self.direction),
                    "(" + ", ".join(f"{c:.3g}" for c in self.direction) + ")")
        where = (f"column {self.column}" if self.row == "all"
                 else f"particle ({self.column}, {self.row})")
        phase = f", phase {self.phase:g} rad" if self.phase else ""
        return (f"driven ({what}) at {where} along {axis}, "
                f"A={self.amplitude:g} m, f={self.frequency:g} Hz{phase}")


PIN = Driver(kind="displacement", amplitude=0.0, ramp=0.0)
"""The drive of a barrier's pinned particle: held at rest."""


def check_sources(value: Any) -> tuple[Driver, ...]:
    """Validated sources (``sim.model.sources``) from a list of drivers, tables or "key=value,..."
    texts (one text may hold several sources separated by ";")."""
    if value is None or value is False:
        return ()
    if isinstance(value, str):
        value = [part for part in value.split(";") if part.strip()]
    elif isinstance(value, (dict, Driver)):
        value = [value]
    try:
        return tuple(Driver.create(item) for item in value)
    except TypeError:
        raise ForcingError(f"sources must be a list of source tables, got {value!r}") from None


def parse_driver_text(text: str) -> dict[str, Any]:
    """Fields from "column=3,row=0,frequency=1.2,kind=force,direction=y" (direction also as
    "0 1 0")."""
    fields: dict[str, Any] = {}
    for key, raw in schema.key_values(text, "driver", error=ForcingError):
        if key == "direction" and raw.lower() not in _DIRECTIONS:
            try:
                fields[key] = [float(value) for value in raw.split()]
            except ValueError:
                raise ForcingError(f"driver direction must be x, y, z or 'dx dy dz', "
                                   f"got {raw!r}") from None
        else:
            fields[key] = raw  # numbers are checked by Driver.create
    return fields


def _unit_vector(value: Any) -> tuple[float, float, float]:
    if isinstance(value, str):
        key = value.strip().lower()
        if key not in _DIRECTIONS:
            raise ForcingError(f"driver direction must be x, y, z or a vector, got {value!r}")
        return _DIRECTIONS[key]
    try:
        vector = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ForcingError(f"driver direction must be x, y, z or a vector, got {value!r}") from None
    if vector.size not in (2, 3) or not np.all(np.isfinite(vector)):
        raise ForcingError(f"driver direction must be a 2- or 3-vector, got {value!r}")
    vector = np.concatenate([vector, np.zeros(3 - vector.size)])
    length = float(np.linalg.norm(vector))
    if length == 0.0:
        raise ForcingError("driver direction must not be the zero vector")
    return tuple(float(c) for c in vector / length)  # type: ignore[return-value]


SIDES = ("left", "right", "bottom", "top")


def check_boundary(boundary: Any, sponge_width: Any, sponge_strength: Any
                   ) -> tuple[str, int, float]:
    """Validated (boundary, sponge_width, sponge_strength); raises ``ForcingError``.  The
    boundary is a name of the registry ``sim.model.boundaries``."""
    name = str(boundary).strip().lower()
    if name not in boundaries.names():
        raise ForcingError(f"boundary must be one of {', '.join(boundaries.names())}, "
                           f"got {boundary!r}")
    try:
        width = float(sponge_width)
        strength = float(sponge_strength)
    except (TypeError, ValueError):
        raise ForcingError(
            f"sponge_width and sponge_strength must be numbers, got {sponge_width!r}, "
            f"{sponge_strength!r}"
        ) from None
    if not width.is_integer() or width < 1:
        raise ForcingError(
            f"sponge_width must be a whole number of particles >= 1, got {sponge_width!r}"
        )
    if not (math.isfinite(strength) and strength > 0):
        raise ForcingError(f"sponge_strength must be a positive number, got {sponge_strength!r}")
    return name, int(width), strength


def check_sides(sides: Any, nx: int, ny: int, width: int) -> tuple[str, ...]:
    """The walls that get a layer: "auto" (every wall across which the lattice is more than
    3 layers long, so a chain absorbs at its two ends only), or a list of left/right/bottom/top
    (as a sequence or a text separated by commas or spaces).  Raises ``ForcingError`` when a
    named wall's direction is too short for the layer."""
    if isinstance(sides, str) and sides.strip().lower() in ("auto", ""):
        chosen = tuple(
            side for side in SIDES
            if (nx > 3 * width if side in ("left", "right") else ny > 3 * width)
        )
        if not chosen:
            raise ForcingError(
                f"an absorbing layer {width} particles deep needs more than {3 * width} "
                f"particles along x or y; this lattice is {nx}x{ny} (lower sponge_width)"
            )
        return chosen
    names = sides.replace(",", " ").split() if isinstance(sides, str) else list(sides)
    chosen = []
    for side in names:
        key = str(side).strip().lower()
        if key not in SIDES:
            raise ForcingError(f"sponge side must be one of {', '.join(SIDES)}, got {side!r}")
        count = nx if key in ("left", "right") else ny
        if count < 2 * width:
            raise ForcingError(
                f"a {width}-particle layer on the {key} wall needs at least {2 * width} "
                f"particles in that direction; this lattice has {count} (lower sponge_width)"
            )
        if key not in chosen:
            chosen.append(key)
    if not chosen:
        raise ForcingError("sponge_sides names no wall")
    return tuple(side for side in SIDES if side in chosen)


def sponge_depth(nx: int, ny: int, width: int, sides: tuple[str, ...]) -> np.ndarray:
    """(ny, nx) depth of each particle in the layer: 0 inside the lattice and at the layer's
    inner edge, 1 next to the wall (the largest depth over the walls that have a layer)."""

    def ramp(distance_to_wall: np.ndarray) -> np.ndarray:
        return np.clip((width - distance_to_wall) / width, 0.0, 1.0)

    columns = np.arange(nx)[None, :]
    rows = np.arange(ny)[:, None]
    depth = np.zeros((ny, nx))
    distances = {"left": columns, "right": nx - 1 - columns, "bottom": rows, "top": ny - 1 - rows}
    for side in sides:
        depth = np.maximum(depth, ramp(distances[side] + 0.0))
    return depth


def sponge_rates(model: Any) -> np.ndarray:
    """(ny, nx) rate of the layer at every particle (1/s): strength * omega_0 * depth^SPONGE_POWER,
    omega_0 = sqrt(k / mean mass)."""
    omega_0 = math.sqrt(model.stiffness / float(np.mean(model.masses)))
    depth = sponge_depth(model.nx, model.ny, model.sponge_width, model.sponge_sides)
    return model.sponge_strength * omega_0 * depth**SPONGE_POWER


class Forcing:
    """The driver and sponge of one model, applied to a state around each integrator step.

    ``sponge(state, span)``, ``drive_before(state, dt)`` and ``drive_after(state, dt)`` are the
    actions; ``Simulation`` composes them as half sponge, then per step (half drive, step, half
    drive, full sponge), with a half sponge instead of the last full one: the symmetric
    (Strang) splitting with the two half sponges between steps merged.  ``moves_particles``
    says whether the driver sets positions (the integrator's cached forces are then stale).
    """

    def __init__(self, model: Any) -> None:
        self.model = model
        self.driver: Driver | None = model.driver
        # (driver, row j, column i) per driven or pinned particle
        self.entries = sources.entries(model, PIN)
        self._masses = np.ascontiguousarray(model.masses, dtype=np.float64)
        sides = model.sponge_sides if model.walls.absorbing else ()
        widths = tuple(model.sponge_width if side in sides else 0 for side in SIDES)
        self._matched = (matched_layer.MatchedLayer(model, widths, model.sponge_strength)  # type: ignore[arg-type]
                         if model.walls.absorbing else None)
        if self.entries:
            self._spring_arguments = (bool(model.linear), model.kernel_parameters)

    @property
    def has_sponge(self) -> bool:
        return self._matched is not None

    @property
    def drives(self) -> bool:
        """Whether any particle is driven or pinned (a driver, sources or barriers)."""
        return bool(self.entries)

    def drive_table(self) -> np.ndarray | None:
        """The drivers, sources and pinned particles as the drive table the compiled steps read
        (``sim.forces.drive_table``, one row per particle), or None without any."""
        if not self.entries:
            return None
        if getattr(self, "_table", None) is None:
            self._table = sources.drive_table(self.model, self.entries)
        return self._table

    def sponge_arrays(self, dt: float, dtype: type) -> Any:
        """The absorbing layer as the compiled steps take it (a ``MatchedLayer``); None without
        one."""
        return self._matched

    def place(self, state: Any) -> None:
        """Put a prescribed particle where its prescription says at the state's time (the work
        this takes is added to ``State.driven``)."""
        if self.moves_particles:
            self._place(state, state.time)

    @property
    def moves_particles(self) -> bool:
        return any(driver.kind == "displacement" for driver, _, _ in self.entries)

    def sponge(self, state: Any, span: float) -> None:
        """The absorbing layer's action over ``span`` seconds (``sim.forces.absorbing_layer``)."""
        if self._matched is not None:
            self._matched.act(state, span)

    def _kick(self, state: Any, time: float, dt: float) -> None:
        for driver, j, i in self.entries:
            if driver.kind != "force":
                continue
            value, _ = driver.signal(time)
            if value == 0.0:
                continue
            mass = float(self._masses[j, i])
            impulse = 0.5 * dt * driver.amplitude * self.model.stiffness * value / mass
            dvx, dvy, dvz = (impulse * c for c in driver.direction)
            state.driven += forcing_kernels.kick_particle(
                state.velocities, j, i, dvx, dvy, dvz if self.model.dim == 3 else 0.0, mass,
            )

    def _place(self, state: Any, time: float) -> None:
        rest_positions = self.model.rest_positions
        for driver, j, i in self.entries:
            if driver.kind != "displacement":
                continue
            value, rate = driver.signal(time)
            rest = tuple(float(c) for c in rest_positions[j * self.model.nx + i])
            rest = rest + (0.0,) * (3 - len(rest))  # (x, y, z) m
            position = (r + driver.amplitude * value * d
                        for r, d in zip(rest, driver.direction, strict=True))
            velocity = (driver.amplitude * rate * d for d in driver.direction)
            before = self._local_energy(state, j, i)
            forcing_kernels.place_particle(state.positions, state.velocities, j, i, *position,
                                           *velocity)
            state.driven += self._local_energy(state, j, i) - before

    def _local_energy(self, state: Any, j: int, i: int) -> float:
        """Kinetic, spring and gravity energy that involve particle (j, i) (J)."""
        mass = float(self._masses[j, i])
        energy = forcing_kernels.local_energy(state.positions, state.velocities, j, i, mass,
                                              *self._spring_arguments)
        for c in range(self.model.dim):
            energy -= mass * self.model.gravity[c] * float(state.positions[c, j, i])
        return energy

    def drive_before(self, state: Any, dt: float) -> None:
        """The driver's first half: a half kick at the step's start time, or the prescribed
        position and velocity at that time."""
        if self.entries:
            self._kick(state, state.time, dt)
            self._place(state, state.time)

    def drive_after(self, state: Any, dt: float) -> None:
        """The driver's second half: a half kick at the step's end time (force drivers)."""
        if self.entries:
            self._kick(state, state.time, dt)
