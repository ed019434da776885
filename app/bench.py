"""``oscillators bench``: steps per second of the numba integrators against plain numpy.

For each integrator it times, in one run on the same state:

* the compiled step loop alone (``Integrator.advance``),
* ``Simulation.step`` (the loop plus the blow-up check after each chunk),
* the same step written in plain vectorised numpy (``sim.reference``),

and prints steps per second and the ratio kernel / numpy.  It also measures what the scene flags
buy: the undamped planar kernel against the general kernel forced to carry zero-valued damping,
drag and gravity terms (the code a scene would run if the flags did not pick a specialised one).

Timing is the best of many short bursts, which keeps the numbers meaningful on a machine that is
busy with other work; the load average is printed beside them.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable

import numpy as np


def _best_rate(
    run: Callable[[int], None], burst: int, seconds: float,
    prepare: Callable[[], None] | None = None,
) -> float:
    """Steps per second: the best of bursts of ``burst`` steps over about ``seconds``;
    ``prepare`` (not timed) runs before each burst."""
    run(1)  # compile / warm up
    best = float("inf")
    deadline = time.perf_counter() + seconds
    repetitions = 0
    while time.perf_counter() < deadline or repetitions < 3:
        if prepare is not None:
            prepare()
        started = time.perf_counter()
        run(burst)
        best = min(best, (time.perf_counter() - started) / burst)
        repetitions += 1
    return 1.0 / best


def _numpy_rate(model, integrator: str, positions, velocities, dt: float, seconds: float) -> float:
    from sim import reference

    state = {"x": positions.copy(), "v": velocities.copy()}

    def run(steps: int) -> None:
        state["x"], state["v"] = reference.run(model, integrator, state["x"], state["v"], dt, steps)

    return _best_rate(run, 1, seconds)


def measure(scene_name: str = "interference", overrides: dict | None = None,
            seconds: float = 2.0) -> dict:
    """Run the benchmark and return the numbers (steps per second, ratios)."""
    import sim
    from sim import stepping
    from sim.integrators import KernelArguments

    scene = sim.scenes.build(scene_name, **(overrides or {}))
    simulation = sim.Simulation(scene)
    simulation.step(2)
    results: dict = {
        "scene": scene_name,
        "lattice": f"{scene.model.nx}x{scene.model.ny}",
        "particles": scene.model.n_particles,
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}",
        "load_average": os.getloadavg()[0],
        "integrators": {},
    }
    for integrator in sim.INTEGRATORS:
        simulation.reset()
        simulation.integrator = integrator
        simulation.dt = scene.dt
        if integrator in ("euler", "heun"):
            simulation.dt = scene.dt / 10  # keep the unstable methods finite while timing
        simulation.step(1)
        burst = {"euler": 20, "heun": 10, "verlet": 100, "rk4": 20}[integrator]
        unstable = integrator in ("euler", "heun")

        def kernel(steps: int, simulation=simulation) -> None:
            simulation._integrator.advance(simulation.state, steps, simulation.dt)

        def checked(steps: int, simulation=simulation) -> None:
            simulation.step(steps)

        # Euler and Heun gain energy at every dt: start each burst from the scene's initial
        # state so that long measurements never reach a blow-up
        prepare = simulation.reset if unstable else None
        kernel_rate = _best_rate(kernel, burst, seconds, prepare=prepare)
        checked_rate = _best_rate(checked, burst, seconds, prepare=prepare)
        numpy_rate = _numpy_rate(
            scene.model, integrator, simulation.state.positions, simulation.state.velocities,
            simulation.dt, seconds / 2,
        )
        results["integrators"][integrator] = {
            "kernel_steps_per_second": kernel_rate,
            "simulation_steps_per_second": checked_rate,
            "numpy_steps_per_second": numpy_rate,
            "speedup_over_numpy": kernel_rate / numpy_rate,
        }

    # what specialisation buys: the same undamped scene through the general kernel
    model = scene.model
    arguments = KernelArguments.from_model(model)
    state = sim.State.from_particle_arrays(model, scene.initial_positions, scene.initial_velocities)
    work = [np.zeros((model.dim, 4, model.nx)) for _ in range(4)]
    general = (0.0, 0.0, np.zeros(3))

    def specialised(steps: int) -> None:
        stepping.rk4_steps(steps, scene.dt, arguments.linear, arguments.out_of_plane,
                           state.positions, state.velocities, arguments.inverse_mass,
                           arguments.uniform_inverse_mass, arguments.parameters,
                           arguments.dashpot, arguments.drag,
                           arguments.gravity, *work)

    def unspecialised(steps: int) -> None:
        stepping.rk4_steps(steps, scene.dt, arguments.linear, arguments.out_of_plane,
                           state.positions, state.velocities, arguments.inverse_mass,
                           None, arguments.parameters, *general, *work)

    if arguments.dashpot is None and arguments.drag is None and arguments.gravity is None:
        specialised_rate = _best_rate(specialised, 5, seconds)
        general_rate = _best_rate(unspecialised, 5, seconds)
        results["specialisation"] = {
            "integrator": "rk4",
            "specialised_steps_per_second": specialised_rate,
            "general_steps_per_second": general_rate,
            "gain": specialised_rate / general_rate,
        }
    return results


def print_table(results: dict) -> None:
    print(f"scene {results['scene']} ({results['lattice']} = {results['particles']:,} particles), "
          f"float64, one thread; {results['machine']}; load average {results['load_average']:.1f}")
    header = f"{'integrator':10s} {'kernel steps/s':>15s} {'Simulation.step':>16s} " \
             f"{'numpy steps/s':>14s} {'kernel/numpy':>13s}"
    print(header)
    print("-" * len(header))
    for name, row in results["integrators"].items():
        print(f"{name:10s} {row['kernel_steps_per_second']:15.1f} "
              f"{row['simulation_steps_per_second']:16.1f} {row['numpy_steps_per_second']:14.2f} "
              f"{row['speedup_over_numpy']:12.1f}x")
    if "specialisation" in results:
        row = results["specialisation"]
        print(f"\nscene flags pick a specialised kernel: RK4 {row['specialised_steps_per_second']:.1f} "
              f"steps/s without damping/drag/gravity terms, {row['general_steps_per_second']:.1f} "
              f"with them present but zero ({row['gain']:.2f}x)")


def main(arguments: argparse.Namespace) -> int:
    from app.cli import parse_overrides

    results = measure(arguments.scene, parse_overrides(arguments.overrides), arguments.seconds)
    if arguments.json:
        print(json.dumps(results, indent=2))
    else:
        print_table(results)
    return 0
