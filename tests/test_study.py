"""Accuracy study: physics against physics.

The exact normal-mode solution is checked against the numba kernels, the measured convergence
orders against theory, and the recommendation against its promise (fast, never less accurate than
asked).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import sim
from app.study.accuracy import accuracy_study, recommend
from app.study.linear import ExactLinearSolution, NotExactError
from sim.integrators.registry import FORCE_EVALUATIONS

# Per-integrator steps (s) in the asymptotic range on the linearised 12x8 grid, T = 2 s
# (omega_max = 11.75 rad/s): small enough that Euler's growth exp(omega^2 dt T / 2) stays near 1,
# large enough that RK4 stays above round-off.
CONVERGENCE_DTS = {
    "euler": [4e-4, 2e-4, 1e-4, 5e-5],
    "heun": [4e-3, 2e-3, 1e-3, 5e-4],
    "verlet": [1e-2, 5e-3, 2.5e-3, 1.25e-3],
    "rk4": [2e-2, 1e-2, 5e-3, 2.5e-3],
    "ralston3": [1e-2, 5e-3, 2.5e-3, 1.25e-3],
}


@pytest.fixture(scope="module")
def linear_grid_study():
    scene = sim.scenes.build("grid", linear=True)
    # the orders are float64's (float32's runs, whose rounding sets a floor, are in the
    # recommendation and command tests below)
    return accuracy_study(scene, dts=CONVERGENCE_DTS, until=2.0, tolerance=1e-2,
                          minimum_seconds=0.0, precisions=("float64",))


@pytest.mark.parametrize(
    "overrides",
    [dict(), dict(damping=0.5),
     pytest.param(dict(gravity=9.81, rest_length=0.9), marks=pytest.mark.slow),
     pytest.param(dict(drag=0.3, dim=3, rest_length=0.8), marks=pytest.mark.slow)],
    ids=["undamped", "dashpots", "gravity+tension", "drag+3d"],
)
def test_exact_solution_matches_a_fine_rk4_run(overrides):
    scene = sim.scenes.build("grid", nx=6, ny=4, linear=True, **overrides)
    simulation = sim.Simulation(scene, integrator="rk4", dt=1e-3)
    exact = ExactLinearSolution(
        scene.model, simulation.state.positions, simulation.state.velocities
    )
    simulation.step(1500)
    positions, velocities = exact.state_at(simulation.time)
    assert np.abs(simulation.state.positions - positions).max() < 1e-8
    assert np.abs(simulation.state.velocities - velocities).max() < 1e-7


def test_exact_solution_refuses_nonlinear_springs():
    scene = sim.scenes.build("grid")
    with pytest.raises(NotExactError, match="linear"):
        ExactLinearSolution(scene.model, scene.model.rest_positions.T, scene.initial_velocities.T)


@pytest.mark.slow  # float32 kernels of their own
def test_reference_is_exact_for_linear_scene(linear_grid_study):
    reference = linear_grid_study.reference
    assert reference.kind == "exact normal modes"
    assert reference.error == 0.0
    # the reference state at T = 2 s against an independent fine RK4 run (error ~ (omega dt)^4)
    simulation = sim.Simulation(sim.scenes.build("grid", linear=True), integrator="rk4", dt=1e-3)
    simulation.step(2000)
    assert simulation.time == pytest.approx(linear_grid_study.until)
    assert np.abs(simulation.state.positions).max() > 0.1  # the comparison is not of zeros
    assert np.abs(simulation.state.positions - reference.positions).max() < 1e-8
    assert np.abs(simulation.state.velocities - reference.velocities).max() < 1e-7


@pytest.mark.parametrize("integrator", sim.INTEGRATORS)
def test_measured_convergence_order_matches_theory(linear_grid_study, integrator):
    measured = linear_grid_study.orders[integrator]
    assert measured is not None
    assert abs(measured - sim.ORDERS[integrator]) < 0.2, (integrator, measured)


# Global error rates on a linear oscillator from the amplification factor R(i omega dt) over
# T / dt steps: the phase error is T/dt * |arg R - omega dt|, the energy drift T/dt * ||R|^2 - 1|.
# Euler: R = 1 + ih, |R|^2 = 1 + h^2, arg R = h - h^3/3  -> phase dt^2, energy dt^1.
# Heun:  R = 1 + ih - h^2/2, |R|^2 = 1 + h^4/4, arg error ~ h^3 -> phase dt^2, energy dt^3.
# Verlet: symplectic, the energy oscillates with amplitude ~ h^2 -> phase dt^2, energy dt^2.
# RK4: |R|^2 = 1 - h^6/72, arg error ~ h^5 -> phase dt^4, energy dt^5.
# Ralston RK3: R - e^(ih) = -h^4/24 + O(h^5), real: |R|^2 = 1 - h^4/12 + h^6/36 -> energy dt^3;
#   arg error h^5/30 -> phase dt^4.
PHASE_ORDERS = {"euler": 2, "heun": 2, "verlet": 2, "rk4": 4, "ralston3": 4}
ENERGY_ORDERS = {"euler": 1, "heun": 3, "verlet": 2, "rk4": 5, "ralston3": 3}


@pytest.mark.parametrize("integrator", sim.INTEGRATORS)
def test_phase_and_energy_errors_shrink_with_dt_at_the_theoretical_rate(
    linear_grid_study, integrator
):
    runs = linear_grid_study.runs_of(integrator)
    assert len(runs) == len(CONVERGENCE_DTS[integrator])
    for quantity, orders in (("phase_error", PHASE_ORDERS), ("energy_drift", ENERGY_ORDERS)):
        errors = [abs(getattr(run, quantity)) for run in runs]
        assert errors[0] > 0, (integrator, quantity, errors)
        for i in range(1, len(runs)):
            # at least half the theoretical growth from one dt to the next
            expected = (runs[i].dt / runs[i - 1].dt) ** orders[integrator]
            assert errors[i] / errors[i - 1] >= expected / 2, (integrator, quantity, errors)


@pytest.mark.slow  # fine reference runs of a nonlinear lattice
def test_nonlinear_reference_reports_its_own_error():
    scene = sim.scenes.build("grid", nx=6, ny=4)
    study = accuracy_study(scene, integrators=["verlet", "rk4"], dts=[0.02, 0.01], until=1.0,
                           minimum_seconds=0.0)
    assert study.reference.kind == "RK4 (Richardson)"
    rk4 = study.runs_of("rk4")
    # far more accurate than the most accurate run it judges (RK4 at a quarter of its step)
    assert 0 < study.reference.error < rk4[0].error / 100
    # the study's verdict must not change if the reference is refined further
    assert rk4[0].error < rk4[1].error / 10


def test_recommendation_beats_rk4_at_a_tenth_of_its_limit_and_meets_the_tolerance():
    # 30x20 linearised grid: big enough that wall time is dominated by the force evaluations.
    scene = sim.scenes.build("grid", nx=30, ny=20, linear=True)
    rk4_limit = sim.Simulation(scene).stable_dt("rk4")
    until = 4.0
    slow_and_safe = 0.1 * rk4_limit
    dts = [slow_and_safe, 0.25 * rk4_limit, 0.5 * rk4_limit]
    tolerance = 0.05
    study = accuracy_study(scene, integrators=["verlet", "rk4"], dts=dts, until=until,
                           tolerance=tolerance)
    choice = study.recommendation
    assert choice.integrator is not None
    assert choice.error <= tolerance
    chosen = next(run for run in study.runs
                  if run.integrator == choice.integrator and run.dt == choice.dt)
    assert chosen.error <= tolerance
    baseline = next(run for run in study.runs_of("rk4") if math.isclose(
        run.dt, until / round(until / slow_and_safe)))
    # faster as in cheaper: force evaluations, which do not depend on the machine's load
    def cost(run):
        return run.steps * FORCE_EVALUATIONS[run.integrator]

    assert cost(chosen) < cost(baseline)
    # the baseline itself is far below the loose tolerance: a recommendation must exist for 1e-2
    assert baseline.error < 1e-2
    assert recommend(study.runs, 1e-2).integrator is not None
    # never less accurate than asked, whatever the tolerance
    for tight in (1e-2, 1e-4, 1e-6):
        again = recommend(study.runs, tight)
        assert again.integrator is None or again.error <= tight


def test_json_output_is_valid_and_complete(linear_grid_study):
    data = json.loads(json.dumps(linear_grid_study.as_dict()))
    assert {"runs", "orders", "recommendation", "reference", "limits"} <= set(data)
    assert len(data["runs"]) >= 16


def test_cli_accuracy_prints_table_and_writes_picture(tmp_path, capsys):
    from app.cli import main

    picture = tmp_path / "wp.png"
    status = main(["accuracy", "chain", "--set", "linear=true", "--integrators", "verlet", "rk4",
                   "--dts", "0.02", "0.01", "--until", "1", "--quiet", "--plot", str(picture)])
    assert status == 0
    output = capsys.readouterr().out
    assert "recommendation" in output and "exact normal modes" in output
    assert picture.stat().st_size > 10_000


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--dts", "nan"], "--dts: must be a positive, finite"),
        (["--dts", "0.01", "inf"], "--dts: must be a positive, finite"),
        (["--dts", "0.01", "-0.01"], "--dts: must be a positive, finite"),
        (["--dts", "0.01", "--until", "nan"], "--until: must be a positive, finite"),
        # the reference alone would need 8e12 steps: refused before anything runs
        (["--dts", "1", "--until", "1e12"], "over the limit"),
    ],
    ids=["nan dt", "inf dt", "negative dt", "nan until", "reference too long"],
)
def test_cli_accuracy_rejects_bad_input_with_a_clear_message(arguments, message, capsys):
    from app.cli import main

    try:
        status = main(["accuracy", "chain", "--quiet", *arguments])
    except SystemExit as exit_request:  # argparse refused the option itself
        status = exit_request.code
    assert status == 2
    captured = capsys.readouterr()
    assert "error: " in captured.err and message in captured.err
    assert len(captured.err.strip().splitlines()) == 1
    assert "Traceback" not in captured.err
