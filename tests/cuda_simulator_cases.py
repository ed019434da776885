"""Run by ``tests/test_cuda_device.py`` in a process with ``NUMBA_ENABLE_CUDASIM=1``: the GPU
stepper on numba-cuda's simulator against the CPU's Verlet, on small lattices; prints JSON."""

from __future__ import annotations

import json

import numpy as np

import sim
from sim.model.lattice import ModelError


def _pair(model, precision, seed):
    """A CPU and a GPU simulation of ``model`` from the same displaced, moving start."""
    rng = np.random.default_rng(seed)
    runs = [sim.Simulation(model, integrator="verlet", dt=0.02, precision=precision,
                           device=device) for device in ("cpu", "cuda")]
    kick = 0.2 * rng.standard_normal(runs[0].positions.shape)
    push = 0.5 * rng.standard_normal(runs[0].velocities.shape)
    for run in runs:
        run.positions += kick
        run.velocities = push
    return runs


def _difference(cpu, gpu):
    scale = float(np.abs(cpu.positions - cpu.rest_positions).max())
    return {"positions": float(np.abs(cpu.positions - gpu.positions).max()) / scale,
            "velocities": float(np.abs(cpu.velocities - gpu.velocities).max())
            / float(np.abs(cpu.velocities).max()),
            "moved": scale, "time": [cpu.time, gpu.time]}


def main() -> None:
    results = {}
    masses = 1.0 + np.random.default_rng(1).random((4, 5))
    model = sim.Model.create(nx=5, ny=4, spacing=1.0, stiffness=30.0, rest_length=0.7,
                             mass=masses)
    for precision in ("float64", "float32"):
        cpu, gpu = _pair(model, precision, 2)
        cpu.step(130)
        gpu.step(130)
        results[precision] = _difference(cpu, gpu)
    # a parameter changed mid-run, then a drag of a particle, on both
    cpu, gpu = _pair(model, "float64", 3)
    for run in (cpu, gpu):
        run.step(20)
        run.set_parameters(stiffness=45.0)
        run.step(20)
        run.positions[7, 0] += 0.3
        run.step(20)
    results["changed"] = _difference(cpu, gpu)
    # a step far past the stability limit: stopped, the state before the bad step kept
    gpu = sim.Simulation(model, device="cuda")
    gpu.dt = 1.3 * gpu.stable_dt()
    gpu.positions[3, 1] += 0.3
    try:
        gpu.step(200)
        results["blow_up"] = None
    except sim.BlowUpError as error:
        results["blow_up"] = {"step": error.step, "kept": gpu.step_count,
                              "finite": bool(np.isfinite(gpu.positions).all())}
    refusals = {}
    for name, action in (
            ("rk4", lambda run: setattr(run, "integrator", "rk4")),
            ("damping", lambda run: run.set_parameters(damping=0.2))):
        gpu = sim.Simulation(model, device="cuda")
        gpu.positions[3, 1] += 0.3
        before = gpu.peek_positions()
        try:
            action(gpu)
            refusals[name] = None
        except ModelError as error:
            gpu.step(3)
            refusals[name] = {"message": str(error), "integrator": gpu.integrator,
                              "damping": gpu.model.damping,
                              "stepped": bool(np.abs(gpu.peek_positions() - before).max() > 0)}
    results["refusals"] = refusals
    print(json.dumps(results))


if __name__ == "__main__":
    main()
