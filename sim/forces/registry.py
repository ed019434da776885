"""The registry of force terms: the one list every face reads.

Each term is one ``sim.forces.term.ForceTerm`` declared in its own module; ``TERMS`` lists them
in the order the parameter table shows them.  Adding a term is its module and one line here: the
parameter table, the model's checks and stored values, the kernel records' fields, the kernel key,
the loops' choice of shape, the model's description, scene files and the page read this list.
"""

from __future__ import annotations

from typing import Any

from sim.forces import dashpot, diagonal, drag, fpu, gravity, nearest
from sim.forces.term import ForceTerm, KernelField, LinearStiffness, Parameter

TERMS: tuple[ForceTerm, ...] = (
    nearest.TERM,
    diagonal.TERM,
    dashpot.TERM,
    drag.TERM,
    gravity.TERM,
    fpu.TERM,
)
"""Every force term, in the parameter table's order."""


def parameters() -> tuple[Parameter, ...]:
    """Every term's parameter rows, in order."""
    return tuple(row for term in TERMS for row in term.parameters)


def owner(parameter: str) -> ForceTerm | None:
    """The term that declares ``parameter``, or None."""
    for term in TERMS:
        if any(row.name == parameter for row in term.parameters):
            return term
    return None


def fields(record: str) -> tuple[KernelField, ...]:
    """The fields the terms add to the kernel record ``record`` ("springs" or "terms")."""
    return tuple(field for term in TERMS for field in term.fields if field.record == record)


def present(model: Any) -> tuple[ForceTerm, ...]:
    """The terms ``model`` has."""
    return tuple(term for term in TERMS if term.present(model))


def kernel_values(record: str, model: Any) -> dict[str, Any]:
    """The values of the fields the terms add to the kernel record ``record`` ("springs" or
    "terms") for ``model`` (float64; None: compiled out, ``ForceTerm.kernel_values``)."""
    damped = velocity_dependent(model)
    names = {field.name for field in fields(record)}
    return {name: value for term in TERMS for name, value in term.kernel_values(model, damped).items()
            if name in names}


def kernel_flags(model: Any) -> tuple:
    """What of every term changes the compiled kernels' types (which fields are compiled in),
    in order: the force terms' part of the kernel key."""
    damped = velocity_dependent(model)
    return tuple(tuple(value is not None for value in term.kernel_values(model, damped).values())
                 for term in TERMS)


def linear_stiffness(model: Any) -> LinearStiffness:
    """The lattice's stiffness at rest, summed over the terms ``model`` has: what the normal
    modes, the bands and the exact solver read."""
    parts = [term.linear_stiffness(model) for term in present(model)
             if term.linear_stiffness is not None]
    return LinearStiffness(*(float(sum(values)) for values in zip(*parts, strict=True))) \
        if parts else LinearStiffness()


def velocity_dependent(model: Any) -> bool:
    """Whether a term ``model`` has depends on the velocities (dashpots, drag)."""
    return any(term.velocity_dependent for term in present(model))


def leapfrog(model: Any) -> bool:
    """Whether the fused leapfrog loop carries every term ``model`` has."""
    return all(term.leapfrog for term in present(model))


def conflicts(model: Any) -> list[str]:
    """Why ``model``'s terms cannot run together (empty: they can): a term the absorbing layer
    does not take."""
    return [f"the absorbing layer has no {term.name} yet; use fixed walls far away (boundary "
            f"fixed) or no {term.name}"
            for term in present(model) if model.walls.absorbing and not term.absorbing_layer]
