"""Gravity: a uniform acceleration g (m/s^2) on every particle.

The kernels take it as ``Terms.gravity`` ((3,) array, None: none, compiled out);
``gravity_vector`` gives it as the tuple ``particle_acceleration`` adds.  A scene gives g as a
number (downwards, -y) or a 2- or 3-vector (``as_vector``); the z component acts only in 3-D.
Its potential energy is a line of its own in the energy account
(``sim.theory.observables.gravity_energy``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit

from sim.forces.term import ForceTerm, KernelField, Parameter

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def gravity_vector(gravity, zero):
    """The (3,) gravity array as a tuple (gx, gy, gz) in m/s^2 for ``particle_acceleration``;
    (zero, zero, zero) when there is none (``gravity`` None), which compiles to nothing."""
    if gravity is None:
        return zero, zero, zero
    return gravity[0], gravity[1], gravity[2]


def as_vector(name: str, gravity: Any) -> tuple[float, float, float]:
    """g as the (x, y, z) vector a model stores: a number means (0, -g, 0) (downwards)."""
    try:
        array = np.asarray(gravity)
    except (TypeError, ValueError):
        array = None
    if array is None or array.dtype.kind not in "fiu":
        raise ValueError(f"{name} must be a number (downwards) or a 2- or 3-vector, got "
                         f"{str(gravity)[:40]!r}")
    array = array.astype(float)
    if array.ndim == 0:
        vector = (0.0, -float(array), 0.0)
    elif array.shape in ((2,), (3,)):
        vector = tuple(float(c) for c in array) + (0.0,) * (3 - array.shape[0])
    else:
        raise ValueError(f"{name} must be a number (downwards) or a 2- or 3-vector, got "
                         f"{str(gravity)[:40]!r}")
    if not all(math.isfinite(component) for component in vector):
        raise ValueError(f"{name} must be finite, got {vector}")
    return vector  # type: ignore[return-value]


def _numpy_force(model: Any, positions: np.ndarray, velocities: np.ndarray) -> np.ndarray:
    g = np.asarray(model.gravity[: model.dim])[:, None, None]
    return g * np.asarray(model.masses)[None]


TERM = ForceTerm(
    "gravity",
    "a uniform acceleration on every particle",
    parameters=(Parameter("gravity", "g", "m/s²", "Gravity",
                          "acceleration of gravity (x, y, z)", -1e6, 1e6, (0.0, 0.0, 0.0)),),
    fields=(KernelField("gravity", "terms", "vector",
                        lambda model: np.array(model.gravity) if model.has_gravity else None,
                        zero=np.zeros(3)),),
    # a zero pull costs the undamped leapfrog 8 %, RK4 4 %, the damped kernels -3 to +2 %
    compiled_out_when_damped=False,
    present=lambda model: model.has_gravity,
    describe=lambda model: "gravity (" + ", ".join(
        f"{g:g}" for g in model.gravity[: model.dim]) + ")",
    example={"gravity": 9.81},
    check=as_vector,
    numpy_force=_numpy_force,
)
