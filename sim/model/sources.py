"""Sources and barriers of a scene: what fills the drive table the compiled steps read
(``sim.forces.drive_table``), one row per driven or pinned particle.

* **Sources** (scene key ``sources``): a list of drivers (``sim.model.forcing.Driver``), each with its
  column, row (or ``"all"``: every particle of the column is driven alike, which launches a plane
  wave), direction, amplitude, frequency, kind, start, ramp and phase (rad).  The scene's single
  ``driver`` is one more source.
* **Barriers** (scene key ``barriers``): a column (``{"column": 40, "openings": [[30, 34]]}``) or
  a row (``{"row": 12, ...}``) of pinned particles, except the particle ranges of its openings
  (inclusive, in particle indices along the barrier).  A pinned particle is a prescribed
  displacement of amplitude zero: it sits at its rest position with zero velocity at every
  step, so it does no work (the energy account stays closed) and, being fixed, it only lowers
  the lattice's highest frequency (the stability limit of the free lattice stays safe).

``entries(model)`` lists every driven particle as (driver, row j, column i); ``drive_table``
turns them into the table (``DRIVE_FIELDS`` float64 columns).
"""

from __future__ import annotations

import dataclasses
import re
from typing import Any

import numpy as np

from sim.forces import drive_table as instruments
from sim.model import schema
from sim.model.schema import shown

ALL_ROWS = "all"


class SourceError(ValueError):
    """An invalid source or barrier (the message says which and why)."""


@dataclasses.dataclass(frozen=True)
class Barrier:
    """Pinned particles along column ``index`` (``axis="column"``) or row ``index``
    (``axis="row"``), except the inclusive particle ranges ``openings`` along it."""

    axis: str
    index: int
    openings: tuple[tuple[int, int], ...] = ()

    @classmethod
    def create(cls, value: Any) -> Barrier:
        """A validated barrier from a ``Barrier`` or a table ``{"column": i, "openings":
        [[first, last], ...]}`` (or ``"row": j``)."""
        if isinstance(value, Barrier):
            return value
        if not isinstance(value, dict):
            raise SourceError(f"a barrier is a table {{column = i, openings = [[first, last]]}}, "
                              f"got {shown(value)}")
        unknown = set(value) - {"column", "row", "openings"}
        if unknown:
            raise SourceError(f"unknown barrier field(s) {', '.join(sorted(unknown))}; "
                              f"accepted: column or row, openings")
        axes = [axis for axis in ("column", "row") if axis in value]
        if len(axes) != 1:
            raise SourceError("a barrier names exactly one of column or row")
        axis = axes[0]
        index = _whole(f"barrier {axis}", value[axis])
        openings = []
        listed = value.get("openings", ()) or ()
        if isinstance(listed, (str, bytes, dict)):
            raise SourceError(f"barrier openings are a list of [first, last], got {shown(listed)}")
        for opening in listed:
            try:
                first, last = opening
            except (TypeError, ValueError):
                raise SourceError(f"a barrier opening is [first, last], got {shown(opening)}"
                                  ) from None
            first, last = _whole("opening start", first), _whole("opening end", last)
            if last < first:
                raise SourceError(f"a barrier opening ends before it starts: {opening!r}")
            openings.append((first, last))
        return cls(axis=axis, index=index, openings=tuple(sorted(openings)))

    def pinned(self, nx: int, ny: int) -> list[tuple[int, int]]:
        """(row j, column i) of the pinned particles; raises ``SourceError`` outside the lattice."""
        length, across = (ny, nx) if self.axis == "column" else (nx, ny)
        if self.index >= across:
            raise SourceError(f"barrier {self.axis} {self.index} is outside the {nx}x{ny} lattice")
        for first, last in self.openings:
            if last >= length:
                raise SourceError(f"barrier opening [{first}, {last}] runs past the lattice's "
                                  f"{length} particles along the barrier")
        open_ = np.zeros(length, dtype=bool)
        for first, last in self.openings:
            open_[first:last + 1] = True
        along = [k for k in range(length) if not open_[k]]
        if self.axis == "column":
            return [(k, self.index) for k in along]
        return [(self.index, k) for k in along]

    def as_table(self) -> dict[str, Any]:
        """The fields as plain values (for scene files and JSON)."""
        return {self.axis: self.index, "openings": [list(opening) for opening in self.openings]}

    def describe(self) -> str:
        slits = ", ".join(f"{a}-{b}" for a, b in self.openings) or "none"
        return f"barrier along {self.axis} {self.index} (openings {slits})"


