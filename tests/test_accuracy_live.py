"""Accuracy you can see: the energy-balance error, the predicted error and the exact integrator,
each against theory.

* A single particle on linearised springs is one oscillator per direction with omega^2 = K/m
  (K = 2k + 2T/a): explicit Euler multiplies its energy by 1 + (omega dt)^2 per step, Heun by
  1 + (omega dt)^4/4, RK4 by |1 - x^2/2 + x^4/24 + i(x - x^3/6)|^2 (x = omega dt).
* The prediction is checked against measured runs on linear scenes.
* The exact integrator is checked against an independent normal-mode solution assembled spring by
  spring (``tests/lattice_theory.py``), and against a damped state-space solution.
"""

from __future__ import annotations

import numpy as np
import pytest

import sim
from sim.theory.prediction import predictor_for
from tests.lattice_theory import exact_linear_motion, stiffness_matrix


def single_particle(integrator: str, dt: float) -> tuple[sim.Simulation, float]:
    simulation = sim.Simulation(sim.scenes.build("single", linear=True), integrator=integrator,
                                dt=dt)
    model = simulation.model
    omega = np.sqrt((2 * model.stiffness + 2 * model.tension_stiffness) / model.masses.flat[0])
    return simulation, float(omega)


def test_balance_error_is_zero_at_the_start_and_after_a_reset():
    simulation = sim.Simulation(sim.scenes.build("grid"))
    assert simulation.energy_balance_error() == 0.0
    simulation.step(50)
    assert simulation.energy_balance_error() != 0.0
    simulation.reset()
    assert simulation.energy_balance_error() == 0.0


def test_one_euler_step_changes_the_balance_by_omega_dt_squared():
    """Hand computation: from rest at u0, one Euler step leaves u0 and gives v = -omega^2 u0 dt,
    so the energy grows by 1/2 m omega^4 u0^2 dt^2 on top of 1/2 m omega^2 u0^2."""
    simulation, omega = single_particle("euler", 0.01)
    simulation.step(1)
    assert simulation.energy_balance_error() == pytest.approx((omega * 0.01) ** 2, rel=1e-12)


@pytest.mark.parametrize("integrator, growth", [
    ("euler", lambda x: 1 + x**2),
    ("heun", lambda x: 1 + x**4 / 4),
    ("rk4", lambda x: (1 - x**2 / 2 + x**4 / 24) ** 2 + (x - x**3 / 6) ** 2),
])
def test_energy_changes_per_step_as_the_amplification_factor_says(integrator, growth):
    dt, steps = 0.02, 100  # Euler's energy grows 16-fold: short of a blow-up (100-fold)
    simulation, omega = single_particle(integrator, dt)
    simulation.step(steps)
    expected = growth(omega * dt) ** steps - 1
    assert simulation.energy_balance_error() == pytest.approx(expected, rel=1e-9)


def test_verlet_energy_error_stays_bounded_by_its_modified_energy():
    """Velocity Verlet conserves a modified energy: the true energy oscillates within
    (omega dt)^2 / (4 - (omega dt)^2) of it, at any time."""
    dt = 0.05
    simulation, omega = single_particle("verlet", dt)
    x = omega * dt
    bound = x**2 / (4 - x**2)
    worst = 0.0
    for _ in range(400):
        simulation.step(5)
        worst = max(worst, abs(simulation.energy_balance_error()))
    assert 0.1 * bound < worst <= bound * (1 + 1e-9)


def test_a_scene_at_rest_under_gravity_measures_against_the_energy_of_its_fall():
    simulation = sim.Simulation(sim.scenes.build("catenary"))
    assert simulation.energy().kinetic == 0.0
    # the linearised sag releases 1/2 f.K^-1 f: checked with the spring-by-spring matrix
    model = simulation.model
    matrix = stiffness_matrix(model.nx, model.ny, 2, model.stiffness, model.tension_stiffness)
    force = np.zeros(model.n_particles * 2)
    force[1::2] = model.masses.ravel() * model.gravity[1]
    assert simulation.energy_scale() == pytest.approx(0.5 * force @ np.linalg.solve(matrix, force),
                                                      rel=1e-10)


