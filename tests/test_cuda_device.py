"""The GPU stepper (``Simulation(..., device="cuda")``) on numba-cuda's simulator against the
CPU's velocity Verlet, and what it refuses."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sim
from sim.devices.cuda_stepper import cuda_device_problem, cuda_support
from sim.model.lattice import ModelError

pytest.importorskip("numba_cuda")


@pytest.fixture(scope="module")
def simulated():
    """The cases of ``cuda_simulator_cases.py``, run on the simulator in a process of their own
    (the simulator is chosen when numba.cuda is first imported)."""
    script = Path(__file__).with_name("cuda_simulator_cases.py")
    result = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=600,
        env={**os.environ, "NUMBA_ENABLE_CUDASIM": "1"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_gpu_verlet_is_the_cpu_verlet_in_float64(simulated):
    """Unequal masses, pre-tensioned springs, a random start, 130 steps: the same trajectory
    to round-off (the two devices sum the same forces in the same order)."""
    case = simulated["float64"]
    assert case["moved"] > 0.1
    assert case["time"][0] == case["time"][1]
    assert case["positions"] < 1e-12
    assert case["velocities"] < 1e-12


def test_gpu_verlet_in_float32_within_its_round_off(simulated):
    case = simulated["float32"]
    assert case["moved"] > 0.1
    assert case["positions"] < 1e-4
    assert case["velocities"] < 1e-4


def test_parameters_and_drags_mid_run_reach_the_gpu(simulated):
    """A stiffness changed mid-run and a particle moved by hand: the GPU copy follows both."""
    case = simulated["changed"]
    assert case["positions"] < 1e-12
    assert case["velocities"] < 1e-12


def test_a_gpu_run_that_blows_up_stops_with_the_state_kept(simulated):
    case = simulated["blow_up"]
    assert case is not None, "a step 1.3 times the stability limit did not blow up"
    assert case["kept"] == case["step"] - 1
    assert case["finite"]


def test_what_the_gpu_cannot_run_is_refused_and_changes_nothing(simulated):
    for name, refused in simulated["refusals"].items():
        assert refused is not None, f"{name} was not refused"
        assert refused["message"].startswith("device 'cuda': the GPU runs")
        assert refused["integrator"] == "verlet"
        assert refused["damping"] == 0.0
        assert refused["stepped"], f"the run did not go on after refusing {name}"


def test_cuda_support_names_each_reason():
    base = dict(nx=4, ny=3)
    assert cuda_support(sim.Model.create(**base), "verlet") is None
    cases = {
        "velocity Verlet (integrator 'verlet') only": (sim.Model.create(**base), "rk4"),
        "planar": (sim.Model.create(**base, dim=3), "verlet"),
        "nonlinear": (sim.Model.create(**base, linear=True), "verlet"),
        "fixed walls": (sim.Model.create(**base, boundary="periodic"), "verlet"),
        "gravity": (sim.Model.create(**base, gravity=(0.0, -9.81, 0.0)), "verlet"),
    }
    for words, (model, integrator) in cases.items():
        reason = cuda_support(model, integrator)
        assert reason is not None and words in reason, (words, reason)


def test_without_a_gpu_device_cuda_says_how_to_get_one():
    """On a machine without a GPU (and without the simulator), the refusal says what to do."""
    if cuda_device_problem() is None:
        pytest.skip("a CUDA device (or the simulator) is available here")
    with pytest.raises(ModelError, match="no CUDA GPU found.*NUMBA_ENABLE_CUDASIM"):
        sim.Simulation(sim.Model.create(nx=3, ny=2), device="cuda")
    with pytest.raises(ModelError, match="device must be one of cpu, cuda"):
        sim.Simulation(sim.Model.create(nx=3, ny=2), device="gpu")
    assert np.isfinite(sim.Simulation(sim.Model.create(nx=3, ny=2)).energy().total)


def test_bench_says_when_no_gpu_is_measured():
    from app.benchmark import measure

    if cuda_device_problem() is None:
        pytest.skip("a CUDA device (or the simulator) is available here")
    gpu = measure("chain", parts=("gpu",))["gpu"]
    assert gpu == {"found": False, "reason": cuda_device_problem()}
