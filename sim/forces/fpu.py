"""The Fermi-Pasta-Ulam-Tsingou spring law: a nearest spring stretched by s pulls with
k (s + alpha s^2 + beta s^3) and stores k (s^2/2 + alpha s^3/3 + beta s^4/4).

s is the extension |d| - L of the nonlinear law; the linearised law keeps this law along the
springs' rest direction, about their rest extension a - L (with L = a, a chain moving along
itself is the FPU chain of 1955).  The kernels
are the law's part in ``sim.forces.axial`` (``alpha``, ``beta`` None: Hooke's law, compiled out);
this module declares the term and its numpy twin.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sim.forces.term import ForceTerm, KernelField, LinearStiffness, Parameter


def _numpy_axial(model: Any, stretch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(force (N), energy (J)) of the alpha and beta terms of springs stretched by ``stretch``."""
    k, alpha, beta = model.stiffness, model.spring_alpha, model.spring_beta
    s = np.asarray(stretch, dtype=float)
    return (k * (alpha * s**2 + beta * s**3),
            k * (alpha * s**3 / 3.0 + beta * s**4 / 4.0))


def _linear_stiffness(model: Any) -> LinearStiffness:
    """What alpha and beta add at the rest extension s0 = a - L: k (2 alpha s0 + 3 beta s0^2)
    along the springs, k (alpha s0^2 + beta s0^3) to their rest tension."""
    k, alpha, beta = model.stiffness, model.spring_alpha, model.spring_beta
    s0 = model.spacing - model.rest_length
    return LinearStiffness(k * (2 * alpha * s0 + 3 * beta * s0**2),
                           k * (alpha * s0**2 + beta * s0**3))


def _describe(model: Any) -> str:
    return f"FPU spring law α={model.spring_alpha:g}/m, β={model.spring_beta:g}/m²"


TERM = ForceTerm(
    "FPU spring law",
    "the quadratic (alpha) and cubic (beta) terms of the Fermi-Pasta-Ulam-Tsingou springs",
    parameters=(
        Parameter("spring_alpha", "α", "1/m", "FPU quadratic term",
                  "quadratic term of the nearest springs' law, k (s + α s² + β s³) (0: none)",
                  -1e6, 1e6, 0.0, page=(-1.0, 1.0, 0.01)),
        Parameter("spring_beta", "β", "1/m²", "FPU cubic term",
                  "cubic term of the nearest springs' law, k (s + α s² + β s³) (0: none)",
                  -1e6, 1e6, 0.0, page=(0.0, 10.0, 0.1)),
    ),
    fields=(
        KernelField("spring_alpha", "springs", "number",
                    lambda model: model.spring_alpha or None),
        KernelField("spring_beta", "springs", "number", lambda model: model.spring_beta or None),
    ),
    present=lambda model: model.spring_alpha != 0.0 or model.spring_beta != 0.0,
    describe=_describe,
    example={"spring_alpha": 0.25, "spring_beta": 1.0},
    numpy_axial=_numpy_axial,
    linear_stiffness=_linear_stiffness,
)
