"""Dashpots beside every nearest spring: a force c ((v2 - v1) . d) d / |d|^2 along the spring.

The dashpot acts inside the spring law (``sim.forces.springs``: ``dashpot_factor`` is its part of
the law's factor) and the kernels take its c as ``Terms.dashpot`` (None: no dashpots, compiled
out).  It dissipates the power c (dv . d)^2 / |d|^2 (W), which the loops sum.
"""

from __future__ import annotations

from numba import njit

from sim.forces.term import ForceTerm, KernelField, Parameter

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def dashpot_factor(dashpot, rate, inverse_length):
    """(the dashpot's part of the spring law's factor on d, the power it dissipates (W)) for a
    spring whose ends separate at ``rate`` = dv . d (m^2/s)."""
    factor = dashpot * rate * inverse_length * inverse_length
    return factor, factor * rate


TERM = ForceTerm(
    "dashpots",
    "a dashpot beside every nearest spring, on the velocity along it",
    parameters=(Parameter("damping", "c", "N s/m", "Dashpot",
                          "dashpot beside every spring (relative velocity along it)",
                          0.0, 1e9, 0.0),),
    fields=(KernelField("dashpot", "terms", "number",
                        lambda model: model.damping if model.damping > 0 else None),),
    present=lambda model: model.damping > 0,
    describe=lambda model: f"dashpots c={model.damping:g}",
    example={"damping": 0.5},
    velocity_dependent=True,
    leapfrog=False,
)
