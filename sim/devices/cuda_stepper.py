"""``CudaVerlet``: velocity Verlet of a planar lattice of nearest springs on an NVIDIA GPU.

What it runs is what ``cuda_support`` accepts: a planar lattice (dim 2), Hooke's nonlinear
nearest springs between fixed walls, any masses, no other force term, no driver, source or
absorbing layer.  Anything else is refused with the reason, before anything changes.

The state stays on the device between calls while nobody touches it (the ``State``'s revision
and time); each call copies the new positions and velocities back, so the ``State`` the
simulation checks, observes and records is always the current one.  numba-cuda's simulator
(``NUMBA_ENABLE_CUDASIM=1``) runs the same code on the CPU, one Python thread per GPU thread:
correct and slow, for tests on machines without a GPU.
"""

from __future__ import annotations

import numpy as np

from sim.forces import nearest, registry
from sim.integrators.registry import describe, names_on
from sim.model.lattice import Model, ModelError
from sim.model.state import State


def cuda_support(model: Model, integrator: str) -> str | None:
    """Why ``model`` cannot run with ``integrator`` on the GPU, or None if it can."""
    runs = names_on("cuda")
    if integrator not in runs:
        return ("the GPU runs " + ", ".join(f"{describe(name).label} (integrator '{name}')"
                                            for name in runs) + f" only, not {integrator!r}")
    if model.dim != 2:
        return "the GPU runs planar lattices only (dim 2)"
    if model.linear:
        return "the GPU runs the nonlinear spring law only (linear false)"
    if model.row_ends != "walls":
        return f"the GPU runs fixed walls only, not {model.boundary!r}"
    if model.has_forcing:
        return "the GPU runs no driver, source or absorbing layer"
    others = [term.name for term in registry.present(model) if term is not nearest.TERM]
    if others:
        return "the GPU runs the nearest springs only, not " + ", ".join(others)
    return None


def cuda_device_problem() -> str | None:
    """Why no CUDA device can run kernels here (None: one can, or the simulator is on)."""
    try:
        from numba import cuda
    except ImportError:
        return ("numba-cuda is not installed: pip install 'coupled-oscillators[gpu]' "
                "(NVIDIA's CUDA target for numba)")
    if cuda.is_available():
        return None
    return ("no CUDA GPU found (numba.cuda.is_available() is False); NUMBA_ENABLE_CUDASIM=1 "
            "runs the GPU code on numba-cuda's simulator, slowly")


def device_name() -> str:
    """The name of the GPU the kernels run on, "simulator" under ``NUMBA_ENABLE_CUDASIM``."""
    from numba import config, cuda

    if getattr(config, "ENABLE_CUDASIM", False):
        return "simulator"
    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


class CudaVerlet:
    """The ``Stepper`` (``sim.integrators.registry``) of velocity Verlet on the GPU."""

    name = "verlet"
    drive = None
    sponge = None

    def __init__(self, model: Model, dtype: type[np.floating] = np.float64,
                 integrator: str = "verlet") -> None:
        problem = cuda_support(model, integrator) or cuda_device_problem()
        if problem is not None:
            raise ModelError(f"device 'cuda': {problem}")
        from numba import cuda

        from sim.devices import cuda_lattice

        self.model = model
        self.dtype = np.dtype(dtype).type
        self._cuda = cuda
        self._kernel = cuda_lattice.leapfrog_kernel(np.dtype(dtype).name)
        self._law = cuda_lattice.law_record(model.kernel_parameters, self.dtype)
        self._blocks, self._threads = cuda_lattice.launch_shape(model.nx, model.ny)
        shape = (model.ny, model.nx)
        self._inverse_mass = cuda.to_device(np.ascontiguousarray(model.inverse_masses,
                                                                 dtype=self.dtype))
        self._positions = [cuda.device_array((2, *shape), dtype=self.dtype) for _ in range(2)]
        self._velocity = cuda.device_array((2, *shape), dtype=self.dtype)
        self._current = 0
        self._on_device: tuple | None = None

    @property
    def in_step(self) -> frozenset[str]:
        return frozenset()

    def invalidate(self) -> None:
        """The state was changed from outside: copy it to the device before the next steps."""
        self._on_device = None

    def _launch(self, kick: float, drift: float, moves: bool) -> None:
        x_in = self._positions[self._current]
        x_out = self._positions[1 - self._current]
        v = self._velocity
        self._kernel[self._blocks, self._threads](
            x_in[0], x_in[1], x_out[0], x_out[1], v[0], v[1], self._inverse_mass, self._law,
            self.dtype(kick), self.dtype(drift), moves)
        if moves:
            self._current = 1 - self._current

    def advance(self, state: State, n: int, dt: float) -> None:
        """n steps of velocity Verlet: a (dt/2, dt) leapfrog launch, n - 1 (dt, dt) launches and
        a closing half kick, as the CPU's leapfrog (``sim.loops.leapfrog``)."""
        if n <= 0:
            return
        stamp = (state.revision, state.time, state.step)
        if self._on_device != stamp:
            self._positions[self._current].copy_to_device(np.ascontiguousarray(state.positions))
            self._velocity.copy_to_device(np.ascontiguousarray(state.velocities))
        half = 0.5 * dt
        self._launch(half, dt, True)
        for _ in range(n - 1):
            self._launch(dt, dt, True)
        self._launch(half, 0.0, False)
        self._positions[self._current].copy_to_host(state.positions)
        self._velocity.copy_to_host(state.velocities)
        state.advance_clock(n, dt)
        self._on_device = (state.revision, state.time, state.step)
