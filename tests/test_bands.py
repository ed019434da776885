"""The band structure against independent physics: the eigenvalues of the hand-built stiffness
matrix of small lattices (tests/lattice_theory.py), the diatomic chain's band edges, the
elastic solid's P and S speeds, and velocity Verlet's frequency measured on a run."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.model.lattice import Model
from sim.scenes.presets import ionic_masses
from sim.theory import bands
from sim.theory.modes import excited_state
from tests.lattice_theory import stiffness_matrix

K, A = 35.0, 1.0


def hand_built_frequencies(model: Model, tension_over_spacing: float) -> np.ndarray:
    """Every normal-mode omega (rad/s) of ``model`` from the spring-by-spring stiffness matrix
    and its masses (independent of the code under test), rising."""
    matrix = stiffness_matrix(model.nx, model.ny, model.dim, model.stiffness, tension_over_spacing)
    masses = np.repeat(np.asarray(model.masses, dtype=float).ravel(), model.dim)
    scale = 1.0 / np.sqrt(masses)
    values = np.linalg.eigvalsh(matrix * np.outer(scale, scale))
    return np.sort(np.sqrt(np.maximum(values, 0.0)))


def band_values_at_sine_modes(model: Model) -> np.ndarray:
    """The bands at the wave vectors a lattice between fixed walls allows,
    q = (m pi / ((nx + 1) a), n pi / ((ny + 1) a)), every branch, rising."""
    structure = bands.BandStructure(model)
    qx = np.arange(1, model.nx + 1) * math.pi / ((model.nx + 1) * model.spacing)
    qy = np.arange(1, model.ny + 1) * math.pi / ((model.ny + 1) * model.spacing)
    grid_x, grid_y = np.meshgrid(qx, qy)
    return np.sort(structure.omegas(grid_x, grid_y).ravel())


@pytest.mark.parametrize(("dim", "rest_length"), [(2, 1.0), (2, 0.8), (3, 0.8)])
def test_equal_mass_bands_are_the_exact_modes_of_a_small_lattice(dim, rest_length):
    model = Model.create(nx=5, ny=4, dim=dim, spacing=A, stiffness=K, rest_length=rest_length,
                         mass=1.3)
    expected = hand_built_frequencies(model, K * (A - rest_length) / A)
    assert band_values_at_sine_modes(model) == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_ionic_bands_are_the_exact_modes_of_a_small_checkerboard():
    """Each mode appears twice in the bands: at q and at (pi/a - qx, pi/a - qy), where the
    coupling of the two sublattices only changes sign (nx, ny even: no q is its own partner)."""
    model = Model.create(nx=6, ny=4, spacing=A, stiffness=K, rest_length=0.8,
                         mass=ionic_masses(6, 4))
    assert bands.BandStructure(model).kind == "ionic"
    expected = hand_built_frequencies(model, K * 0.2)
    values = band_values_at_sine_modes(model)
    assert values[::2] == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert values[1::2] == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_the_ionic_chain_has_its_gap_between_the_textbook_band_edges():
    heavy, light = 4.0, 1.0
    model = Model.create(nx=20, ny=1, spacing=A, stiffness=K, mass=ionic_masses(20, 1, heavy, light))
    structure = bands.BandStructure(model)
    acoustic, optical = structure.omegas(math.pi / (2 * A), 0.0)[:2]
    assert acoustic == pytest.approx(math.sqrt(2 * K / heavy), rel=1e-12)
    assert optical == pytest.approx(math.sqrt(2 * K / light), rel=1e-12)
    top = structure.omegas(0.0, 0.0)[1]
    assert top == pytest.approx(math.sqrt(2 * K * (1 / heavy + 1 / light)), rel=1e-12)
    # no wave lives inside the gap anywhere along the chain's path
    path = structure.along_path(401)
    inside = (path.omega[:2] > math.sqrt(2 * K / heavy) + 1e-9) & \
        (path.omega[:2] < math.sqrt(2 * K / light) - 1e-9)
    assert not inside.any()


def test_group_velocity_is_the_closed_form_and_the_continuum_slope_is_the_wave_speed():
    model = Model.create(nx=8, ny=8, spacing=A, stiffness=K, rest_length=0.8)
    structure = bands.BandStructure(model)
    qx, qy = 1.1, 0.4
    velocities = structure.group_velocities(qx, qy)
    tension = K * 0.2
    for index, (kx, ky) in enumerate([(K, tension), (tension, K)]):
        omega = 2 * math.sqrt(kx * math.sin(qx * A / 2) ** 2 + ky * math.sin(qy * A / 2) ** 2)
        expected = (A * kx * math.sin(qx * A) / omega, A * ky * math.sin(qy * A) / omega)
        assert velocities[index] == pytest.approx(expected, rel=1e-7)
    # the pre-tensioned lattice's two speeds along x: sqrt(k/m) a and sqrt(T/(a m)) a
    assert structure.long_wave_speeds(0.0) == pytest.approx(
        [A * math.sqrt(K), A * math.sqrt(tension)], rel=1e-7)
    path = structure.along_path(101)
    near = path.distance < 0.05
    assert path.continuum[0, near] == pytest.approx(path.omega[0, near], rel=1e-3)


def test_diagonal_springs_have_the_elastic_p_and_s_speeds():
    """Isotropic solid k2 = k/2: P speed a sqrt(3k/2m), S speed a sqrt(k/2m) (Lame
    lambda = mu = k/2 per unit length, density m/a^2)."""
    model = Model.create(nx=8, ny=8, spacing=A, stiffness=K, diagonal_stiffness=K / 2)
    structure = bands.BandStructure(model)
    assert structure.names == ("S", "P")
    for angle in (0.0, 0.3, math.pi / 4):
        assert structure.long_wave_speeds(angle) == pytest.approx(
            [A * math.sqrt(K / 2), A * math.sqrt(1.5 * K)], rel=1e-6)
    wave = structure.wave("P", 1e-4, 0.0)
    assert wave["group_speed"] == pytest.approx(A * math.sqrt(1.5 * K), rel=1e-6)
    assert wave["phase_speed"] == pytest.approx(A * math.sqrt(1.5 * K), rel=1e-6)


def test_lattices_without_a_repeating_cell_are_refused():
    masses = np.ones((4, 5))
    masses[1, 2] = 3.0
    with pytest.raises(bands.BandError, match="repeating cell"):
        bands.BandStructure(Model.create(nx=5, ny=4, stiffness=K, mass=masses))


def test_verlet_numerical_frequency_from_its_matrix_is_the_closed_form():
    omega = np.linspace(0.0, 2.5, 26)
    found = bands.numerical_omegas("verlet", omega, 1.0)
    expected = bands.verlet_omega(omega, 1.0)
    inside = omega < 1.95  # at omega dt = 2 the double eigenvalue -1 is known to sqrt(eps) only
    assert found.omega_numerical[inside] == pytest.approx(expected[inside], rel=1e-9)
    assert list(found.stable) == list(omega <= 2.0 + 1e-12)


def test_verlet_runs_a_mode_at_its_numerical_frequency_near_the_limit():
    """One exact mode of a small linear lattice, run with velocity Verlet at dt = 0.9 * 2 / omega:
    its measured frequency is (2/dt) asin(omega dt / 2), 24 % above omega."""
    scene = sim.scenes.build("grid", nx=5, ny=4, linear=True)
    model = scene.model
    structure = bands.BandStructure(model)
    m, n = 5, 4
    qx, qy = m * math.pi / (6 * A), n * math.pi / (5 * A)
    omega = float(structure.omegas(qx, qy)[0])  # the x polarisation
    dt = 0.9 * 2.0 / omega
    simulation = sim.Simulation(scene, integrator="verlet", dt=dt)
    positions, velocities = excited_state(model, m, n, 0, 0.01 * model.spacing)
    simulation.positions[...] = positions
    simulation.velocities[...] = velocities
    particle = 2 * model.nx + 2
    rest = model.rest_positions[particle, 0]
    samples = [positions[particle, 0] - rest]
    for _ in range(1500):
        simulation.step(1)
        samples.append(simulation.positions[particle, 0] - rest)
    u = np.asarray(samples)
    crossings = np.flatnonzero(np.sign(u[1:]) != np.sign(u[:-1]))
    exact = crossings + u[crossings] / (u[crossings] - u[crossings + 1])  # interpolated (steps)
    period = 2 * (exact[-1] - exact[0]) / (len(exact) - 1) * dt
    measured = 2 * math.pi / period
    predicted = 2.0 / dt * math.asin(omega * dt / 2.0)
    assert measured == pytest.approx(predicted, rel=2e-3)
    assert abs(measured - omega) > 0.2 * omega
    from_matrix = bands.numerical_omegas("verlet", np.array([omega]), dt).omega_numerical[0]
    assert from_matrix == pytest.approx(predicted, rel=1e-9)


def test_density_of_states_counts_every_mode():
    model = Model.create(nx=6, ny=5, spacing=A, stiffness=K, rest_length=0.8)
    centres, density = bands.density_of_states(model, bins=12)
    width = centres[1] - centres[0]
    assert float(density.sum() * width) == pytest.approx(model.n_particles * model.dim)
    expected = hand_built_frequencies(model, K * 0.2)
    assert bands.mode_frequencies(model) == pytest.approx(expected, rel=1e-10, abs=1e-10)


def test_the_command_draws_a_scene_s_bands_and_refuses_chain_options(tmp_path, capsys):
    import json

    from PIL import Image

    from app.cli import main

    picture = tmp_path / "ionic.png"
    assert main(["dispersion", "ionic", "--integrator", "verlet", "--dt", "0.2", "--json",
                 "--plot", str(picture)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["branches"] == ["x acoustic", "x optical", "y acoustic", "y optical"]
    heavy, light = 4.0, 1.0
    assert data["gaps"][0]["low"] == pytest.approx(math.sqrt(2 * K / heavy))
    assert data["gaps"][0]["high"] == pytest.approx(math.sqrt(2 * K / light))
    top = math.sqrt(2 * K * (1 / heavy + 1 / light))
    assert data["highest_omega"] == pytest.approx(top, rel=1e-4)
    assert data["highest_omega_numerical"] == pytest.approx(
        float(bands.verlet_omega(data["highest_omega"], 0.2)), rel=1e-9)
    image = np.asarray(Image.open(picture).convert("L"))
    assert image.shape[0] > 300 and image.std() > 10  # a drawn picture, not a blank one
    assert main(["dispersion", "--dt", "0.1"]) == 2
    assert "applies to a SCENE" in capsys.readouterr().err