# --- prediction -----------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["grid", "chain", "ionic"])
@pytest.mark.parametrize("integrator", ["euler", "heun", "verlet", "rk4"])
def test_prediction_matches_the_measured_error_on_linear_scenes(name, integrator):
    scene = sim.scenes.build(name, linear=True)
    dt = {"euler": 0.0025, "heun": 0.005, "verlet": 0.02, "rk4": 0.05}[integrator]
    simulation = sim.Simulation(scene, integrator=integrator, dt=dt)
    prediction = predictor_for(simulation).predict(integrator, dt, 10.0)
    simulation.step(prediction.steps)
    measured = simulation.energy_balance_error()
    assert abs(measured) > 1e-9  # there is an error to predict
    assert prediction.energy_error == pytest.approx(measured, rel=0.10)


# --- presets ----------------------------------------------------------------------------------------


LONGEST_SMALL_RUNS = ("membrane", "catenary", "two-sources", "single-slit", "double-slit",
                      "bandgap", "elastic-solid")
"""Smaller presets whose whole run takes the longest (3-D with its own kernels; gravity with
dashpots over many steps; the absorbing walls of the ripple tanks and the band-gap chain, 40-60 s
each; the diagonal springs' own kernels, whose physics ``test_diagonal_springs`` checks): with the
slow tests, like the paper-sized ones."""


def _presets_large_ones_slow() -> list:
    """Every preset; the paper-sized ones (over 100,000 particles) and the longest small runs
    are with the slow tests."""
    return [
        pytest.param(name, marks=pytest.mark.slow)
        if _particles(name) > 100_000 or name in LONGEST_SMALL_RUNS else name
        for name in sim.scenes.names()
    ]


def _particles(name: str) -> int:
    parameters = sim.scenes.presets.PRESETS[name].parameters
    return int(parameters.get("nx", 1)) * int(parameters.get("ny", 1))


@pytest.mark.parametrize("name", _presets_large_ones_slow())
def test_every_preset_keeps_its_energy_balance_within_one_percent(name):
    scene = sim.scenes.build(name)
    simulation = sim.Simulation(scene)
    simulation.step(int(round(scene.duration / scene.dt)))
    assert abs(simulation.energy_balance_error()) <= 0.01


# --- the exact integrator --------------------------------------------------------------------------


def exact_reference(model: sim.Model, positions: np.ndarray, velocities: np.ndarray,
                    time: float) -> tuple[np.ndarray, np.ndarray]:
    """The independent solution: undamped by normal modes of the hand-built K; damped by the
    eigen-decomposition of the first-order system (uniform drag, equal masses)."""
    n, dim = model.n_particles, model.dim
    matrix = stiffness_matrix(model.nx, model.ny, dim, model.stiffness, model.tension_stiffness)
    masses = np.repeat(model.masses.ravel(), dim)
    u0 = (positions - model.rest_positions).ravel()
    v0 = velocities.ravel()
    if model.drag == 0.0:
        u, v = exact_linear_motion(matrix, masses, u0, v0, time)
    else:
        system = np.zeros((2 * n * dim, 2 * n * dim))
        system[: n * dim, n * dim :] = np.eye(n * dim)
        system[n * dim :, : n * dim] = -matrix / masses[:, None]
        system[n * dim :, n * dim :] = -np.eye(n * dim) * model.drag / masses[:, None]
        values, vectors = np.linalg.eig(system)
        z = vectors @ (np.exp(values * time) * np.linalg.solve(vectors, np.concatenate([u0, v0])))
        u, v = z.real[: n * dim], z.real[n * dim :]
    return model.rest_positions + u.reshape(n, dim), v.reshape(n, dim)


@pytest.mark.parametrize("masses", ["equal", "unequal"])
@pytest.mark.parametrize("drag", [0.0, 0.3])
def test_exact_matches_an_independent_normal_mode_solution(masses, drag):
    if masses == "unequal" and drag:
        pytest.skip("uniform drag is not diagonal in the modes of unequal masses (refused)")
    overrides = dict(nx=6, ny=4, linear=True, drag=drag, rest_length=0.8)
    if masses == "unequal":
        overrides["mass"] = np.random.default_rng(3).uniform(0.5, 3.0, (4, 6))
    scene = sim.scenes.build("grid", **overrides)
    rng = np.random.default_rng(7)
    positions = scene.model.rest_positions + rng.normal(0, 0.05, scene.initial_positions.shape)
    velocities = rng.normal(0, 0.1, positions.shape)
    scene = sim.Scene(name="t", model=scene.model, initial_positions=positions,
                      initial_velocities=velocities, integrator="exact", dt=0.1)
    for time in (0.1, 10.0, 1000.0):
        simulation = sim.Simulation(scene, integrator="exact", dt=time / 4)
        simulation.step(4)
        want_positions, want_velocities = exact_reference(scene.model, positions, velocities, time)
        np.testing.assert_allclose(simulation.state.particle_positions(), want_positions,
                                   rtol=0, atol=1e-10)
        np.testing.assert_allclose(simulation.state.particle_velocities(), want_velocities,
                                   rtol=0, atol=1e-10)
        assert abs(simulation.energy_balance_error()) < 1e-10


