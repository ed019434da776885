"""The mutable state of a simulation: positions, velocities, time, and energy dissipated so far.

Arrays are stored component-major, ``(dim, ny, nx)`` C-contiguous (what the kernels want), in
float64 or float32 (the simulation's precision); the
particle-major ``(n_particles, dim)`` arrays that users see are views of the same memory, so
writing into them moves the particles.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sim.model.lattice import Model


@dataclasses.dataclass
class State:
    """Positions (m), velocities (m/s), time (s), step count, dissipated energy and driver work (J).

    ``positions`` and ``velocities`` are ``(dim, ny, nx)`` arrays; ``revision`` counts changes made
    from outside the integrators (a drag, a reset) so cached forces know when to recompute.
    """

    positions: np.ndarray
    velocities: np.ndarray
    time: float = 0.0
    step: int = 0
    dissipated: float = 0.0
    revision: int = 0
    driven: float = 0.0
    """Work done on the lattice by a driver so far (J)."""

    @classmethod
    def at_rest(cls, model: Model, dtype: type[np.floating] = np.float64) -> State:
        """The rest lattice, not moving, stored in ``dtype`` (np.float64 or np.float32)."""
        positions = np.array(
            model.rest_positions.T.reshape(model.dim, model.ny, model.nx), order="C", dtype=dtype
        )
        return cls(positions=positions, velocities=np.zeros_like(positions))

    @classmethod
    def from_particle_arrays(
        cls, model: Model, positions: np.ndarray, velocities: np.ndarray,
        dtype: type[np.floating] = np.float64,
    ) -> State:
        """Build from (n_particles, dim) arrays, stored in ``dtype``."""
        state = cls.at_rest(model, dtype)
        state.particle_positions()[...] = positions
        state.particle_velocities()[...] = velocities
        return state

    def as_type(self, dtype: type[np.floating]) -> State:
        """A copy of this state stored in ``dtype`` (positions rounded to its precision)."""
        return dataclasses.replace(
            self, positions=self.positions.astype(dtype), velocities=self.velocities.astype(dtype)
        )

    def copy(self) -> State:
        return dataclasses.replace(
            self, positions=self.positions.copy(), velocities=self.velocities.copy()
        )

    def restore(self, other: State) -> None:
        """Copy another state's values into this one's arrays (keeps views valid)."""
        self.positions[...] = other.positions
        self.velocities[...] = other.velocities
        self.time = other.time
        self.step = other.step
        self.dissipated = other.dissipated
        self.driven = other.driven
        self.revision += 1

    def advance_clock(self, n: int, dt: float) -> None:
        """n steps of dt later.  The time is summed one step at a time, so it does not depend
        on how the steps were grouped into calls (n steps at once = n single steps, bit for bit)."""
        self.step += n
        time = self.time
        for _ in range(n):
            time += dt
        self.time = time

    def particle_positions(self) -> np.ndarray:
        """(n_particles, dim) view of the positions (m)."""
        return _view(self.positions)

    def particle_velocities(self) -> np.ndarray:
        """(n_particles, dim) view of the velocities (m/s)."""
        return _view(self.velocities)

    def is_finite(self) -> bool:
        return bool(np.isfinite(self.positions).all() and np.isfinite(self.velocities).all())


def _view(component_major: np.ndarray) -> np.ndarray:
    dim = component_major.shape[0]
    return component_major.reshape(dim, -1).T

