"""``choose``: the answer is verified by running it, against physics.

On a linear chain the chosen setting, run on its own, stays within the tolerance of the
normal-mode solution computed independently (``app.study.linear``, a dense eigen-decomposition)
at every sample time of the run; a named error is the one checked and the other is still shown;
a tolerance no integrator can meet is said to be missed (exit 1) with the best reached;
``--json`` prints one document and writes no file; every run goes through the one ``map_runs``
seam as a picklable task.
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sim
from app.study.choose import BOTH, choose
from app.study.linear import ExactLinearSolution
from sim.integrators.registry import describe
from sim.runtime.errors import SAMPLES, displacement

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 1e-3


def _linear_chain() -> sim.Scene:
    return sim.scenes.build("chain", linear=True, nx=8)


def _cli(cwd: Path, *arguments: str) -> subprocess.CompletedProcess:
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "app.cli", *arguments], capture_output=True,
                          text=True, cwd=cwd, env=environment, timeout=300)


def _pickled_map(counter: list[int]):
    """A map that sends every task and outcome through pickle, as another process would."""

    def map_runs(function, tasks):
        for task in tasks:
            counter[0] += 1
            yield pickle.loads(pickle.dumps(function(pickle.loads(pickle.dumps(task)))))

    return map_runs


def test_the_chosen_setting_meets_the_tolerance_against_the_exact_modes() -> None:
    scene = _linear_chain()
    calls = [0]
    choice = choose(scene, TOLERANCE, map_runs=_pickled_map(calls))
    assert choice.measure == BOTH and choice.reference.dt is None  # exact reference
    answer = choice.answer
    assert answer is not None and answer.error <= TOLERANCE
    assert max(answer.field_error, answer.energy_error) <= TOLERANCE
    assert calls[0] == len(choice.runs)  # every run went through the seam
    assert len(choice.runs) <= 12  # few runs
    # run the answer again, alone, and compare with an independent modal solution
    simulation = sim.Simulation(scene, integrator=answer.integrator, dt=answer.dt)
    exact = ExactLinearSolution(scene.model, simulation.state.positions,
                                simulation.state.velocities)
    assert answer.steps % SAMPLES == 0
    distances, sizes = [], []
    for k in range(1, SAMPLES + 1):  # the whole run, sampled at k T / SAMPLES
        simulation.step(answer.steps // SAMPLES)
        expected = displacement(scene.model, exact.state_at(k * scene.duration / SAMPLES)[0])
        distances.append(np.linalg.norm(displacement(scene.model, simulation.state.positions)
                                        - expected))
        sizes.append(np.linalg.norm(expected))
        assert abs(simulation.energy_balance_error()) <= TOLERANCE
    assert abs(simulation.time - scene.duration) < 1e-9
    assert max(sizes) > 0.1  # the chain is moving
    assert max(distances) / max(sizes) <= TOLERANCE
    # no cheaper verified setting was passed over (cost: the registry's estimate, load-free)
    def cost(run):
        return run.steps * describe(run.integrator).seconds_per_step(scene.model.n_particles)

    assert all(cost(run) >= cost(answer) for run in choice.runs if run.meets)


@pytest.mark.slow  # a study of many runs
def test_a_blown_up_or_missing_run_is_never_the_answer_and_a_miss_is_said() -> None:
    scene = _linear_chain()
    choice = choose(scene, 1e-13, integrators=["euler", "verlet"])
    assert choice.answer is None
    assert choice.best_reached is not None and choice.best_reached.error > 1e-13
    result = choose(scene, 0.5, measure="energy", integrators=["verlet"])
    assert result.answer is not None and result.answer.blew_up is None
    assert result.answer.energy_error <= 0.5


def test_a_named_error_is_the_one_checked_and_the_other_is_still_shown() -> None:
    scene = _linear_chain()
    for named, other in (("field", "energy_error"), ("energy", "field_error")):
        choice = choose(scene, 1e-2, measure=named, integrators=["verlet"])
        answer = choice.answer
        assert choice.measure == named and answer is not None
        assert answer.error == getattr(answer, f"{named}_error") <= 1e-2
        assert getattr(answer, other) is not None and np.isfinite(getattr(answer, other))
        assert choice.as_dict()["definitions"]["error"] == f"the error checked against the " \
            f"tolerance: the {named} error"


def test_cli_json_is_one_document_and_writes_no_file(tmp_path: Path) -> None:
    result = _cli(tmp_path, "choose", "chain", "--set", "linear=true", "--tolerance", "1e-3",
                  "--integrators", "verlet,rk4", "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert {"integrator", "dt", "duration", "error", "wall_seconds"} <= set(data)
    assert data["error"] <= 1e-3 and data["measure"] == "field and energy"
    assert max(data["field_error"], data["energy_error"]) <= 1e-3
    assert "field_error" in data["definitions"] and "energy_error" in data["definitions"]
    assert list(tmp_path.iterdir()) == []
    # the chosen setting, run by `run` over the scene's duration, exits 0
    run = _cli(tmp_path, "run", "chain", "--set", "linear=true", "--integrator",
               data["integrator"], "--dt", repr(data["dt"]), "--json", "--quiet")
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["steps"] == data["steps"]


@pytest.mark.slow  # a study of many runs
def test_cli_says_when_nothing_meets_and_exits_nonzero(tmp_path: Path) -> None:
    result = _cli(tmp_path, "choose", "chain", "--set", "linear=true", "--tolerance", "1e-13",
                  "--integrators", "verlet", "--quiet", "-o", str(tmp_path / "choice.json"))
    assert result.returncode == 1
    assert "nothing met the tolerance" in result.stdout and "best reached" in result.stdout
    assert json.loads((tmp_path / "choice.json").read_text())["met"] is False


def test_accuracy_json_is_one_document_and_writes_no_picture(tmp_path: Path) -> None:
    result = _cli(tmp_path, "accuracy", "chain", "--integrators", "verlet", "--dts", "0.02",
                  "0.01", "--until", "1", "--precisions", "float64", "--json", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "runs" in json.loads(result.stdout)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("preset", [name for name in sim.scenes.names()
                                    if sim.scenes.build(name).model.n_particles < 5000])
def test_every_preset_choice_run_by_run_meets_its_tolerance(preset: str, tmp_path: Path) -> None:
    """The chosen setting, run with `oscillators run` over the scene's duration, exits 0 and its
    energy error (the measure `run` reports) is within the tolerance when that is the measure."""
    result = _cli(tmp_path, "choose", preset, "--tolerance", "0.01", "--error", "energy",
                  "--json", "--quiet")
    assert result.returncode == 0, result.stdout + result.stderr
    data = json.loads(result.stdout)
    run = _cli(tmp_path, "run", preset, "--integrator", data["integrator"], "--dt",
               repr(data["dt"]), "--json", "--quiet")
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    assert summary["steps"] == data["steps"]
    assert abs(summary["energy_balance_error"]) <= 0.01