def test_exact_closes_the_energy_balance_with_dashpots_and_gravity():
    scene = sim.scenes.build("catenary", linear=True)
    simulation = sim.Simulation(scene, integrator="exact", dt=5.0)
    simulation.step(200)  # 1000 s: the slowest mode (rate c lambda_min / m) has died out
    assert simulation.energy().dissipated > 0.5 * simulation.energy_scale()
    assert abs(simulation.energy_balance_error()) < 1e-12
    # settled: the static sag of the hand-built K u = m g
    model = simulation.model
    matrix = stiffness_matrix(model.nx, model.ny, 2, model.stiffness, model.tension_stiffness)
    force = np.zeros(model.n_particles * 2)
    force[1::2] = model.masses.ravel() * model.gravity[1]
    sag = np.linalg.solve(matrix, force).reshape(-1, 2)
    np.testing.assert_allclose(simulation.state.particle_positions(),
                               model.rest_positions + sag, atol=1e-8)


def test_exact_refuses_what_it_cannot_solve_and_says_why():
    with pytest.raises(sim.IntegratorError, match="linear=true"):
        sim.Simulation(sim.scenes.build("grid"), integrator="exact")
    unequal_damped = sim.scenes.build("ionic", linear=True, damping=0.5)
    with pytest.raises(sim.IntegratorError, match="damping"):
        sim.Simulation(unequal_damped, integrator="exact")


def test_exact_follows_a_displaced_particle_mid_run():
    scene = sim.scenes.build("grid", nx=5, ny=3, linear=True)
    simulation = sim.Simulation(scene, integrator="exact", dt=0.1)
    simulation.step(10)
    simulation.positions[7] += (0.1, 0.0)  # a drag in the page: the solution restarts from here
    moved = simulation.state.particle_positions().copy()
    velocities = simulation.state.particle_velocities().copy()
    simulation.step(10)
    want, _ = exact_reference(scene.model, moved, velocities, 1.0)
    np.testing.assert_allclose(simulation.state.particle_positions(), want, atol=1e-10)


@pytest.mark.slow
def test_exact_interference_agrees_with_fine_rk4_to_its_error():
    scene = sim.scenes.build("interference", linear=True)
    exact = sim.Simulation(scene, integrator="exact", dt=150.0)
    exact.step(1)
    fine = sim.Simulation(scene, integrator="rk4", dt=0.005)
    fine.step(30_000)
    coarse = sim.Simulation(scene, integrator="rk4", dt=0.01)
    coarse.step(15_000)
    difference = np.abs(fine.positions - exact.positions).max()
    rk4_error = np.abs(coarse.positions - fine.positions).max() / 15  # Richardson, order 4
    assert difference <= 2 * rk4_error + 1e-12


@pytest.mark.slow  # kernels of their own
def test_accuracy_command_writes_its_picture_by_default_and_says_where(tmp_path, monkeypatch,
                                                                       capsys):
    from app.cli import main

    monkeypatch.chdir(tmp_path)
    status = main(["accuracy", "single", "--set", "linear=true", "--integrators", "rk4",
                   "--dts", "0.02", "--until", "1", "--quiet"])
    assert status == 0
    picture = tmp_path / "pictures" / "single-work-precision.png"  # never the current folder
    assert picture.stat().st_size > 10_000
    assert not list(tmp_path.glob("*.png"))
    assert str(picture.relative_to(tmp_path)) in capsys.readouterr().out


def test_run_reports_the_energy_balance_error(capsys):
    import json

    from app.cli import main

    assert main(["run", "single", "--set", "linear=true", "--integrator", "euler", "--dt", "0.02",
                 "--steps", "100", "--quiet", "--json"]) == 0
    output = capsys.readouterr().out
    summary = json.loads(output[output.index("{"):])
    simulation, omega = single_particle("euler", 0.02)
    assert summary["energy_balance_error"] == pytest.approx((1 + (omega * 0.02) ** 2) ** 100 - 1,
                                                             rel=1e-9)
