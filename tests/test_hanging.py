"""A lattice under gravity hangs between its walls only if its springs' rest tension carries
the weight on their ends; otherwise it folds through its bottom wall, and the page says so with
advice that a run verifies."""

from __future__ import annotations

import numpy as np

import sim
from sim.theory.hanging import hanging_problem
from tests.helpers import wait_for
from tests.test_web_safety import PageClient, send, settle


def _hangs(scene: sim.Scene, seconds: float = 30.0) -> bool:
    """The rows stay in order and the bottom row above the bottom wall after ``seconds``."""
    simulation = sim.Simulation(scene)
    simulation.step(round(seconds / simulation.dt))
    model = simulation.model
    y = simulation.state.particle_positions()[:, 1].reshape(model.ny, model.nx)
    wall = model.origin[1] - model.spacing
    return bool(np.all(np.diff(y, axis=0) > 0) and y[0].min() > wall)


def test_the_grid_under_gravity_folds_and_the_advice_makes_it_hang():
    folding = sim.scenes.build("grid", gravity=9.81, damping=2.0)
    problem = hanging_problem(folding.model)
    assert problem is not None and "39.2 N" in problem and "k = 100 N/m" in problem
    assert not _hangs(folding)
    advised = sim.scenes.build("grid", gravity=9.81, damping=2.0, stiffness=100.0,
                               rest_length=0.5)
    assert hanging_problem(advised.model) is None
    assert _hangs(advised)


def test_the_page_says_why_the_lattice_falls(web_app):
    physics = web_app.panel.physics
    assert not physics.hanging.visible
    send(physics.gravity_on, True, PageClient())
    settle(web_app)
    assert wait_for(lambda: physics.hanging.visible)
    assert "folds through its wall" in physics.hanging.content
