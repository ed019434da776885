"""What a force term is, as data: its parameters, what the kernels take of it, what it works with.

A ``ForceTerm`` is declared once, in the module that holds the term's kernels (``nearest`` for the
nearest springs, whose kernels are ``springs`` and ``axial``; ``diagonal``, ``dashpot``, ``drag``,
``gravity``, ``fpu``), and registered in ``sim.forces.registry``.  Everything that shows,
checks, stores, compiles or explains a term reads that one object: the parameter table
(``Parameter`` rows, ``sim.model.parameters``), the model's stored values and their checks, the
kernels' records (``KernelField``: the fields a term adds to
``sim.forces.springs.SpringParameters`` or ``sim.forces.terms.Terms``), the kernel key
(``sim.runtime.warming``), the loops' choice of shape (``velocity_dependent``, ``leapfrog``),
the model's one-line description, scene files and the page's Physics folder.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np


@dataclasses.dataclass(frozen=True)
class Parameter:
    """One scene parameter.

    ``low``/``high``: the bounds of a number (SI units; None for whole numbers, flags, choices and
    records, which the model checks itself).  ``symbol``: as in the docs and the paper (``-`` when
    it has none); ``unit``: the SI unit, or what the value is when it has none; ``label``: the few
    words a control shows; ``help``: one sentence for read-mes and ``--help``.  ``default``: the
    value a model has when nobody sets it (a force term's parameters: the term absent).
    ``page``: (lowest, highest, step) of the slider the page's Physics folder shows for a force
    term's parameter; None: no slider of this kind (the folder's own controls, or none).
    """

    name: str
    symbol: str
    unit: str
    label: str
    help: str
    low: float | None = None
    high: float | None = None
    default: Any = None
    page: tuple[float, float, float] | None = None

    @property
    def bounds(self) -> tuple[float, float] | None:
        """(smallest, largest) of a number, None for anything else."""
        if self.low is None or self.high is None:
            return None
        return (self.low, self.high)

    def caption(self) -> str:
        """The label with its symbol and unit, as a control shows it: "Spring constant k (N/m)"."""
        symbol = "" if self.symbol == "-" else f" {self.symbol}"
        return f"{self.label}{symbol} ({self.unit})"


@dataclasses.dataclass(frozen=True)
class KernelField:
    """One field a term adds to a kernel record.

    ``record``: "springs" (``SpringParameters``) or "terms" (``Terms``).  ``kind``: "number" (a
    scalar in the kernels' precision), "flag" (True, or None) or "vector" (an array in the
    kernels' precision).  ``value(model)``: the field's value in float64, None when the model
    does not have the term: numba compiles one version per combination of None and not None, so
    an absent term costs nothing.
    """

    name: str
    record: str
    kind: str
    value: Callable[[Any], Any]
    zero: Any = None
    """The value that adds nothing (a zero vector), passed where the term is absent but not
    compiled out (``ForceTerm.compiled_out_when_damped``)."""


def in_precision(kind: str, value: Any, scalar: type) -> Any:
    """A kernel record's value of ``kind`` ("number", "flag", "vector") in the kernels'
    precision ``scalar``; None stays None (the term is absent) and a flag stays as it is."""
    if value is None or kind == "flag":
        return value
    if kind == "vector":
        return np.asarray(value, dtype=scalar)
    return scalar(value)


class LinearStiffness(NamedTuple):
    """A term's part of the lattice's stiffness at rest, what the linear theory reads (the
    normal modes, the bands, the exact solver; ``sim.forces.registry.linear_stiffness`` sums the
    terms): ``along`` (N/m) the stiffness of a nearest spring along its rest direction, d F / d s
    at the rest extension; ``tension`` (N) the nearest springs' force at rest, which stiffens
    them across by tension / a; ``diagonal`` (N/m) a diagonal spring's stiffness along itself."""

    along: float = 0.0
    tension: float = 0.0
    diagonal: float = 0.0


@dataclasses.dataclass(frozen=True)
class ForceTerm:
    """One force term of the lattice.

    ``parameters``: its rows of the parameter table; a row whose name is not a field of
    ``sim.model.lattice.Model`` is stored by the model for the term (``Model.create`` takes it,
    checked by ``check``, and the model answers it as an attribute).  ``check(name, value)``:
    the value a model stores (raises ``ValueError`` saying why not); None: a number within the
    row's bounds.  ``fields``: what the kernels take (``KernelField``).  ``present(model)``:
    whether the model has the term.  ``describe(model)``: a few words for ``Model.describe``
    when present.  ``example``: parameter values that make the term present (the tests set
    them).  What it works with: ``velocity_dependent`` (the force depends on velocities: Verlet
    then predicts them), ``leapfrog`` (the fused leapfrog loop carries it), ``absorbing_layer``
    (False: a model with absorbing walls refuses it).

    Its numpy twins, written from the physics apart from the kernels (the reference integrators
    and the tests use them): ``numpy_force(model, positions, velocities)`` its force (N) on
    every particle, (dim, ny, nx) arrays; ``numpy_energy(model, positions)`` the elastic energy (J)
    it stores, from the rest lattice; ``numpy_axial(model, stretch)`` for a term of the nearest springs' law
    along their length (``sim.forces.axial``): (its force (N) along each spring of extension
    ``stretch`` (m), its energy (J)) on top of Hooke's k s and k s^2 / 2.

    ``linear_stiffness(model)``: its ``LinearStiffness`` at rest (None: the term adds no
    stiffness, as gravity or a dashpot).
    """

    name: str
    summary: str
    parameters: tuple[Parameter, ...] = ()
    fields: tuple[KernelField, ...] = ()
    present: Callable[[Any], bool] = lambda model: True
    describe: Callable[[Any], str] | None = None
    example: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    check: Callable[[str, Any], Any] | None = None
    velocity_dependent: bool = False
    leapfrog: bool = True
    absorbing_layer: bool = True
    numpy_force: Callable[..., Any] | None = None
    numpy_energy: Callable[..., Any] | None = None
    numpy_axial: Callable[..., Any] | None = None
    linear_stiffness: Callable[[Any], LinearStiffness] | None = None
    compiled_out_when_damped: bool = True
    """False: in a scene with a velocity-dependent term, this term's fields are passed as their
    ``zero`` when it is absent instead of being compiled out, so that switching it on or off there
    compiles nothing new (for a term that buys less than 3 % in those kernels, which are slower
    anyway: ``oscillators bench --only specialisation``, ``docs/speed.md``)."""

    def kernel_values(self, model: Any, damped: bool) -> dict[str, Any]:
        """Its fields' values for the kernels of ``model`` (float64; None: compiled out), in a
        scene with velocity-dependent terms when ``damped``."""
        values = {field.name: field.value(model) for field in self.fields}
        if damped and not self.compiled_out_when_damped:
            values = {field.name: field.zero if values[field.name] is None else values[field.name]
                      for field in self.fields}
        return values
