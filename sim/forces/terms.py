"""The scene's terms as every kernel takes them: one flat record, a field per term.

A loop shape (``sim.loops``) passes one ``Terms`` record down to the row functions of the springs
(``sim.forces.springs``) beside the spring constants (``SpringParameters``); a new term is a
field a force term declares (``sim.forces.term.KernelField``), filled in one place
(``sim.integrators.steppers.KernelArguments.from_model``).

A field that is None marks a term the scene does not have.  numba compiles one machine-code
version per combination of field types and prunes an ``is None`` branch when the value tested
is an argument of the function that tests it, so the row functions pass the field on as an
argument (``terms.dashpot`` to the spring law, ``terms.drag`` to ``particle_acceleration``)
rather than testing ``terms.drag is None`` themselves: that would be typed on both sides and
fail.  The record is flat (no record inside it): numba's parallel loops do not take a record
nested in another.
"""

from __future__ import annotations

from collections import namedtuple

from numba import njit

from sim.forces import registry

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

_BASE_FIELDS = ("linear", "out_of_plane", "inverse_mass", "uniform_inverse_mass", "damped")
FIELDS = _BASE_FIELDS + tuple(field.name for field in registry.fields("terms"))
"""The record's fields: the lattice's own, then one per ``KernelField`` a force term adds to
it (``sim.forces.registry``: the dashpots' c, drag, gravity)."""


class Terms(namedtuple("Terms", FIELDS, defaults=(None,) * (len(FIELDS) - 3))):
    """The model's terms in one precision (None marks an absent term, compiled out).

    ``linear`` None for the nonlinear spring law, True for the linearised one (a compile-time
    choice: never False); ``out_of_plane`` None for planar scenes (dim 2), True for dim 3;
    ``inverse_mass`` (ny, nx) 1/kg; ``uniform_inverse_mass`` (1/kg) replaces it for equal masses
    (one memory stream less); ``damped`` True when a present term depends on the velocities
    (the loops then predict them), else None.  Then the force terms' fields: ``dashpot`` c
    (N s/m) beside every spring; ``drag`` (N s/m) on every particle; ``gravity`` (3,) m/s^2.
    Every field after ``inverse_mass`` is None (absent) unless given.
    """

    __slots__ = ()


@njit(**_JIT)
def inverse_mass_at(uniform_inverse_mass, inverse_mass, j, i):
    """1/m (1/kg) of the particle at row j, column i: the uniform one when not None."""
    if uniform_inverse_mass is not None:
        return uniform_inverse_mass
    return inverse_mass[j, i]
