"""What the absorbing layer costs in velocity Verlet's leapfrog steps, and where.

    .venv/bin/python benchmarks/layer_cost.py                  # default layer and 10 deep
    .venv/bin/python benchmarks/layer_cost.py --widths 4,6,10 --rounds 20

Times ``sim.loops.leapfrog.leapfrog_steps`` itself (one thread, float64) on the 682x383 interference
lattice: without the layer, with it, and with its side strips or its bands emptied (the
layer's record with no lines in those parts), so that the side strips' part, the bands' part
and what is left when both are empty (the calls) are told apart.  Each
variant runs ``--steps`` steps per round from the same state; the best round of each counts,
the variants interleaved round by round.  ``oscillators bench`` measures the whole
``Simulation.step`` (its "instruments" line); this splits the sweep.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import sim
from sim.forces.absorbing_kicks import LINES, PARTS
from sim.loops import leapfrog
from sim.runtime.warming import REHEARSED_STEPS, rehearse_reading


def sweep(simulation: sim.Simulation):
    """A function running n leapfrog steps of ``simulation``'s state with a given layer tuple
    (None: without the layer)."""
    stepper = simulation._integrator
    kernel = stepper.kernel
    state = simulation.state
    dt = stepper._dt(simulation.dt)

    def run(layer, steps: int) -> None:
        leapfrog.leapfrog_steps(
            steps, dt, *kernel, state.positions, state.velocities, stepper._block_starts,
            stepper._leapfrog_work, 0.0, None, stepper._saved, layer, np.zeros((1, 2)))
    return run


def variants(simulation: sim.Simulation) -> dict:
    """The layer's tuple as the sweep takes it, and the same with parts emptied."""
    full = simulation._integrator.sponge.arguments(0.5 * simulation.dt, np.float64)

    def emptied(*parts: str):
        geometry = full.geometry.copy()
        geometry[[PARTS.index(part) for part in parts], LINES] = 0
        return full._replace(geometry=geometry)
    return {"layer": full, "bands only": emptied("left", "right"),
            "side strips only": emptied("bottom", "top"),
            "both emptied": emptied(*PARTS)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--widths", default=f"{sim.model.boundaries.DEFAULT_LAYER_WIDTH},10",
                        help="layer widths in particles (default: the default layer's and 10)")
    parser.add_argument("--rounds", type=int, default=10)
    parser.add_argument("--steps", type=int, default=10)
    arguments = parser.parse_args()
    widths = [int(w) for w in arguments.widths.split(",")]
    measure(widths, arguments.rounds, arguments.steps)


def measure(widths: list[int], rounds: int, steps: int) -> None:
    """Time and print the variants for each layer width."""
    scene = sim.scenes.build("interference")
    for width in widths:
        model = scene.model.replace(boundary="absorbing", sponge_width=width)
        for kernels in (dataclasses.replace(scene, model=model), scene):
            # read from numba's cache, compiled apart if missing: kernels compiled in this
            # process would run slower (sim.runtime.warming, "Compiled apart")
            rehearse_reading(kernels, ("verlet", scene.dt, "float64", 1, REHEARSED_STEPS))
        simulation = sim.Simulation(dataclasses.replace(scene, model=model), integrator="verlet")
        simulation.step(100)  # waves in the layer
        start = simulation.state.positions.copy(), simulation.state.velocities.copy()
        run = sweep(simulation)
        cases = {"plain": None, **variants(simulation)}
        for layer in cases.values():
            run(layer, 1)
        best = dict.fromkeys(cases, float("inf"))
        for _ in range(rounds):
            for name, layer in cases.items():
                simulation.state.positions[...], simulation.state.velocities[...] = start
                started = time.perf_counter()
                run(layer, steps)
                best[name] = min(best[name], (time.perf_counter() - started) / steps)
        plain = best["plain"]
        print(f"layer {width} particles deep, {model.nx}x{model.ny}, ms per step "
              f"(ratio to the plain sweep):")
        for name, seconds in best.items():
            print(f"  {name:18s} {seconds * 1e3:7.3f} ms  {seconds / plain:5.2f}x")


if __name__ == "__main__":
    main()
