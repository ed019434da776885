"""coupled-oscillators simulation core: a lattice of point masses joined by springs.

The physics knows nothing of any viewer.  Main entry points::

    import sim
    sim.scenes.names()                      # the presets (``sim.scenes.presets``)
    scene = sim.scenes.build("grid", nx=20) # a preset with overrides
    sim.scenes.scene_files.save(scene, "grid.toml"); sim.scenes.scene_files.load("grid.toml")
    s = sim.Simulation(scene, integrator="rk4", dt=0.01)
    s.step(100); s.energy(); s.strains(); s.stable_dt()

Rooms (subpackages), each named after what it holds; a room uses only the rooms listed after it
(the layering contract in ``pyproject.toml``)::

    runtime      the simulation, the runner views subscribe to, the blow-up rule, error measures,
                 the kernel cache
    scenes       presets as data, building a scene, scene files, bodies and their continuum limit,
                 the ripple tank
    instruments  probes and the intensity screen: what measures a running lattice
    theory       normal modes, the exact solution, lattice waves, slits, predicted errors,
                 observables of a state
    integrators  the integrator registry, the steppers that advance a State, amplification
                 matrices, the numpy reference
    loops        the compiled loop shapes: row sweep, row blocks on threads, wavefront,
                 leapfrog, the per-row stage updates, host tuning
    model        the immutable lattice (``Model``), its ``State``, parameters' checks (schema),
                 boundaries, the driver and the absorbing layer's description, sources and
                 barriers
    storage      the one atomic file writer
    forces       the force terms' kernels: springs, the drive table, the driver, the absorbing
                 layer
"""

# first: numba's optimisation level, the kernels' cache key and numba's target, before any
# kernel is defined
from sim.runtime import optimisation as _optimisation  # noqa: I001, F401
from sim.runtime import kernel_cache as _kernel_cache  # noqa: F401
from sim.runtime.vector_width import WIDE_VECTORS
from sim import model, scenes, integrators  # the rooms whose main names are used as sim.ROOM.name
from sim.integrators.registry import INTEGRATORS, ORDERS, IntegratorError
from sim.model.lattice import Model, ModelError
from sim.theory.observables import Energy, StabilityLimit
from sim.scenes.building import Scene, SceneError
from sim.runtime.simulation import BlowUpError, Simulation
from sim.theory import exact  # registers the "exact" integrator for linear scenes
from sim.model.state import State

__all__ = [
    "WIDE_VECTORS", "INTEGRATORS", "ORDERS", "BlowUpError", "Energy", "IntegratorError", "Model",
    "ModelError", "Scene", "SceneError", "Simulation", "StabilityLimit", "State", "exact",
    "integrators", "model", "scenes",
]
