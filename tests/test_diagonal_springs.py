"""The diagonal springs against physics: forces are minus the gradient of the energy, the
stiffness matrix is the forces' Jacobian, the modes of a torus are the dispersion relation, the
long waves travel at the Lame speeds, a run's measured P and S speeds match them, and every loop
shape computes what the one-thread sweep computes."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.forces.diagonal import numpy_energy, numpy_forces
from sim.integrators.registry import make_integrator
from sim.integrators.steppers import KernelArguments
from sim.loops import row_sweep
from sim.model.lattice import Model, ModelError
from sim.model.state import State
from sim.theory.lattice_waves import elastic_constants, in_plane_omegas
from sim.theory.modes import in_plane_stiffness
from sim.theory.observables import energy, highest_frequency, spring_energy

ENDS = {"fixed": "walls", "periodic": "ring", "free": "free"}


def _model(boundary="fixed", linear=False, dim=2, rest_length=0.8, **extra):
    return Model.create(5, 4, dim=dim, stiffness=3.0, rest_length=rest_length,
                        diagonal_stiffness=1.7, boundary=boundary, linear=linear, mass=1.3,
                        **extra)


def _displaced(model, scale=0.1, seed=1):
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)
    return rest + scale * np.random.default_rng(seed).standard_normal(rest.shape)


def _kernel_forces(model, positions):
    """Forces (N) on every particle from the compiled row sweep."""
    terms, parameters = KernelArguments.from_model(model)
    acceleration = np.zeros_like(positions)
    row_sweep.accelerations(terms, parameters, positions, np.zeros_like(positions), acceleration)
    return acceleration * model.masses


def _gradient(function, positions, step=1e-6):
    gradient = np.zeros_like(positions)
    for index in np.ndindex(positions.shape):
        up, down = positions.copy(), positions.copy()
        up[index] += step
        down[index] -= step
        gradient[index] = (function(up) - function(down)) / (2 * step)
    return gradient


@pytest.mark.parametrize("linear", [False, True])
@pytest.mark.parametrize("ends", ["walls", "ring", "free"])
def test_numpy_forces_are_minus_the_gradient_of_numpy_energy(ends, linear):
    positions = _displaced(_model(dim=3))
    arguments = (1.7, 1.0, (-2.0, -1.5), ends, linear)
    gradient = _gradient(lambda p: numpy_energy(p, *arguments), positions)
    assert np.abs(numpy_forces(positions, *arguments) + gradient).max() < 1e-7


@pytest.mark.parametrize("boundary, linear, dim", [
    ("fixed", False, 2), ("fixed", True, 2),
    pytest.param("periodic", False, 3, marks=pytest.mark.slow),
    pytest.param("periodic", True, 2, marks=pytest.mark.slow),
    pytest.param("free", False, 2, marks=pytest.mark.slow),
    pytest.param("free", True, 3, marks=pytest.mark.slow),
])
def test_kernel_forces_are_minus_the_gradient_of_the_energy(boundary, linear, dim):
    """The compiled forces against finite differences of the energy written in numpy (the
    nearest springs' ``spring_energy`` and the diagonal springs' ``numpy_energy``)."""
    rest_length = 1.0 if (boundary == "free" and linear) else 0.8  # no free-end tension term
    model = _model(boundary, linear, dim, rest_length)
    positions = _displaced(model)
    gradient = _gradient(lambda p: spring_energy(model, p), positions)
    assert np.abs(_kernel_forces(model, positions) + gradient).max() < 1e-7
    # and the compiled energy pass counts the same energy
    state = State.from_particle_arrays(model, positions.reshape(dim, -1).T,
                                       np.zeros((model.n_particles, dim)))
    assert energy(model, state).spring == pytest.approx(spring_energy(model, positions),
                                                        rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("boundary", ["fixed", pytest.param("periodic", marks=pytest.mark.slow),
                                      pytest.param("free", marks=pytest.mark.slow)])
def test_stiffness_matrix_is_the_jacobian_of_the_linearised_forces(boundary):
    model = _model(boundary, linear=True)
    rest = model.rest_positions.T.reshape(2, model.ny, model.nx).copy()
    at_rest = _kernel_forces(model, rest)
    jacobian = np.zeros((2 * model.n_particles, 2 * model.n_particles))
    for p in range(model.n_particles):
        for c in range(2):
            moved = rest.copy()
            moved[c, p // model.nx, p % model.nx] += 1.0
            jacobian[:, 2 * p + c] = (_kernel_forces(model, moved) - at_rest).transpose(
                1, 2, 0).reshape(-1)
    stiffness = in_plane_stiffness(model.nx, model.ny, model.stiffness,
                                   model.tension_stiffness, model.diagonal_stiffness,
                                   ENDS[boundary])
    assert np.abs(jacobian + stiffness).max() < 1e-12


def test_modes_of_a_torus_are_the_dispersion_relation():
    """Spring by spring, a 6x5 torus's modes are plane waves at q = 2 pi (p/6, r/5) / a with the
    two frequencies of the in-plane dynamical matrix."""
    model = Model.create(6, 5, stiffness=2.0, rest_length=0.9, diagonal_stiffness=0.7, mass=1.5)
    matrix = in_plane_stiffness(6, 5, 2.0, model.tension_stiffness, 0.7, "ring", row_ring=True)
    measured = np.sort(np.linalg.eigvalsh(matrix / 1.5))
    qx, qy = np.meshgrid(2 * np.pi * np.arange(6) / 6, 2 * np.pi * np.arange(5) / 5)
    lower, upper = in_plane_omegas(model, qx, qy)
    theory = np.sort(np.concatenate([lower.ravel(), upper.ravel()]) ** 2)
    assert np.abs(measured - theory).max() < 1e-12
    # without the diagonal springs a lattice at rest length has no shear stiffness at all
    assert in_plane_omegas(Model.create(6, 5, stiffness=2.0), 0.3, 0.0)[0] == 0.0


@pytest.mark.parametrize("angle", [0.0, 0.4, math.pi / 4, 1.1])
def test_long_waves_travel_at_the_lame_speeds_in_every_direction(angle):
    """k2 = k/2: lambda = mu = k2, P speed sqrt((lambda + 2 mu)/rho), S speed sqrt(mu/rho),
    whatever the direction (isotropy)."""
    k, mass, a = 35.0, 1.3, 0.5
    model = Model.create(4, 4, stiffness=k, diagonal_stiffness=k / 2, mass=mass, spacing=a)
    rho = mass / a**2
    lame = k / 2
    q = 1e-4 / a
    lower, upper = in_plane_omegas(model, q * math.cos(angle), q * math.sin(angle))
    assert upper / q == pytest.approx(math.sqrt((lame + 2 * lame) / rho), rel=1e-6)
    assert lower / q == pytest.approx(math.sqrt(lame / rho), rel=1e-6)
    constants = elastic_constants(model)
    assert constants["p_speed"] == pytest.approx(math.sqrt(3 * lame / rho), rel=1e-12)
    assert constants["s_speed"] == pytest.approx(math.sqrt(lame / rho), rel=1e-12)


def test_anisotropic_solid_long_waves_along_x_follow_c11_and_c44():
    k, k2 = 10.0, 1.0
    model = Model.create(4, 4, stiffness=k, diagonal_stiffness=k2)
    lower, upper = in_plane_omegas(model, 1e-5, 0.0)
    assert upper / 1e-5 == pytest.approx(math.sqrt(k + k2), rel=1e-6)  # C11 = k + k2
    assert lower / 1e-5 == pytest.approx(math.sqrt(k2), rel=1e-6)  # C44 = k2
    diagonal_lower, _ = in_plane_omegas(model, 1e-5 / math.sqrt(2), 1e-5 / math.sqrt(2))
    assert diagonal_lower / 1e-5 != pytest.approx(math.sqrt(k2), rel=1e-3)


@pytest.mark.parametrize("boundary", ["fixed", "free", "periodic"])
def test_stability_frequency_bounds_every_mode_closely(boundary):
    model = Model.create(12, 10, stiffness=3.0, rest_length=0.9, diagonal_stiffness=1.5,
                         boundary=boundary)
    matrix = in_plane_stiffness(12, 10, 3.0, model.tension_stiffness, 1.5, ENDS[boundary])
    highest = math.sqrt(np.linalg.eigvalsh(matrix).max())
    bound = highest_frequency(model)
    assert highest <= bound <= 1.03 * highest
    # the diagonal springs raise the highest frequency above the nearest springs' own
    assert bound > highest_frequency(model.replace(diagonal_stiffness=0.0)) * 1.1


def test_parameter_reaches_scenes_files_and_refusals(tmp_path):
    from sim.integrators.steppers import Verlet
    from sim.scenes import scene_files

    scene = sim.scenes.build("grid", diagonal_stiffness=2.5)
    assert scene.model.diagonal_stiffness == 2.5
    assert scene.model.kernel_parameters.diagonal_stiffness == 2.5
    assert sim.scenes.build("grid").model.kernel_parameters.diagonal_stiffness is None
    loaded = scene_files.load_file(scene_files.save(scene, tmp_path / "solid.toml"))
    assert loaded.model.diagonal_stiffness == 2.5
    assert Verlet.loop_family(scene.model) == "sweep"  # the fused leapfrog has none
    with pytest.raises(ModelError, match="diagonal_stiffness must be zero or positive"):
        sim.scenes.build("grid", diagonal_stiffness=-1.0)
    with pytest.raises(ModelError, match="absorbing layer has no diagonal springs"):
        sim.scenes.build("grid", diagonal_stiffness=1.0, boundary="absorbing")
    with pytest.raises(sim.IntegratorError, match="diagonal springs"):
        sim.Simulation(sim.scenes.build("grid", diagonal_stiffness=1.0, linear=True),
                       integrator="exact")


def _run(model, integrator, threads, steps=12, dt=0.01):
    positions = _displaced(model, 0.05, seed=3)
    velocities = 0.1 * np.random.default_rng(4).standard_normal(positions.shape)
    state = State.from_particle_arrays(model, positions.reshape(model.dim, -1).T,
                                       velocities.reshape(model.dim, -1).T)
    stepper = make_integrator(integrator, model, "float64", threads)
    stepper.advance(state, steps, dt)
    return state.positions.copy()


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["verlet", "rk4", "heun", "euler"])
@pytest.mark.parametrize("threads", [1, 2])
def test_every_loop_shape_agrees_with_the_numpy_reference(integrator, threads):
    """One-thread sweeps, row blocks on threads, and the RK wavefronts, nonlinear springs with
    diagonal ones, against the numpy reference integrators."""
    from sim.integrators import reference

    model = Model.create(7, 9, stiffness=3.0, rest_length=0.9, diagonal_stiffness=1.5)
    positions = _displaced(model, 0.05, seed=3)
    velocities = 0.1 * np.random.default_rng(4).standard_normal(positions.shape)
    expected, _ = reference.run(model, integrator, positions, velocities, 0.01, 12)
    assert np.abs(_run(model, integrator, threads) - expected).max() < 1e-12


@pytest.mark.slow
def test_measured_p_and_s_speeds_match_the_lame_speeds():
    from app.study.elastic import measure_speeds

    speeds = measure_speeds()
    assert abs(speeds["p_speed_relative_error"]) < 0.02
    assert abs(speeds["s_speed_relative_error"]) < 0.02


@pytest.mark.slow
def test_measured_branches_along_an_axis_follow_the_dispersion_relation():
    """Both in-plane branches of a strip of ring rows (q_x = 0), measured from a run's
    space-time spectrum, against the eigenvalues of the dynamical matrix."""
    from app.study.elastic import measure_branches

    branches = measure_branches(rows=100, duration=150.0)
    resolved = branches["q"] * 1.0 / math.pi > 0.05
    for name in ("p", "s"):
        error = branches[f"{name}_measured"][resolved] / branches[f"{name}_theory"][resolved] - 1
        assert np.abs(error).max() < 0.005


@pytest.mark.parametrize("linear", [False, True])
def test_the_drivers_energy_around_a_particle_changes_as_the_lattices_does(linear):
    """A prescribed move of one particle (the displacement driver) changes the energy around it
    by what it changes the whole lattice's elastic energy (numpy's sum over every spring),
    diagonal springs included."""
    from sim.forces.driver import local_energy

    model = Model.create(5, 4, stiffness=30.0, rest_length=0.8, diagonal_stiffness=12.0,
                         linear=linear)
    rest = model.rest_positions.T.reshape(2, 4, 5)
    before = rest + 0.05 * np.random.default_rng(3).standard_normal(rest.shape)
    after = before.copy()
    after[:, 2, 3] += (0.04, -0.03)
    still = np.zeros_like(before)

    def around(positions):
        return local_energy(positions, still, 2, 3, 1.0, linear, model.kernel_parameters)

    assert around(after) - around(before) == pytest.approx(
        spring_energy(model, after) - spring_energy(model, before), rel=1e-10)
