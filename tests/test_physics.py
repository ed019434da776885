"""The simulation against physics: analytic frequencies, normal modes, convergence orders,
stability limits, static sag and the energy balance.  Theory comes from closed forms or from
``tests/lattice_theory.py`` (a stiffness matrix assembled by hand), never from the code's output."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.model.lattice import Model
from tests.lattice_theory import exact_linear_motion, stiffness_matrix

K = 35.0  # N/m, the paper's default stiffness


def upward_crossings(times: np.ndarray, signal: np.ndarray) -> np.ndarray:
    """Times where the signal crosses zero going up, by linear interpolation."""
    index = np.flatnonzero((signal[:-1] < 0) & (signal[1:] >= 0))
    fraction = -signal[index] / (signal[index + 1] - signal[index])
    return times[index] + fraction * (times[index + 1] - times[index])


def measured_period(simulation: sim.Simulation, particle: int, axis: int, duration: float) -> float:
    rest = simulation.rest_positions[particle, axis]
    steps = int(round(duration / simulation.dt))
    times = np.empty(steps + 1)
    signal = np.empty(steps + 1)
    for n in range(steps + 1):
        times[n] = simulation.time
        signal[n] = simulation.state.particle_positions()[particle, axis] - rest
        simulation.step(1)
    crossings = upward_crossings(times, signal)
    assert crossings.size >= 3, "not enough oscillations to measure a period"
    return float(np.mean(np.diff(crossings)))


# --- frequencies ---------------------------------------------------------------------------------


@pytest.mark.parametrize("mass", [1.0, 2.5])
def test_single_particle_period_unstressed(mass):
    scene = sim.scenes.build("single", mass=mass).with_displacement(0, (-0.3, -0.2))
    # start from a small displacement along x only
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.002)
    simulation.positions[0] = simulation.rest_positions[0] + (1e-4, 0.0)
    period = measured_period(simulation, 0, 0, duration=4.0)
    expected = 2 * math.pi / math.sqrt(2 * K / mass)
    assert period == pytest.approx(expected, rel=1e-5)


def test_single_particle_transverse_frequency_with_pretension():
    # L = 0.8 a: tension T = k (a - L); across a spring the stiffness is T / a, so along x the
    # particle feels 2k from the horizontal springs and 2T/a from the vertical ones.
    spacing, rest_length, mass = 1.0, 0.8, 1.0
    simulation = sim.Simulation(
        sim.scenes.build("single", rest_length=rest_length), integrator="rk4", dt=0.002
    )
    simulation.positions[0] = (0.0, 1e-4)
    tension = K * (spacing - rest_length)
    expected = 2 * math.pi / math.sqrt((2 * K + 2 * tension / spacing) / mass)
    assert measured_period(simulation, 0, 1, duration=3.0) == pytest.approx(expected, rel=1e-5)


@pytest.mark.parametrize("linear", [True, False])
@pytest.mark.parametrize("mode", [1, 2, 3, 4, 5])
def test_chain_normal_modes_keep_shape_and_frequency(mode, linear):
    count, mass = 5, 1.0
    amplitude = 1e-5 if not linear else 0.1
    simulation = sim.Simulation(
        sim.scenes.build("chain", linear=linear), integrator="rk4", dt=0.001
    )
    j = np.arange(1, count + 1)
    shape = np.sin(mode * math.pi * j / (count + 1))
    rest = simulation.rest_positions.copy()
    simulation.positions[:, 0] = rest[:, 0] + amplitude * shape
    simulation.velocities[...] = 0.0
    omega = 2 * math.sqrt(K / mass) * math.sin(mode * math.pi / (2 * (count + 1)))
    for time in (0.37, 1.0, 2.5):
        simulation.step(int(round((time - simulation.time) / simulation.dt)))
        displacement = simulation.state.particle_positions()[:, 0] - rest[:, 0]
        expected = amplitude * shape * math.cos(omega * simulation.time)
        tolerance = 1e-7 * amplitude if linear else 1e-3 * amplitude
        np.testing.assert_allclose(displacement, expected, atol=tolerance)
        transverse = simulation.state.particle_positions()[:, 1] - rest[:, 1]
        assert np.abs(transverse).max() < 1e-12


@pytest.mark.slow  # 3-D Runge-Kutta kernels of its own (3-D steps are checked by default)
def test_membrane_drum_mode_frequency():
    nx, ny, rest_length, mass = 8, 6, 0.9, 1.0
    scene = sim.scenes.build("membrane", nx=nx, ny=ny, rest_length=rest_length, linear=True)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.005)
    i = np.arange(nx)
    j = np.arange(ny)
    shape = np.outer(np.sin(math.pi * (j + 1) / (ny + 1)), np.sin(math.pi * (i + 1) / (nx + 1)))
    simulation.positions[:, :2] = simulation.rest_positions[:, :2]
    simulation.positions[:, 2] = 0.05 * shape.ravel()
    simulation.velocities[...] = 0.0
    tension_over_spacing = K * (1.0 - rest_length) / 1.0
    omega = math.sqrt(
        tension_over_spacing / mass
        * (4 * math.sin(math.pi / (2 * (nx + 1))) ** 2 + 4 * math.sin(math.pi / (2 * (ny + 1))) ** 2)
    )
    simulation.step(400)
    expected = 0.05 * shape.ravel() * math.cos(omega * simulation.time)
    np.testing.assert_allclose(simulation.positions[:, 2], expected, atol=1e-8)


# --- convergence -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "integrator, steps",
    [("euler", (0.0005, 0.00025)), ("heun", (0.01, 0.005)), ("verlet", (0.01, 0.005)),
     ("rk4", (0.04, 0.02)), ("ralston3", (0.02, 0.01))],
)
def test_observed_order_of_convergence(integrator, steps):
    nx, ny, final_time = 5, 1, 1.0
    scene = sim.scenes.build("chain", linear=True)
    rng = np.random.default_rng(7)
    displacement0 = 0.1 * rng.standard_normal((nx * ny, 2))
    velocity0 = 0.1 * rng.standard_normal((nx * ny, 2))
    matrix = stiffness_matrix(nx, ny, 2, K, 0.0)
    exact, _ = exact_linear_motion(
        matrix, np.ones(nx * ny * 2), displacement0.ravel(), velocity0.ravel(), final_time
    )
    errors = []
    for dt in steps:
        simulation = sim.Simulation(scene, integrator=integrator, dt=dt)
        simulation.positions = simulation.rest_positions + displacement0
        simulation.velocities = velocity0
        simulation.step(int(round(final_time / dt)))
        displacement = simulation.positions - simulation.rest_positions
        errors.append(np.abs(displacement.ravel() - exact).max())
    order = math.log2(errors[0] / errors[1])
    assert order == pytest.approx(sim.ORDERS[integrator], abs=0.2), errors


# --- stability -------------------------------------------------------------------------------------


def _random_lattice(integrator: str, dt_factor: float, rest_length: float = 0.8, seed: int = 3):
    scene = sim.scenes.build("grid", nx=6, ny=5, rest_length=rest_length)
    simulation = sim.Simulation(scene, integrator=integrator, dt=0.01)
    simulation.dt = dt_factor * simulation.stable_dt("verlet" if integrator in ("euler", "heun") else None)
    rng = np.random.default_rng(seed)
    # small random displacements from rest excite every mode, the highest included; the preset's
    # large displacement is left out because at large amplitude the springs stiffen and the
    # small-amplitude stability limit no longer applies
    simulation.positions = simulation.rest_positions + 1e-3 * rng.standard_normal(
        simulation.positions.shape
    )
    return simulation


@pytest.mark.parametrize("integrator, factor", [("verlet", 2.0), ("rk4", 2 * math.sqrt(2))])
def test_stability_limit_matches_highest_frequency(integrator, factor):
    rest_length = 0.8
    simulation = _random_lattice(integrator, 1.0, rest_length)
    matrix = stiffness_matrix(6, 5, 2, K, K * (1.0 - rest_length))
    omega_max = math.sqrt(np.linalg.eigvalsh(matrix).max())  # unit masses
    assert simulation.stable_dt() == pytest.approx(factor / omega_max, rel=1e-9)


@pytest.mark.parametrize("integrator", ["verlet", "rk4"])
def test_bounded_just_below_limit_and_reported_just_above(integrator):
    below = _random_lattice(integrator, 0.98)
    start = below.energy().total
    below.step(3000)
    assert np.isfinite(below.positions).all()
    assert below.energy().total < 2 * start

    above = _random_lattice(integrator, 1.05)
    with pytest.raises(sim.BlowUpError) as caught:
        above.step(3000)
    error = caught.value
    assert error.integrator == integrator
    assert error.stable_dt == pytest.approx(above.stable_dt())
    assert "stability limit" in str(error)
    assert np.isfinite(above.positions).all()
    assert above.step_count == error.step - 1  # the state before the bad step is kept


def test_euler_and_heun_have_no_stable_step_without_damping():
    simulation = _random_lattice("rk4", 0.5)
    assert simulation.stable_dt("euler") is None
    assert simulation.stable_dt("heun") is None
    assert "no stable step" in simulation.stability("euler").reason


def test_damped_euler_limit_is_beta_over_omega_squared():
    # one particle, drag only: each axis obeys u'' + (g/m) u' + (2k/m) u = 0, and explicit Euler
    # is stable while |1 + h lambda| <= 1, i.e. h <= beta / omega^2 = drag / (2 k).
    drag = 0.5
    simulation = sim.Simulation(sim.scenes.build("single", drag=drag), integrator="euler")
    assert simulation.stable_dt() == pytest.approx(drag / (2 * K), rel=1e-6)
    for factor, grows in ((0.9, False), (1.1, True)):
        trial = sim.Simulation(sim.scenes.build("single", drag=drag, linear=True), "euler")
        trial.dt = factor * drag / (2 * K)
        start = trial.energy().total
        try:
            trial.step(20000)
            end = trial.energy().total
        except sim.BlowUpError:
            end = math.inf
        assert (end > start) == grows


def test_energy_drift_signatures_of_the_integrators():
    drifts = {}
    # explicit Euler over 0.8 s only: longer, its energy grows past what counts as a blow-up
    for integrator, chunk in (("euler", 1), ("rk4", 100), ("verlet", 100)):
        simulation = _random_lattice(integrator, 0.3, seed=11)
        simulation.dt = 0.02
        start = simulation.energy().total
        history = []
        for _ in range(40):
            simulation.step(chunk)
            history.append(simulation.energy().total / start - 1)
        drifts[integrator] = np.array(history)
    assert drifts["euler"][-1] > 0.5  # explicit Euler gains energy
    assert -0.05 < drifts["rk4"][-1] < 0  # RK4 loses a little
    verlet = np.abs(drifts["verlet"])
    assert verlet.max() < 0.01  # Verlet's error stays bounded ...
    assert verlet[-10:].max() < 3 * verlet[:10].max()  # ... and does not grow


# --- statics and energy balance -----------------------------------------------------------------


@pytest.mark.slow  # kernels of their own (the energy balance checks both)
def test_gravity_with_damping_settles_to_static_solution():
    nx, ny, gravity = 6, 4, 9.81
    masses = np.linspace(0.5, 2.0, nx * ny).reshape(ny, nx)
    scene = sim.scenes.build(
        "catenary", nx=nx, ny=ny, linear=True, gravity=gravity, damping=3.0, drag=0.5, mass=masses
    )
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.01)
    simulation.step(20000)
    matrix = stiffness_matrix(nx, ny, 2, K, 0.0)
    load = np.zeros((nx * ny, 2))
    load[:, 1] = -masses.ravel() * gravity
    expected = np.linalg.solve(matrix, load.ravel())
    displacement = (simulation.positions - simulation.rest_positions).ravel()
    np.testing.assert_allclose(displacement, expected, atol=1e-9 * np.abs(expected).max())
    assert np.abs(expected).max() > 0.1  # it really sagged


@pytest.mark.parametrize("integrator, tolerance", [("rk4", 1e-8), ("verlet", 1e-3), ("heun", 1e-3)])
def test_energy_balance_with_dashpots_drag_and_gravity(integrator, tolerance):
    scene = sim.scenes.build("grid", nx=6, ny=5, damping=0.8, drag=0.2, gravity=(0.3, -2.0))
    simulation = sim.Simulation(scene, integrator=integrator, dt=0.002)
    start = simulation.energy()
    simulation.step(2500)
    end = simulation.energy()
    assert end.dissipated > 0.3 * start.total  # the dampers really took energy out
    assert end.balance == pytest.approx(start.balance, abs=tolerance * start.total)


# --- kernels against an independent numpy implementation -------------------------------------------


EXTRAS = ({}, {"damping": 0.7}, {"drag": 0.3, "gravity": (0.5, -9.8, 1.0)})


def _kernel_matrix() -> list:
    """Every integrator with every combination of terms, dimension and linearity: each is a kernel
    of its own (the flags are compile-time constants), so each costs a compilation on a cold cache.
    The default suite runs, for Verlet and RK4, one set that covers each term, each dimension and
    both spring laws at least once, and for Euler and the other Runge-Kutta tables (whose loops
    share RK4's stage sweeps) the 2-D set; the full product is in the slow suite."""
    covering = {(2, False, 3), (1, True, 2), (0, True, 3)}
    shared_stages = {"euler", "heun", "ralston3"}
    cases = []
    for integrator in sim.INTEGRATORS:
        for index, extras in enumerate(EXTRAS):
            for linear in (False, True):
                for dim in (2, 3):
                    fast = (index, linear, dim) in covering and (
                        dim == 2 or integrator not in shared_stages)
                    marks = () if fast else pytest.mark.slow
                    cases.append(pytest.param(dim, linear, extras, integrator, marks=marks,
                                              id=f"{integrator}-extras{index}-{linear}-{dim}"))
    return cases


@pytest.mark.parametrize("dim, linear, extras, integrator", _kernel_matrix())
def test_steps_match_plain_numpy(dim, linear, extras, integrator):
    from sim.integrators import reference

    model = Model.create(
        7, 4, dim=dim, stiffness=K, rest_length=0.85, linear=linear,
        mass=np.linspace(1, 3, 28).reshape(4, 7), **extras,
    )
    simulation = sim.Simulation(model, integrator=integrator, dt=0.01)
    rng = np.random.default_rng(1)
    simulation.positions += 0.1 * rng.standard_normal(simulation.positions.shape)
    simulation.velocities += 0.1 * rng.standard_normal(simulation.velocities.shape)
    positions, velocities = reference.run(
        model, integrator, simulation.state.positions, simulation.state.velocities, 0.01, 3
    )
    simulation.step(3)
    np.testing.assert_allclose(simulation.state.positions, positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(simulation.state.velocities, velocities, rtol=0, atol=1e-12)


def _runge_kutta_tables() -> list:
    from sim.integrators.butcher import MIDPOINT

    tables = [(d.name, d.butcher) for d in sim.integrators.descriptions() if d.butcher is not None]
    return [pytest.param(table, id=name) for name, table in [*tables, ("midpoint", MIDPOINT)]]


LOOP_SHAPES = [
    pytest.param(1, 16, False, id="row-sweep"),
    pytest.param(2, 16, True, id="block-wavefronts"),
    pytest.param(2, 6, False, id="stage-phases"),
]
"""(threads, ny, blocks): the whole lattice as one wavefront on one thread; on 2 threads, one
wavefront with halos per row block (16 rows: blocks of 8, at least 2 stages each); one parallel
phase per stage (6 rows: too thin for halos)."""


@pytest.mark.parametrize("threads, ny, blocks", LOOP_SHAPES)
@pytest.mark.parametrize("table", _runge_kutta_tables())
def test_every_runge_kutta_table_matches_its_textbook_form_on_every_loop_shape(
    table, threads, ny, blocks
):
    """The compiled low-storage stages of each table against the numpy Runge-Kutta step written
    from the full matrix A (``sim.integrators.reference.runge_kutta``), with dashpots and unequal
    masses so that the stage velocities and every weight matter.  One compiled loop per shape
    serves every table (the same kernels on one thread as ``test_steps_match_plain_numpy``)."""
    from sim.integrators import reference
    from sim.integrators.steppers import RungeKutta

    model = Model.create(7, ny, dim=2, stiffness=K, rest_length=0.85, linear=True, damping=0.7,
                         mass=np.linspace(1, 3, 7 * ny).reshape(ny, 7))
    stepper = RungeKutta.of(table)(model, np.float64, threads)
    assert stepper.parallel == (threads > 1)
    assert (stepper._blocks is not None) == blocks
    state = sim.State.at_rest(model)
    rng = np.random.default_rng(1)
    state.positions += 0.1 * rng.standard_normal(state.positions.shape)
    state.velocities += 0.1 * rng.standard_normal(state.velocities.shape)
    positions, velocities = reference.run(model, table, state.positions, state.velocities, 0.01, 3)
    start = state.velocities.copy()
    stepper.advance(state, 3, 0.01)
    assert np.abs(state.velocities - start).max() > 1e-3  # the springs really acted
    np.testing.assert_allclose(state.positions, positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state.velocities, velocities, rtol=0, atol=1e-12)


def test_squeezed_spring_gives_no_nan():
    simulation = sim.Simulation(sim.scenes.build("chain"), integrator="rk4", dt=0.01)
    simulation.positions[1] = simulation.positions[0]  # two particles on top of each other
    simulation.step(10)
    assert np.isfinite(simulation.positions).all()


def test_switching_integrator_keeps_the_state():
    simulation = sim.Simulation(sim.scenes.build("grid"), integrator="rk4", dt=0.01)
    simulation.step(50)
    before = simulation.peek_positions()
    time = simulation.time
    simulation.integrator = "verlet"
    assert simulation.time == time
    np.testing.assert_array_equal(simulation.peek_positions(), before)
    twin = sim.Simulation(sim.scenes.build("grid"), integrator="verlet", dt=0.01)
    twin.positions = simulation.positions
    twin.velocities = simulation.velocities
    simulation.step(20)
    twin.step(20)
    np.testing.assert_allclose(simulation.positions, twin.positions, atol=1e-13)


# --- bad input ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "overrides, message",
    [
        ({"mass": -1.0}, "mass"),
        ({"mass": 0.0}, "mass"),
        ({"nx": 0}, "nx"),
        ({"ny": -3}, "ny"),
        ({"stiffness": float("nan")}, "stiffness"),
        ({"spacing": float("inf")}, "spacing"),
        ({"damping": -0.1}, "damping"),
        ({"gravity": (1.0, float("nan"))}, "gravity"),
        ({"dim": 4}, "dim"),
        ({"mass": np.ones((3, 3))}, "shape"),
        ({"colour": 3}, "unknown parameter"),
    ],
)
def test_bad_parameters_are_refused_clearly(overrides, message):
    with pytest.raises(ValueError, match=message):
        sim.scenes.build("grid", **overrides)


def test_bad_names_and_steps_are_refused_clearly():
    with pytest.raises(sim.SceneError, match="unknown scene"):
        sim.scenes.build("nope")
    with pytest.raises(sim.IntegratorError, match="unknown integrator"):
        sim.Simulation(sim.scenes.build("single"), integrator="leapfrog")
    for dt in (0.0, -0.01, float("nan")):
        with pytest.raises(ValueError, match="dt"):
            sim.Simulation(sim.scenes.build("single"), dt=dt)
    simulation = sim.Simulation(sim.scenes.build("single"))
    with pytest.raises(sim.ModelError, match="mass"):
        simulation.set_parameters(mass=-2.0)
    assert simulation.model.masses.min() > 0  # nothing changed


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("linear", [False, True])
def test_compiled_energy_matches_numpy_energy(dim, linear):
    from sim.theory import observables

    model = Model.create(5, 3, dim=dim, stiffness=K, rest_length=0.9, linear=linear,
                         mass=np.linspace(1, 2, 15).reshape(3, 5))
    state = sim.State.at_rest(model)
    rng = np.random.default_rng(5)
    state.positions += 0.2 * rng.standard_normal(state.positions.shape)
    state.velocities += rng.standard_normal(state.velocities.shape)
    energy = observables.energy(model, state)
    assert energy.spring == pytest.approx(observables.spring_energy(model, state.positions), rel=1e-12)
    assert energy.kinetic == pytest.approx(
        observables.kinetic_energy(model, state.velocities), rel=1e-12
    )
    state.velocities[0, 1, 2] = np.nan
    assert not math.isfinite(observables.energy(model, state).kinetic)


@pytest.mark.parametrize("mode", [1, 3])
def test_chain_transverse_modes_feel_the_wall_springs_and_the_tension(mode):
    count, mass, rest_length = 5, 1.0, 0.8
    simulation = sim.Simulation(
        sim.scenes.build("chain", linear=True, rest_length=rest_length), integrator="rk4", dt=0.001
    )
    j = np.arange(1, count + 1)
    shape = np.sin(mode * math.pi * j / (count + 1))
    rest = simulation.rest_positions.copy()
    simulation.positions = rest
    simulation.positions[:, 1] += 0.05 * shape
    simulation.velocities[...] = 0.0
    tension = K * (1.0 - rest_length)
    omega = math.sqrt(2 * K / mass + 4 * tension / mass * math.sin(mode * math.pi / (2 * (count + 1))) ** 2)
    simulation.step(1700)
    displacement = simulation.positions[:, 1] - rest[:, 1]
    np.testing.assert_allclose(displacement, 0.05 * shape * math.cos(omega * simulation.time), atol=1e-9)