def slit_openings(slits: int, width: int, separation: int, centre: int
                  ) -> tuple[tuple[int, int], ...]:
    """Openings (inclusive particle ranges along a barrier) of ``slits`` (1 or 2) slits of
    ``width`` open particles each, centred on particle ``centre`` (one slit) or with centres
    ``separation`` particles apart either side of it (two slits); raises ``SourceError`` when
    they overlap or run below particle 0."""
    if slits not in (1, 2):
        raise SourceError(f"a barrier here has one or two slits, got {slits!r}")
    if width < 1:
        raise SourceError(f"a slit is at least one particle wide, got {width}")
    if slits == 2 and separation <= width:
        raise SourceError(f"two slits {width} particles wide need a separation above {width} "
                          f"(a pinned particle between them), got {separation}")
    centres = [centre] if slits == 1 else [centre - separation // 2,
                                           centre - separation // 2 + separation]
    openings = tuple((k - (width - 1) // 2, k - (width - 1) // 2 + width - 1) for k in centres)
    if openings[0][0] < 0:
        raise SourceError(f"the slits run past the barrier's first particle (opening "
                          f"{list(openings[0])})")
    return openings


def _whole(name: str, value: Any) -> int:
    """A whole number >= 0 (``sim.model.schema.whole_number``: no strings, no rounding)."""
    return schema.whole_number(value, name, 0, error=SourceError)


def parse_barrier_text(text: str) -> dict[str, Any]:
    """A barrier table from the command line's text "column=45,openings=89-91 109-111" (or
    row=j; openings as first-last ranges separated by spaces; none for a closed barrier)."""
    fields: dict[str, Any] = {}
    for key, raw in schema.key_values(text, "barrier", error=SourceError):
        if key == "openings":
            fields[key] = [] if raw.lower() in ("", "none") else [
                _span(span) for span in raw.split()]
        elif key in ("column", "row"):
            fields[key] = _whole_text(f"barrier {key}", raw)
        else:
            raise SourceError(f"unknown barrier field {shown(key)}; accepted: column or row, "
                              "openings")
    return fields


def _span(text: str) -> list[int]:
    """[first, last] from "first-last" (or "k": one particle)."""
    ends = text.split("-")
    if len(ends) not in (1, 2):
        raise SourceError(f"a barrier opening is first-last, got {shown(text)}")
    return [_whole_text("opening start", ends[0]), _whole_text("opening end", ends[-1])]


def _whole_text(name: str, raw: str) -> int:
    if not re.fullmatch(r"[0-9]{1,9}", raw.strip()):
        raise SourceError(f"{name} must be a whole number >= 0, got {shown(raw)}")
    return int(raw)


def check_barriers(value: Any) -> tuple[Barrier, ...]:
    """A tuple of validated barriers from a list of barrier tables."""
    if value is None or value is False:
        return ()
    if isinstance(value, (dict, Barrier)):
        value = [value]
    if isinstance(value, str):
        value = [parse_barrier_text(part) for part in value.split(";") if part.strip()]
    try:
        return tuple(Barrier.create(item) for item in value)
    except TypeError:
        raise SourceError(f"barriers must be a list of barrier tables, got {shown(value)}"
                          ) from None


def check_in_lattice(drivers: tuple, barriers: tuple[Barrier, ...], nx: int, ny: int,
                     dim: int) -> None:
    """Raise ``SourceError`` if a source or barrier lies outside the lattice, a planar lattice is
    driven out of its plane, or a source sits on a pinned particle."""
    pinned = {cell for barrier in barriers for cell in barrier.pinned(nx, ny)}
    for driver in drivers:
        rows = range(ny) if driver.row == ALL_ROWS else [driver.row]
        if driver.column >= nx or (driver.row != ALL_ROWS and driver.row >= ny):
            raise SourceError(f"the source at (column {driver.column}, row {driver.row}) is "
                              f"outside the {nx}x{ny} lattice")
        if dim == 2 and driver.direction[2] != 0.0:
            raise SourceError("a planar (2-D) lattice cannot be driven out of the plane (z)")
        if any((j, driver.column) in pinned for j in rows):
            raise SourceError(f"the source at column {driver.column} lies on a barrier's pinned "
                              "particle")


def entries(model: Any, pin: Any) -> list[tuple[Any, int, int]]:
    """(driver, row j, column i) of every driven and pinned particle of ``model``: its
    ``driver``, its ``sources`` (a whole column for row "all") and its barriers' pinned
    particles, driven by ``pin`` (a displacement driver of amplitude zero)."""
    found = []
    drivers = ((model.driver,) if model.driver is not None else ()) + tuple(model.sources)
    for driver in drivers:
        rows = range(model.ny) if driver.row == ALL_ROWS else [driver.row]
        found.extend((driver, j, driver.column) for j in rows)
    for barrier in model.barriers:
        found.extend((pin, j, i) for j, i in barrier.pinned(model.nx, model.ny))
    return found


def drive_table(model: Any, found: list[tuple[Any, int, int]]) -> np.ndarray:
    """(len(found), ``DRIVE_FIELDS``) table of ``found`` (``entries``) as ``sim.forces.drive_table``
    reads it: a force's amplitude in N (A k), a displacement's in m."""
    table = np.zeros((len(found), instruments.DRIVE_FIELDS))
    rest = np.asarray(model.rest_positions)
    for row, (driver, j, i) in zip(table, found, strict=True):
        row[instruments.ROW], row[instruments.COLUMN] = j, i
        row[instruments.DIRECTION:instruments.DIRECTION + 3] = driver.direction
        force = driver.kind == "force"
        row[instruments.AMPLITUDE] = driver.amplitude * (model.stiffness if force else 1.0)
        row[instruments.OMEGA] = driver.angular_frequency
        row[instruments.PHASE] = driver.phase
        row[instruments.START], row[instruments.RAMP] = driver.start, driver.ramp
        row[instruments.KIND] = instruments.FORCE if force else instruments.DISPLACEMENT
        row[instruments.INVERSE_MASS] = 1.0 / float(model.masses[j, i])
        position = rest[j * model.nx + i]
        row[instruments.REST:instruments.REST + model.dim] = position[: model.dim]
    return table
