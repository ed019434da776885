"""The scene's terms as every kernel takes them: one flat record, a field per term.

A loop shape (``sim.loops``) passes one ``Terms`` record down to the row functions of the springs
(``sim.forces.springs``) beside the spring constants (``SpringParameters``); a new term is a
field here, filled in one place (``sim.integrators.steppers.KernelArguments.from_model``).

A field that is None marks a term the scene does not have.  numba compiles one machine-code
version per combination of field types and prunes an ``is None`` branch when the value tested
is an argument of the function that tests it, so the row functions pass the field on as an
argument (``terms.dashpot`` to the spring law, ``terms.drag`` to ``particle_acceleration``)
rather than testing ``terms.drag is None`` themselves: that would be typed on both sides and
fail.  The record is flat (no record inside it): numba's parallel loops do not take a record
nested in another.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


class Terms(NamedTuple):
    """The model's terms in one precision (None marks an absent term, compiled out).

    ``linear`` None for the nonlinear spring law, True for the linearised one (a compile-time
    choice: never False); ``out_of_plane`` None for planar scenes (dim 2), True for dim 3;
    ``inverse_mass`` (ny, nx) 1/kg; ``uniform_inverse_mass`` (1/kg) replaces it for equal masses
    (one memory stream less); ``dashpot`` c (N s/m) beside every spring; ``drag`` (N s/m) on
    every particle; ``gravity`` (3,) m/s^2.
    """

    linear: object
    out_of_plane: object
    inverse_mass: np.ndarray
    uniform_inverse_mass: np.floating | None
    dashpot: np.floating | None
    drag: np.floating | None
    gravity: np.ndarray | None


@njit(**_JIT)
def inverse_mass_at(uniform_inverse_mass, inverse_mass, j, i):
    """1/m (1/kg) of the particle at row j, column i: the uniform one when not None."""
    if uniform_inverse_mass is not None:
        return uniform_inverse_mass
    return inverse_mass[j, i]
