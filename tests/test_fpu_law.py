"""The FPU spring law k (s + alpha s^2 + beta s^3) against physics: the kernels' forces are minus
the gradient of their energy, a chain moving along itself is the FPU chain of the textbook
(written out here), a beta chain keeps its energy to Verlet's second order, and every loop shape,
thread count and precision computes what the numpy reference integrators compute."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from sim.integrators import reference
from sim.integrators.registry import make_integrator
from sim.integrators.steppers import KernelArguments
from sim.loops import row_sweep
from sim.model.lattice import Model, ModelError
from sim.model.state import State
from sim.theory.modes import ModalBasis
from sim.theory.observables import energy, spring_energy


def _kernel_forces(model, positions):
    terms, parameters = KernelArguments.from_model(model)
    acceleration = np.zeros_like(positions)
    row_sweep.accelerations(terms, parameters, positions, np.zeros_like(positions), acceleration)
    return acceleration * model.masses


def _compiled_energy(model, positions):
    state = State.from_particle_arrays(model, positions.reshape(model.dim, -1).T,
                                       np.zeros((model.n_particles, model.dim)))
    return energy(model, state).spring


def _displaced(model, scale, seed):
    rest = model.rest_positions.T.reshape(model.dim, model.ny, model.nx)
    return rest + scale * np.random.default_rng(seed).standard_normal(rest.shape)


@pytest.mark.parametrize("linear", [False, True])
def test_kernel_forces_are_minus_the_gradient_of_the_energy(linear):
    model = Model.create(5, 4, stiffness=3.0, rest_length=1.0 if linear else 0.9, linear=linear,
                         spring_alpha=0.3, spring_beta=2.0)
    positions = _displaced(model, 0.15, seed=2)
    step = 1e-6
    gradient = np.zeros_like(positions)
    for index in np.ndindex(positions.shape):
        up, down = positions.copy(), positions.copy()
        up[index] += step
        down[index] -= step
        gradient[index] = (_compiled_energy(model, up) - _compiled_energy(model, down)) / (2 * step)
    forces = _kernel_forces(model, positions)
    assert np.abs(forces + gradient).max() < 1e-6 * np.abs(forces).max()
    # the numpy twin's energy is the same number, and without alpha and beta it is Hooke's
    assert spring_energy(model, positions) == pytest.approx(_compiled_energy(model, positions),
                                                            rel=1e-12)
    hooke = model.replace(spring_alpha=0.0, spring_beta=0.0)
    assert abs(_compiled_energy(hooke, positions) - _compiled_energy(model, positions)) > 1e-3


@pytest.mark.parametrize("linear, rest_length", [(True, 1.0), (True, 0.8), (False, 0.8)])
def test_a_chain_moving_along_itself_is_the_fpu_chain(linear, rest_length):
    """F_n = F(s0 + s_n) - F(s0 + s_(n-1)), F(s) = k (s + alpha s^2 + beta s^3), s_n = u_(n+1) -
    u_n, fixed ends u_0 = u_(N+1) = 0, s0 = a - L the rest extension: the textbook equations
    (s0 = 0), written here apart from the product.  Along the chain both laws are this one; the
    energy from the rest lattice is sum W(s0 + s_n) - W(s0) with W' = F (the rest tension's
    work sums to zero between the walls).  Each particle's two springs to the walls above and
    below add their pull: F(|d| - L) u / |d|, |d| = sqrt(a^2 + u^2) (linearised: F(s0) u / a)."""
    n, alpha, beta, k = 8, 0.25, 1.5, 2.0
    model = Model.create(n, 1, stiffness=k, rest_length=rest_length, linear=linear,
                         spring_alpha=alpha, spring_beta=beta)
    u = 0.3 * np.random.default_rng(5).standard_normal(n)
    positions = model.rest_positions.T.reshape(2, 1, n).copy()
    positions[0, 0] += u
    s0 = 1.0 - rest_length
    s = np.diff(np.concatenate([[0.0], u, [0.0]])) + s0

    def law(s):
        return k * (s + alpha * s**2 + beta * s**3)

    def stored(s):
        return k * (s**2 / 2 + alpha * s**3 / 3 + beta * s**4 / 4)

    expected = law(s)[1:] - law(s)[:-1]
    walls = 2 * stored(np.sqrt(1 + u**2) - rest_length) - 2 * stored(s0)
    if linear:
        expected -= 2 * law(s0) * u
        walls = law(s0) * u**2
    else:
        expected -= 2 * law(np.sqrt(1 + u**2) - rest_length) * u / np.sqrt(1 + u**2)
    forces = _kernel_forces(model, positions)
    assert np.abs(forces[0, 0] - expected).max() < 1e-12
    assert np.abs(forces[1]).max() < 1e-12  # nothing pulls across the chain (round-off)
    assert _compiled_energy(model, positions) == pytest.approx(
        float(np.sum(stored(s) - stored(s0)) + np.sum(walls)), rel=1e-12)


def test_the_modes_of_a_pre_tensioned_fpu_chain_feel_the_law_at_its_rest_extension():
    """Small waves on springs stretched by s0 = a - L feel F'(s0) = k (1 + 2 alpha s0 +
    3 beta s0^2) along a spring and F(s0) / a across it.  A chain between walls on all four
    sides: x feels the first along the chain and the second from the springs to the walls above
    and below, omega_p^2 = (4 F'(s0) sin^2(p pi / (2 (N + 1))) + 2 F(s0) / a) / m; y the other
    way round.  A run of the lowest longitudinal mode at small amplitude swings with its
    period."""
    n, alpha, beta, k, m, s0 = 12, 0.5, 2.0, 3.0, 0.7, 0.4
    model = Model.create(n, 1, stiffness=k, rest_length=1.0 - s0, mass=m, spring_alpha=alpha,
                         spring_beta=beta)
    along = k * (1 + 2 * alpha * s0 + 3 * beta * s0**2)
    across = k * (s0 + alpha * s0**2 + beta * s0**3)
    sines = 4 * np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1))) ** 2
    basis = ModalBasis.of(model)
    longitudinal = (sines * along + 2 * across) / m
    assert np.sort(basis.omega_squared[0].ravel()) == pytest.approx(longitudinal, rel=1e-12)
    assert np.sort(basis.omega_squared[1].ravel()) == pytest.approx(
        (sines * across + 2 * along) / m, rel=1e-12)

    period = 2 * np.pi / np.sqrt(longitudinal[0])
    shape = 1e-4 * np.sin(np.arange(1, n + 1) * np.pi / (n + 1))
    positions = model.rest_positions.copy()
    positions[:, 0] += shape
    scene = sim.Scene("stretched FPU chain", model, initial_positions=positions)
    simulation = sim.Simulation(scene, integrator="rk4", dt=period / 400)
    middle = n // 2
    swing = []
    for _ in range(401):
        swing.append(simulation.state.particle_positions()[middle, 0]
                     - model.rest_positions[middle, 0])
        simulation.step(1)
    swing = np.array(swing)
    assert swing[200] == pytest.approx(-swing[0], rel=1e-3)  # half a period: the other way
    assert swing[400] == pytest.approx(swing[0], rel=1e-3)  # a whole one: back


def _energy_drift(dt: float) -> float:
    model = Model.create(16, 1, linear=True, spring_beta=1.0)
    shape = np.c_[np.sin(np.pi * np.arange(1, 17) / 17), np.zeros(16)]
    scene = sim.scenes.Scene("beta", model, integrator="verlet", dt=dt,
                             initial_positions=model.rest_positions + shape)
    simulation = sim.Simulation(scene, integrator="verlet", dt=dt)
    start = simulation.energy().total
    worst = 0.0
    for _ in range(40):
        simulation.step(round(1.0 / dt))
        worst = max(worst, abs(simulation.energy().total - start))
    return worst / start


def test_a_beta_chain_keeps_its_energy_to_verlets_order():
    coarse, fine = _energy_drift(0.1), _energy_drift(0.05)
    assert coarse < 1e-2
    assert 3.5 < coarse / fine < 4.5, (coarse, fine)


def _run(model, integrator, threads, precision="float64", steps=12, dt=0.01):
    positions = _displaced(model, 0.05, seed=3)
    velocities = 0.1 * np.random.default_rng(4).standard_normal(positions.shape)
    state = State.from_particle_arrays(model, positions.reshape(model.dim, -1).T,
                                       velocities.reshape(model.dim, -1).T, precision)
    stepper = make_integrator(integrator, model, precision, threads)
    stepper.advance(state, steps, dt)
    expected, _ = reference.run(model, integrator, positions, velocities, dt, steps)
    return np.abs(state.positions - expected).max()


def test_the_fused_leapfrog_carries_the_fpu_law():
    model = Model.create(7, 9, stiffness=3.0, rest_length=0.9, spring_alpha=0.4,
                         spring_beta=1.0)
    make = make_integrator("verlet", model, "float64", 1)
    assert make.loop_family(model) == "leapfrog"
    assert _run(model, "verlet", 1) < 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["verlet", "rk4", "heun", "euler"])
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("extras", [
    {}, {"gravity": 2.0, "damping": 0.3}, {"diagonal_stiffness": 1.5},
    {"linear": True, "rest_length": 1.0, "drag": 0.2}])
def test_every_loop_shape_agrees_with_the_numpy_reference(integrator, threads, precision,
                                                          extras):
    model = Model.create(7, 9, stiffness=3.0, **{"rest_length": 0.9, **extras},
                         spring_alpha=0.4, spring_beta=1.0)
    tolerance = 1e-12 if precision == "float64" else 2e-5
    assert _run(model, integrator, threads, precision) < tolerance


def test_the_law_is_checked_and_named():
    with pytest.raises(ModelError, match="spring_alpha must be a number"):
        Model.create(3, 1, spring_alpha="big")
    model = sim.scenes.build("chain", spring_alpha=0.25)
    assert "FPU spring law α=0.25" in model.model.describe()
