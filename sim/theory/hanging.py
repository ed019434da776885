"""Whether a lattice can hang under gravity between its walls.

In the static solution of a column of N equal masses m between two walls, gravity g along the
column is carried half by the springs above and half by those below: the end springs' forces
change by about N m g / 2. The springs' rest tension k (a - L) must carry that, or the lower
springs are compressed, and a compressed lattice buckles sideways and folds through its bottom
wall (measured on the 12x8 grid and the 15x10 catenary: every lattice whose rest tension was
below that load folded; every one above it hung). ``hanging_problem`` says so, with the load and
the tension, per direction of gravity that has walls at both ends.
"""

from __future__ import annotations

import numpy as np

from sim.model.lattice import Model


def end_load(model: Model, axis: int) -> float:
    """About N m g / 2 (N): what gravity along ``axis`` (0: the rows, 1: the columns) adds to
    the force of a column's or row's end springs in the static solution (mean mass)."""
    count = model.ny if axis == 1 else model.nx
    return float(np.mean(model.masses)) * abs(model.gravity[axis]) * count / 2.0


def hanging_problem(model: Model) -> str | None:
    """Why ``model`` under gravity cannot hang between its walls, or None (it can, or there
    is no gravity across walls)."""
    if not model.has_gravity or model.linear:
        return None
    tension = model.tension
    for axis, line in ((1, "column"), (0, "row")):
        if axis == 0 and model.row_ends != "walls":
            continue  # rings and free ends: no walls to hang from along the rows
        load = end_load(model, axis)
        if load > 0 and load > tension:
            return (f"gravity puts about {load:.3g} N on the end springs of each {line}, more "
                    f"than their rest tension k (a - L) = {tension:.3g} N: the lower springs "
                    "are compressed, and the lattice buckles and folds through its wall. To "
                    "hang it, pre-tension the springs so that k (a - L) > "
                    f"{load:.3g} N: for example L/a = 0.5 and k = {suggested_stiffness(model, load):g} "
                    "N/m")
    return None


def suggested_stiffness(model: Model, load: float) -> float:
    """A round stiffness (N/m) whose rest tension at L = a / 2 carries ``load`` with a tenth to
    spare: k = 2.2 load / a, rounded up to 1, 2 or 5 times a power of ten."""
    wanted = 2.2 * load / model.spacing
    power = 10.0 ** np.floor(np.log10(wanted))
    for step in (1.0, 2.0, 5.0, 10.0):
        if step * power >= wanted:
            return float(step * power)
    return float(10 * power)
