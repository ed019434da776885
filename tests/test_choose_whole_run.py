"""``choose`` looks at the whole run: its answer, run on its own by ``oscillators run`` in a
separate process over the scene's duration, keeps both errors within the tolerance at every
sample time, not at the end alone.

The field error is computed here from the sampled fields ``run --fields`` saves, against a
reference run of RK4 at a step far below the answer's (its own error is checked by halving it),
with the formula written out again (largest distance over the samples / largest reference
field).  On the catenary the lattice sags through its bottom wall: the springs to the wall pass
through zero length, where their force jumps, and halving RK4's step changes the field over the
run about as much at a step of milliseconds as at one twenty times longer.  No step gives a
reference for the field; ``choose`` says so and meets the tolerance in the energy error, which
the run must then keep at every sample.

Each test runs `choose` and several whole runs in other processes (tens of seconds): they are in
the slow suite; ``tests/test_choose.py`` checks the whole-run errors of a linear chain in seconds.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 0.01


def _cli(cwd: Path, *arguments: str) -> subprocess.CompletedProcess:
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "app.cli", *arguments], capture_output=True,
                          text=True, cwd=cwd, env=environment, timeout=900)


def _choose(tmp_path: Path, scene: str, *options: str) -> dict:
    result = _cli(tmp_path, "choose", scene, "--tolerance", str(TOLERANCE), "--json", "--quiet",
                  *options)
    assert result.returncode == 0, result.stdout + result.stderr
    return json.loads(result.stdout)


def _run(tmp_path: Path, scene: str, name: str, *options: str) -> tuple[dict, dict]:
    """`oscillators run` with the sampled fields saved: (its JSON summary, the arrays)."""
    path = tmp_path / f"{name}.npz"
    result = _cli(tmp_path, "run", scene, "--json", "--quiet", "--fields", str(path), *options)
    assert result.returncode == 0, result.stderr
    with np.load(path) as arrays:
        return json.loads(result.stdout), {key: arrays[key] for key in arrays.files}


def _whole_run_distance(fields: np.ndarray, reference: np.ndarray) -> float:
    """max over the samples of ||u - u_ref|| over max over the samples of ||u_ref||."""
    count = len(reference)
    distance = np.sqrt(((fields - reference) ** 2).reshape(count, -1).sum(axis=1))
    size = np.sqrt((reference ** 2).reshape(count, -1).sum(axis=1))
    return float(distance.max() / size.max())


def _rk4(tmp_path: Path, scene: str, duration: float, steps: int, *options: str) -> dict:
    """The sampled fields of RK4 at ``steps`` steps over ``duration`` s."""
    return _run(tmp_path, scene, f"rk4-{steps}", "--integrator", "rk4", "--dt",
                repr(duration / steps), "--duration", repr(duration), *options)[1]


def _reference(tmp_path: Path, scene: str, duration: float, steps: int, *options: str) -> dict:
    """RK4 at ``steps`` steps over the scene, checked against RK4 at twice as many."""
    coarse = _rk4(tmp_path, scene, duration, steps, *options)
    fine = _rk4(tmp_path, scene, duration, 2 * steps, *options)
    np.testing.assert_allclose(coarse["times"], fine["times"])
    assert _whole_run_distance(coarse["fields"], fine["fields"]) < TOLERANCE / 20
    return fine


def _check_answer(tmp_path: Path, scene: str, reference_steps: int, *options: str) -> dict:
    data = _choose(tmp_path, scene, *options)
    assert data["met"] and data["measure"] == "field and energy", data["note"]
    assert data["error"] <= TOLERANCE
    assert max(data["energy_error"], data["field_error"]) <= TOLERANCE
    summary, answer = _run(tmp_path, scene, "answer", "--integrator", data["integrator"], "--dt",
                           repr(data["dt"]), *options)
    assert summary["steps"] == data["steps"] and summary["blew_up"] is None
    assert abs(summary["time"] - data["duration"]) < 1e-9 * data["duration"]
    # the energy balance at every sample time, the end included
    assert np.abs(answer["energy_balance_errors"]).max() <= TOLERANCE
    assert abs(summary["energy_balance_error"]) <= TOLERANCE
    reference = _reference(tmp_path, scene, data["duration"], reference_steps, *options)
    np.testing.assert_allclose(answer["times"], reference["times"], rtol=1e-9)
    assert np.abs(reference["fields"]).max() > 1e-3  # something moves
    assert _whole_run_distance(answer["fields"], reference["fields"]) <= TOLERANCE
    return data


@pytest.mark.slow
def test_the_catenary_answer_keeps_its_energy_balance_over_the_whole_run(tmp_path) -> None:
    data = _choose(tmp_path, "catenary")
    summary = json.loads(_cli(tmp_path, "run", "catenary", "--integrator", data["integrator"],
                              "--dt", repr(data["dt"]), "--json", "--quiet").stdout)
    assert summary["steps"] == data["steps"] and summary["blew_up"] is None
    assert abs(summary["energy_balance_error"]) <= TOLERANCE
    assert data["met"] and data["measure"] == "energy" and data["field_error"] is None
    assert "does not converge" in data["note"]
    _, answer = _run(tmp_path, "catenary", "answer", "--integrator", data["integrator"], "--dt",
                     repr(data["dt"]))
    assert np.abs(answer["energy_balance_errors"]).max() <= TOLERANCE
    # why there is no field reference: the bottom row falls through its wall anchors, so those
    # springs pass through zero length, where a spring's force k (|d| - L) d / |d| jumps, and
    # no integrator keeps its order across a jump.  Two pairs of RK4 runs, one at a step 18.75
    # times the other's: at order 4 the finer pair would change the field 18.75^4 ~ 1.2e5
    # times less than the coarser one.
    coarse_pair = [_rk4(tmp_path, "catenary", data["duration"], n) for n in (640, 1280)]
    fine_pair = [_rk4(tmp_path, "catenary", data["duration"], n) for n in (12000, 24000)]
    for first, second in (coarse_pair, fine_pair):
        np.testing.assert_allclose(first["times"], second["times"])
    coarse_change = _whole_run_distance(coarse_pair[0]["fields"], coarse_pair[1]["fields"])
    fine_change = _whole_run_distance(fine_pair[0]["fields"], fine_pair[1]["fields"])
    assert fine_change > 100 * coarse_change * (640 / 12000) ** 4, (coarse_change, fine_change)
    # the bottom row's middle particle ends below its wall anchor, one spacing (1 m) under its
    # rest site: the anchor's spring went through zero length
    final_y = fine_pair[1]["fields"][-1, 1]
    assert final_y[0, final_y.shape[1] // 2] < -1.0


@pytest.mark.slow
def test_the_damped_grid_answer_meets_both_errors_over_the_whole_run(tmp_path) -> None:
    _check_answer(tmp_path, "grid", 16000, "--set", "damping=0.5")


@pytest.mark.slow
def test_the_resonance_answer_meets_both_errors_over_the_whole_run(tmp_path) -> None:
    _check_answer(tmp_path, "resonance", 24000)
