"""Every preset builds and runs with its own integrator and step without a (false) blow-up."""

import numpy as np
import pytest

import sim

LONG_SMOKE = ("interference-open", "single-slit", "elastic-solid")
"""Presets whose 3000 steps take longest (a paper-sized lattice, absorbing layers on every wall,
the 160x160 solid's 20 s; its whole run is in ``test_accuracy_live``):
with the slow tests.  ``double-slit`` keeps the absorbing ripple tank in the default run."""


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.slow) if n in LONG_SMOKE else n
    for n in sim.scenes.names() if n != "interference"
])
def test_preset_builds_and_steps(name):
    simulation = sim.Simulation(sim.scenes.build(name))
    before = simulation.peek_positions()
    simulation.step(3000)  # 30 s or more of simulated time: catenary sags, membrane drums
    assert simulation.step_count == 3000
    assert np.isfinite(simulation.positions).all()
    assert simulation.peek_positions().shape == before.shape


def test_catenary_settles_under_gravity_without_a_false_alarm():
    simulation = sim.Simulation(sim.scenes.build("catenary"))
    simulation.step(6000)  # 60 s with the preset's Verlet and dt
    energy = simulation.energy()
    assert energy.kinetic < 1e-3 * abs(energy.potential)  # at rest in its sagged shape
    assert energy.gravity < -100  # it really fell
