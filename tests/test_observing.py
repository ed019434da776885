"""Observing a simulation never changes it: reading positions, velocities, energies and other
observables between single steps gives bit for bit the trajectory of stepping without looking,
for every registered integrator on a lattice with dashpots, drag, gravity and a driver."""

from __future__ import annotations

import numpy as np
import pytest

import sim

STEPS = 150


def _scene(driven: bool = True) -> sim.Scene:
    driver = dict(column=0, row=1, direction="y", amplitude=0.05, frequency=0.3, kind="force",
                  ramp=0.5)
    return sim.scenes.build(
        "grid", nx=6, ny=4, damping=0.5, drag=0.05, gravity=9.81, dt=0.02,
        **(dict(driver=driver) if driven else {}),
    )


def _look(simulation: sim.Simulation) -> None:
    """Everything a viewer, recorder or probe reads."""
    seen = [simulation.positions.sum(), simulation.velocities.sum()]
    assert all(np.isfinite(seen))
    simulation.energy()
    simulation.energy_balance_error()
    simulation.energy_scale()
    simulation.strains()
    simulation.peek_positions()
    simulation.stable_dt()


@pytest.mark.parametrize("driven", [True, False], ids=["driven", "free"])
@pytest.mark.parametrize("integrator", [
    name if name in ("verlet", "rk4") else pytest.param(name, marks=pytest.mark.slow)
    for name in sim.integrators.names(_scene().model)])
def test_observing_between_steps_changes_nothing(integrator: str, driven: bool) -> None:
    scene = _scene(driven)
    looked = sim.Simulation(scene, integrator=integrator)
    unobserved = sim.Simulation(scene, integrator=integrator)
    together = sim.Simulation(scene, integrator=integrator)
    for _ in range(STEPS):
        _look(looked)
        looked.step(1)
        unobserved.step(1)
    _look(looked)
    together.step(STEPS)
    # looking is free: bit for bit the run nobody looked at
    assert np.array_equal(looked.state.positions, unobserved.state.positions), "trajectory moved"
    assert np.array_equal(looked.state.velocities, unobserved.state.velocities)
    for other in (unobserved, together):
        assert looked.time == other.time and looked.step_count == other.step_count
    # step(n) is the same steps; a drive's in-step terms are summed in another order there
    if driven:
        assert np.allclose(looked.state.positions, together.state.positions, rtol=0, atol=1e-12)
        assert np.allclose(looked.state.velocities, together.state.velocities, rtol=0, atol=1e-12)
    else:
        assert np.array_equal(looked.state.positions, together.state.positions)
        assert np.array_equal(looked.state.velocities, together.state.velocities)
    # the energy account is the same sum, grouped differently by step(n): equal to round-off
    assert looked.state.dissipated == unobserved.state.dissipated
    assert looked.energy_balance_error() == unobserved.energy_balance_error()
    assert looked.state.dissipated == pytest.approx(together.state.dissipated, rel=1e-12)
    # the lattice really moved, so a perturbation would have shown
    assert np.abs(looked.positions - scene.initial_positions).max() > 1e-3


def test_writing_through_a_view_is_still_an_edit() -> None:
    """A view that is written into moves the particle, and the energy account starts again."""
    simulation = sim.Simulation(sim.scenes.build("chain"), dt=0.01)
    simulation.step(10)
    before = simulation.energy().total
    simulation.positions[2, 1] += 0.1
    assert simulation.energy().total > before
    assert simulation.energy_balance_error() == 0.0
    simulation.step(10)
    assert abs(simulation.energy_balance_error()) < 1e-3
