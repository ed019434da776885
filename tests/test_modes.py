"""The normal-mode spectrum against theory: energies add up, stay put, and one mode is one mode.

Mode frequencies are checked against the spring-by-spring stiffness matrix
(``tests/lattice_theory.py``); the page's Modes folder is driven as a browser would.
"""

from __future__ import annotations

import numpy as np
import pytest

import sim
from sim.theory.modes import ModalBasis, excited_state, mode_energies, mode_frequency
from tests.helpers import wait_for
from tests.lattice_theory import stiffness_matrix


def total(energies: list[np.ndarray]) -> float:
    return float(sum(float(e.sum()) for e in energies))


@pytest.mark.parametrize("name, overrides", [
    ("grid", dict(linear=True, rest_length=0.8)),
    ("ionic", dict(linear=True, rest_length=0.9)),
    ("membrane", dict(linear=True)),
])
def test_mode_energies_add_up_to_the_energy_and_stay_constant(name, overrides):
    simulation = sim.Simulation(sim.scenes.build(name, **overrides), integrator="exact", dt=0.37)
    state = simulation.state
    before = mode_energies(simulation.model, state.particle_positions(),
                           state.particle_velocities())
    energy = simulation.energy()
    assert total(before) == pytest.approx(energy.kinetic + energy.spring, rel=1e-10)
    simulation.step(25)
    after = mode_energies(simulation.model, state.particle_positions(),
                          state.particle_velocities())
    for first, second in zip(before, after, strict=True):
        np.testing.assert_allclose(second, first, rtol=1e-8, atol=1e-12 * total(before))


def test_mode_frequencies_are_the_eigenvalues_of_the_hand_built_stiffness():
    model = sim.scenes.build("grid", nx=5, ny=4, rest_length=0.8, linear=True).model
    matrix = stiffness_matrix(model.nx, model.ny, 2, model.stiffness, model.tension_stiffness)
    expected = np.sort(np.sqrt(np.linalg.eigvalsh(matrix)))
    ours = np.sort([mode_frequency(model, m, n, c) for c in range(2)
                    for m in range(1, 6) for n in range(1, 5)])
    np.testing.assert_allclose(ours, expected, rtol=1e-12)


@pytest.mark.parametrize("m, n, polarisation", [(1, 1, 0), (3, 2, 1), (7, 5, 1)])
def test_exciting_a_mode_puts_all_the_energy_in_it(m, n, polarisation):
    model = sim.scenes.build("grid", linear=True, rest_length=0.8, gravity=9.81).model
    positions, velocities = excited_state(model, m, n, polarisation, 0.1)
    energies = mode_energies(model, positions, velocities)
    assert energies[polarisation][n - 1, m - 1] >= (1 - 1e-12) * total(energies)


def test_unequal_masses_use_eigenvectors_and_still_add_up():
    simulation = sim.Simulation(sim.scenes.build("ionic", linear=True))
    basis = ModalBasis.of(simulation.model)
    assert not basis.separable
    state = simulation.state
    energies = mode_energies(simulation.model, state.particle_positions(),
                             state.particle_velocities(), basis)
    energy = simulation.energy()
    assert total(energies) == pytest.approx(energy.kinetic + energy.spring, rel=1e-10)


@pytest.mark.slow  # a page with kernels of its own; the modes themselves are checked in the default run
def test_the_page_excites_a_mode_and_draws_the_spectrum(tmp_path):
    from app.web.app import WebApp
    from tests.helpers import free_port
    from tests.test_web_safety import press, send, settle

    app = WebApp(sim.Simulation(sim.scenes.build("grid", linear=True, rest_length=0.8)),
                 port=free_port(), scenes_dir=tmp_path, recordings_dir=tmp_path)
    app.start()
    try:
        spectrum = app.panel.spectrum
        send(spectrum.m, 4)
        send(spectrum.n, 2)
        send(spectrum.polarisation, "x")
        assert "mode (4, 2) x" in spectrum.frequency.content
        press(spectrum.excite_button)
        settle(app)
        state = app.runner.simulation.state
        energies = mode_energies(app.runner.simulation.model, state.particle_positions(),
                                 state.particle_velocities())
        assert energies[0][1, 3] >= (1 - 1e-12) * total(energies)
        assert wait_for(lambda: spectrum.picture.image.shape[0] > 100)
        send(spectrum.m, 10**6)
        assert "m must be" in spectrum.frequency.content
    finally:
        app.stop()
