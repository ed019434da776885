"""The scene parameters as data: one ``Parameter`` row each, the one table of their facts.

A row says what a parameter is called on the command line and in scene files (``name``), its
symbol and unit, its bounds (numbers only), a short label and a sentence of help.  Everything that
shows or checks a parameter reads this table: the checks of every outside value
(``sim.model.schema.BOUNDS``), the keys ``--set`` and ``build`` accept
(``sim.scenes.building.OVERRIDES``), the recording's read-me and the page's sliders (their labels).
A force term's rows come from its declaration (``sim.forces.registry``); adding another
parameter is one row here plus its use in the model.
"""

from __future__ import annotations

import math

from sim.forces import registry
from sim.forces.term import Parameter
from sim.model import boundaries

__all__ = ["Parameter", "bounds", "get", "names", "register", "rows"]


_TABLE: dict[str, Parameter] = {}


def register(parameter: Parameter) -> Parameter:
    """Add ``parameter`` to the table (a name is registered once)."""
    if parameter.name in _TABLE:
        raise ValueError(f"parameter {parameter.name!r} is already registered")
    if parameter.bounds is not None and not (
            math.isfinite(parameter.low) and math.isfinite(parameter.high)
            and parameter.low <= parameter.high):
        raise ValueError(f"parameter {parameter.name!r} has bounds {parameter.bounds}")
    _TABLE[parameter.name] = parameter
    return parameter


def get(name: str) -> Parameter:
    """The row of ``name``; a clear error lists the known names."""
    try:
        return _TABLE[name]
    except KeyError:
        raise KeyError(f"no scene parameter {name!r}; known: {', '.join(_TABLE)}") from None


def names() -> tuple[str, ...]:
    """The parameters' names in table order."""
    return tuple(_TABLE)


def rows() -> tuple[Parameter, ...]:
    """Every row, in table order."""
    return tuple(_TABLE.values())


def bounds() -> dict[str, tuple[float, float]]:
    """(smallest, largest) of every number parameter."""
    return {row.name: row.bounds for row in _TABLE.values() if row.bounds is not None}


# With these bounds the largest energy scale, stiffness x (spacing x particles)^2 ~ 1e9 x 1e22,
# stays far below float64's 1e308.
for _row in (
    Parameter("nx", "n_x", "particles", "Particles per row", "particles per row"),
    Parameter("ny", "n_y", "particles", "Rows", "particles per column (rows)"),
    Parameter("spacing", "a", "m", "Spacing",
              "lattice spacing, also the distance to the wall anchors", 1e-6, 1e6),
    Parameter("mass", "m", "kg", "Mass", "mass of every particle (a preset may vary it)",
              1e-9, 1e9),
    *registry.parameters(),
    Parameter("linear", "-", "true/false (no unit)", "Linear springs",
              "springs linearised about the rest lattice"),
    Parameter("dim", "d", "dimensions", "Dimensions",
              "2: motion in the plane; 3: also out of the plane (z)"),
    Parameter("driver", "-", "see its fields (m, Hz)", "Driver",
              "sinusoidal drive on one particle, or none"),
    Parameter("sources", "-", "see their fields (m, Hz, rad)", "Sources",
              "drives with a phase on particles or whole columns"),
    Parameter("barriers", "-", "columns and openings (no unit)", "Barriers",
              "pinned columns with openings (slits)"),
    Parameter("boundary", "-", f"{'/'.join(boundaries.names())} (no unit)", "Walls",
              "walls: fixed anchors, rows as rings, free row ends, or a layer inside them that "
              "absorbs waves"),
    Parameter("sponge_width", "w", "particles", "Absorbing layer depth",
              "depth of the absorbing layer (absorbing walls only)"),
    Parameter("sponge_strength", "-", "ω0 = √(k/m)", "Absorbing layer strength",
              "damping rate at the wall (absorbing walls only)"),
    Parameter("sponge_sides", "-", "walls (no unit)", "Absorbing walls",
              "walls that have an absorbing layer"),
):
    register(_row)
