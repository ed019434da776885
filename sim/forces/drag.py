"""Drag on every particle's absolute velocity: a force -b v (N).

The kernels take b as ``Terms.drag`` (None: no drag, compiled out); ``drag_force`` is its part of
a particle's net force (``sim.forces.springs.particle_acceleration``) and ``drag_power`` the
power it takes from a row (W).
"""

from __future__ import annotations

from numba import njit

from sim.forces.term import ForceTerm, KernelField, Parameter

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def drag_force(drag, velocity):
    """Drag force (fx, fy, fz) (N) on a particle of ``velocity`` (vx, vy, vz)."""
    return -drag * velocity[0], -drag * velocity[1], -drag * velocity[2]


@njit(**_JIT)
def drag_power(drag, vx, vy, vz, r):
    """Power (W) that ``drag`` (None: none) takes from the particles stored at row index r."""
    power = 0.0
    if drag is not None:
        for i in range(vx.shape[1]):
            speed_squared = vx[r, i] * vx[r, i] + vy[r, i] * vy[r, i]
            if vz is not None:
                speed_squared += vz[r, i] * vz[r, i]
            power += drag * speed_squared
    return power


TERM = ForceTerm(
    "drag",
    "drag on every particle's absolute velocity",
    parameters=(Parameter("drag", "b", "N s/m", "Drag",
                          "drag on every particle's absolute velocity", 0.0, 1e9, 0.0,
                          page=(0.0, 5.0, 0.05)),),
    fields=(KernelField("drag", "terms", "number",
                        lambda model: model.drag if model.drag > 0 else None),),
    present=lambda model: model.drag > 0,
    describe=lambda model: f"drag {model.drag:g}",
    example={"drag": 0.2},
    velocity_dependent=True,
    leapfrog=False,
    numpy_force=lambda model, positions, velocities: -model.drag * velocities,
)
