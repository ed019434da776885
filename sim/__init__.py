"""coupled-oscillators simulation core: a lattice of point masses joined by springs.

The physics knows nothing of any viewer.  Main entry points::

    import sim
    sim.scenes.names()                      # the presets (``sim.presets``)
    scene = sim.scenes.build("grid", nx=20) # a preset with overrides
    sim.scene_files.save(scene, "grid.toml"); sim.scene_files.load("grid.toml")
    s = sim.Simulation(scene, integrator="rk4", dt=0.01)
    s.step(100); s.energy(); s.strains(); s.stable_dt()

Modules: ``model`` (immutable lattice description), ``state`` (positions, velocities, time),
``kernels`` and ``stepping`` (numba code), ``integrators``, ``observables``, ``simulation``,
``presets`` (the named configurations as data), ``scenes`` (a scene and building one from a
preset), ``scene_files`` (TOML scene files), ``boundaries`` (the boundary registry),
``forcing`` (a driver and absorbing walls), ``modes`` (normal modes), ``probes`` (particle time
series and spectra), ``exact`` (the normal-mode solver for linear scenes), ``prediction``
(errors predicted before running), ``reference`` (plain numpy integrators, a test oracle),
``runner`` (the loop that viewers and recorders subscribe to).
"""

# first: the kernels' cache key and numba's target, before any kernel is defined
from sim import _kernel_cache  # noqa: I001, F401
from sim._vector_width import WIDE_VECTORS
from sim import boundaries, presets, scene_files, scenes
from sim.integrators import INTEGRATORS, ORDERS, IntegratorError
from sim.model import Model, ModelError
from sim.observables import Energy, StabilityLimit
from sim.scenes import Scene, SceneError
from sim.simulation import BlowUpError, Simulation
from sim import exact  # registers the "exact" integrator for linear scenes
from sim import forcing, modes, probes
from sim.state import State

__all__ = [
    "WIDE_VECTORS", "INTEGRATORS", "ORDERS", "BlowUpError", "Energy", "IntegratorError", "Model",
    "ModelError", "Scene", "SceneError", "Simulation", "StabilityLimit", "State", "boundaries",
    "exact", "forcing", "modes", "presets", "probes", "scene_files", "scenes",
]
