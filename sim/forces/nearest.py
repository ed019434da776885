"""The nearest-neighbour springs as a registered force term: their parameters.

Their kernels are the row functions of ``sim.forces.springs`` (the law of one spring along its
length is ``sim.forces.axial``); the model stores k and L as its own fields, as every lattice
has them.
"""

from __future__ import annotations

from sim.forces.term import ForceTerm, LinearStiffness, Parameter

TERM = ForceTerm(
    "nearest springs",
    "a spring from every particle to each of its four nearest neighbours (or a wall anchor)",
    parameters=(
        Parameter("stiffness", "k", "N/m", "Stiffness",
                  "spring constant of every nearest-neighbour spring", 1e-9, 1e9, 1.0),
        Parameter("rest_length", "L", "m", "Rest length",
                  "spring rest length; L < a pre-tensions the lattice with T = k (a - L)",
                  1e-6, 1e6),
    ),
    linear_stiffness=lambda model: LinearStiffness(
        model.stiffness, model.stiffness * (model.spacing - model.rest_length)),
)
