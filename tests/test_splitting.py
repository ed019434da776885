"""Splitting methods are tables: their order from the order conditions, their stability limit
and dispersion from the harmonic oscillator's matrix, their measured order against the exact
normal-mode solution, a new table registered in one call, and a clear refusal where a method
with backward substeps cannot run."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from app.cli import main
from sim.integrators.registry import (
    IntegratorDescription,
    IntegratorError,
    describe,
    make_integrator,
    register,
    splitting,
    unregister,
)
from sim.integrators.splitting import (
    BLANES_MOAN,
    VELOCITY_VERLET,
    YOSHIDA4,
    SplittingTable,
    SplittingTableError,
)
from sim.model.lattice import Model
from sim.model.state import State


def test_orders_and_costs_follow_from_the_tables():
    assert (VELOCITY_VERLET.order, VELOCITY_VERLET.force_evaluations) == (2, 1)
    assert (YOSHIDA4.order, YOSHIDA4.force_evaluations) == (4, 3)
    assert (BLANES_MOAN.order, BLANES_MOAN.force_evaluations) == (4, 6)
    # Yoshida's weights: w1 = 1 / (2 - 2^(1/3)), w0 = -2^(1/3) w1
    w1 = 1 / (2 - 2 ** (1 / 3))
    assert YOSHIDA4.drifts == pytest.approx((w1, -(2 ** (1 / 3)) * w1, w1), rel=1e-15)
    # a perturbed table loses its order, an inconsistent one is refused
    drifts = list(BLANES_MOAN.drifts)
    drifts[0] += 1e-3
    drifts[1] -= 1e-3
    assert SplittingTable("bent", tuple(drifts), BLANES_MOAN.kicks).order < 4
    with pytest.raises(SplittingTableError, match="sum to"):
        SplittingTable("bad", (0.5, 0.4), (0.5, 0.25, 0.25))


def test_stability_limits_follow_from_the_harmonic_matrix():
    """The limit is where |trace| of one step's matrix on u'' = -u first exceeds 2; a run of
    the harmonic chain just below it stays bounded, just above it blows up."""
    assert VELOCITY_VERLET.stability_factor == pytest.approx(2.0, rel=1e-9)
    for table in (YOSHIDA4, BLANES_MOAN):
        factor = table.stability_factor
        below, above = table.harmonic_matrix(0.999 * factor), table.harmonic_matrix(1.001 * factor)
        assert abs(np.trace(below)) <= 2.0 < abs(np.trace(above))
    assert YOSHIDA4.stability_factor == pytest.approx(1.5734, abs=1e-4)
    assert BLANES_MOAN.stability_factor == pytest.approx(3.1635, abs=1e-4)


def _run(model, name, steps, dt, precision="float64", threads=1):
    rest = model.rest_positions
    positions = rest + 0.05 * np.random.default_rng(3).standard_normal(rest.shape)
    velocities = 0.1 * np.random.default_rng(4).standard_normal(rest.shape)
    state = State.from_particle_arrays(model, positions, velocities, precision)
    make_integrator(name, model, precision, threads).advance(state, steps, dt)
    return state.positions.copy()


def test_measured_orders_against_the_exact_modal_solution():
    """The linear grid: the exact normal-mode solution is the reference."""
    model = Model.create(9, 7, stiffness=3.0, linear=True, rest_length=0.9)
    exact = _run(model, "exact", 10, 0.04)
    for name, order in (("yoshida4", 4), ("blanes-moan", 4), ("verlet", 2)):
        errors = [np.abs(_run(model, name, round(0.4 / dt), dt) - exact).max()
                  for dt in (0.04, 0.02)]
        assert math.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.15), name


def test_another_table_is_one_registration_and_verlet_is_a_table():
    register(IntegratorDescription(name="verlet-table", label="Verlet as a table",
                                   short_label="Verlet table",
                                   **splitting(VELOCITY_VERLET, "verlet-table")))
    try:
        assert describe("verlet-table").order == 2 and describe("verlet-table").symplectic
        model = Model.create(7, 9, stiffness=3.0, rest_length=0.9, spring_alpha=0.3)
        assert np.array_equal(_run(model, "verlet-table", 30, 0.01),
                              _run(model, "verlet", 30, 0.01))
        grid = sim.scenes.build("grid")
        assert "verlet-table" in sim.integrators.names(grid.model)
    finally:
        unregister("verlet-table")


def test_methods_with_backward_substeps_refuse_what_they_cannot_run(capsys):
    damped = sim.scenes.build("catenary")
    with pytest.raises(IntegratorError, match="dashpots and drag depend on the velocities"):
        sim.Simulation(damped, integrator="yoshida4")
    driven = sim.scenes.build("resonance", drag=0.0)
    with pytest.raises(IntegratorError, match="drivers, sources"):
        sim.Simulation(driven, integrator="blanes-moan")
    assert main(["run", "catenary", "--integrator", "blanes-moan", "--steps", "1",
                 "--quiet"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0 and "does not apply here" in error
    assert "yoshida4" not in sim.integrators.names(damped.model)


def test_the_fpu_chain_keeps_its_energy_far_better_at_equal_work():
    """Equal force evaluations per unit time: Verlet at dt / 6, Blanes-Moan at dt."""
    scene = sim.scenes.build("fput")
    errors = {}
    for name, dt in (("verlet", 0.1 / 6), ("blanes-moan", 0.1)):
        simulation = sim.Simulation(scene, integrator=name, dt=dt)
        start, worst = simulation.energy().total, 0.0
        for _ in range(20):
            simulation.step(round(50 / dt))
            worst = max(worst, abs(simulation.energy().total - start))
        errors[name] = worst / start
    assert errors["blanes-moan"] < errors["verlet"] / 100, errors


@pytest.mark.slow
@pytest.mark.parametrize("name", ["yoshida4", "blanes-moan"])
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("extras", [{}, {"gravity": 2.0}, {"diagonal_stiffness": 1.5},
                                    {"linear": True, "rest_length": 1.0}])
def test_every_loop_shape_agrees_with_the_numpy_textbook_form(name, threads, precision,
                                                                  extras):
    from sim.integrators import reference

    model = Model.create(7, 9, stiffness=3.0, **{"rest_length": 0.9, **extras},
                         spring_alpha=0.2)
    rest = model.rest_positions
    positions = (rest + 0.05 * np.random.default_rng(3).standard_normal(rest.shape)).T.reshape(
        model.dim, model.ny, model.nx)
    velocities = (0.1 * np.random.default_rng(4).standard_normal(rest.shape)).T.reshape(
        model.dim, model.ny, model.nx)
    expected, _ = reference.run(model, name, positions, velocities, 0.02, 12)
    got = _run(model, name, 12, 0.02, precision, threads)
    assert np.abs(got - expected).max() < (1e-12 if precision == "float64" else 2e-5)
