"""Cost of the exact normal-mode solver on a large lattice, against the steppers.

    .venv/bin/python benchmarks/exact_speed.py [--scene interference] [--frames 20]

Prints the wall time of one frame of the exact solver (the state at a new time: modal
coefficients advanced in closed form, then inverse sine transforms) and of the first call (the
forward transform of the initial state), and, for the same simulated time per frame, the
stepping integrators' cost; all measured in this run on the scene with linearised springs.
"""

from __future__ import annotations

import argparse
import time

import sim
from sim.integrators.registry import descriptions


def best_seconds(action, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        started = time.perf_counter()
        action()
        best = min(best, time.perf_counter() - started)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--frame-time", type=float, default=0.25,
                        help="simulated seconds per frame (default 0.25, the web app's pacing)")
    arguments = parser.parse_args()
    scene = sim.scenes.build(arguments.scene, linear=True)
    print(f"{scene.summary()}; {arguments.frame_time:g} s of simulated time per frame")
    exact = sim.Simulation(scene, integrator="exact", dt=arguments.frame_time)
    started = time.perf_counter()
    exact.step(1)
    first = time.perf_counter() - started
    frame = best_seconds(lambda: exact.step(1), arguments.frames)
    print(f"exact   first call (forward transform + one frame): {first * 1e3:8.1f} ms")
    print(f"exact   one frame (any dt, no time-step error):     {frame * 1e3:8.1f} ms")
    steppers = [d.name for d in descriptions() if d.kernel and d.stability_factor is not None]
    for name in steppers:  # the compiled steppers that have a stable time step
        simulation = sim.Simulation(scene, integrator=name)
        steps = max(1, round(arguments.frame_time / simulation.dt))
        simulation.step(steps)  # compile
        seconds = best_seconds(lambda s=simulation, n=steps: s.step(n), max(3, arguments.frames // 4))
        print(f"{name:7s} {steps} steps of dt = {simulation.dt:g} s:{'':19s}{seconds * 1e3:8.1f} ms "
              f"(exact / {name}: {frame / seconds:.2f})")


if __name__ == "__main__":
    main()
