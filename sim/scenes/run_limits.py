"""The time-step limits the presets' own runs meet, measured, where large motion puts them below
the small-amplitude theory's.

``Simulation.stable_dt()`` is the limit of the lattice linearised about rest (its normal modes).
A run that sags under gravity or swings far stiffens its springs, so its fastest mode is faster
and the step at which the run stops (its blow-up rule, exit 3 of ``oscillators run``) can be well
below that: the catenary's velocity Verlet run stops at about two thirds of it.  For the presets
listed here, measured by bisection on the preset's own run over its whole duration (the run
looked at as ``oscillators run`` looks at it), the largest step that ran to the end is kept and
printed beside the theory's; it applies only to the preset as built (no parameter changed, the
same start).  Near that edge a run is sensitive to the last bits of its arithmetic (the size of
a step's rounding decides whether a burst of energy grows), so a step within about 1 % below it
may still stop.

Measured with (one command per preset)::

    oscillators stability PRESET --whole-run --integrators verlet rk4

Only the presets and integrators whose measured limit is more than 2 % below the theory's are
listed; elsewhere the theory's limit is the one printed (an undamped Runge-Kutta run can outlive
it a little: its instability grows too slowly to show within the run).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from sim.model.lattice import Model
from sim.scenes.building import Scene, build
from sim.scenes.presets import PRESETS

MEASURED: dict[tuple[str, str], float] = {
    ("single", "verlet"): 0.2300,     # theory 0.2390 (0.962 of it)
    ("single", "rk4"): 0.3306,        # theory 0.3381 (0.978)
    ("square", "verlet"): 0.1642,     # theory 0.1952 (0.841)
    ("grid", "verlet"): 0.1532,       # theory 0.1703 (0.900)
    ("ionic", "verlet"): 0.2100,      # theory 0.2148 (0.978)
    ("catenary", "verlet"): 0.05983,  # theory 0.09043 (0.662)
    ("catenary", "rk4"): 0.1976,      # theory 0.2365 (0.836)
    ("bandgap", "rk4"): 0.2901,       # theory 0.3024 (0.959)
}
"""(preset, integrator) -> the largest dt (s) at which the preset's own run ran to its end."""

MEASURE_COMMAND = "oscillators stability {preset} --whole-run --integrators {integrator}"
"""The command that measures an entry of ``MEASURED``."""


@functools.cache
def _preset(name: str) -> Scene:
    return build(name)


def same_model(first: Model, second: Model) -> bool:
    """Whether two models describe the same lattice (every field equal, arrays element-wise)."""
    for field in dataclasses.fields(Model):
        a, b = getattr(first, field.name), getattr(second, field.name)
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            if not np.array_equal(np.asarray(a), np.asarray(b)):
                return False
        elif a != b:
            return False
    return True


def run_limit(scene: Scene, model: Model, integrator: str) -> float | None:
    """The measured limit (s) of ``scene``'s own run with ``integrator`` when the scene is a
    listed preset as built, running ``model`` (the scene's model, or one set since); else None."""
    key = (scene.name, integrator)
    if key not in MEASURED or scene.name not in PRESETS:
        return None
    preset = _preset(scene.name)
    if not (same_model(model, preset.model)
            and np.array_equal(scene.initial_positions, preset.initial_positions)
            and np.array_equal(scene.initial_velocities, preset.initial_velocities)):
        return None
    return MEASURED[key]


def describe(scene_name: str, integrator: str, measured: float) -> str:
    """One sentence saying what the measured limit is and how to measure it again."""
    command = MEASURE_COMMAND.format(preset=scene_name, integrator=integrator)
    return (f"the {scene_name} preset's own run was measured to run to its end up to "
            f"dt = {measured:.4g} s (large motion lowers the limit; `{command}`)")
