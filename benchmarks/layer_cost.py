"""What the absorbing layer costs in velocity Verlet's leapfrog steps, and where.

    .venv/bin/python benchmarks/layer_cost.py                       # default layer and 10 deep
    .venv/bin/python benchmarks/layer_cost.py --widths 3 --processes 8
    .venv/bin/python benchmarks/layer_cost.py --widths 3 --threads 2

Times ``sim.loops.leapfrog.leapfrog_steps`` itself (float64; ``--threads``: its threaded form) on
the 682x383 interference lattice: without the layer, with it, and with its side strips or its bands
emptied (the layer's record with no lines in those parts), so that the side strips' part, the bands'
part and what is left when both are empty are told apart.  Each variant is timed in a process of its
own (best of ``--rounds`` rounds of ``--steps`` steps from the same state), the variants' processes
alternating, ``--processes`` of each; the median of a variant's processes counts.  Every process
loads both kernels (with the layer and without) in the same order, so that each variant runs among
the same code: the same sweep runs several per cent faster or slower from one process to the next,
with what else the process loaded before it.  ``oscillators bench`` measures the whole
``Simulation.step`` (its "instruments" line); this splits the layer's part.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import subprocess
import sys
import time

import numpy as np

import sim
from sim.forces.absorbing_kicks import LINES, PARTS
from sim.loops import leapfrog
from sim.runtime.warming import REHEARSED_STEPS, rehearse_reading

VARIANTS = ("plain", "layer", "bands only", "side strips only", "both emptied")
"""The variants timed: without the layer, with it, and with parts of it emptied."""


def layer_record(simulation: sim.Simulation, variant: str):
    """The layer's record as the steps take it for ``variant`` (None: without the layer)."""
    if variant == "plain":
        return None
    stepper = simulation._integrator
    blocks = stepper._block_starts.size - 1
    full = stepper.sponge.arguments(0.5 * simulation.dt, np.float64, stepper.parallel, blocks)
    emptied = {"layer": (), "bands only": ("left", "right"),
               "side strips only": ("bottom", "top"), "both emptied": PARTS}[variant]
    geometry = full.geometry.copy()
    geometry[[PARTS.index(part) for part in emptied], LINES] = 0
    return full._replace(geometry=geometry)


def time_variant(width: int, variant: str, rounds: int, steps: int, threads: int) -> float:
    """Best seconds per step of ``variant`` on ``threads`` threads over ``rounds`` rounds, in
    this process."""
    scene = sim.scenes.build("interference")
    model = scene.model.replace(boundary="absorbing", sponge_width=width)
    layered = dataclasses.replace(scene, model=model)
    # both kernels in every process, loaded in the same order, so that every variant runs among
    # the same code; read from numba's cache, compiled apart if missing (kernels compiled in
    # this process would run slower: sim.runtime.warming, "Compiled apart")
    for kernels in (scene, layered):
        rehearse_reading(kernels, ("verlet", scene.dt, "float64", threads, REHEARSED_STEPS))
        simulation = sim.Simulation(kernels, integrator="verlet", threads=threads)
        simulation.step(100)  # waves in the layer
    stepper, state = simulation._integrator, simulation.state
    dt = stepper._dt(simulation.dt)
    layer = layer_record(simulation, variant)
    start = state.positions.copy(), state.velocities.copy()

    steps_of = leapfrog.leapfrog_steps_parallel if stepper.parallel else leapfrog.leapfrog_steps
    totals = np.zeros((stepper._block_starts.size - 1, 2))

    def run(count: int) -> None:
        steps_of(
            np.full((count, 2), dt), *stepper.kernel, state.positions, state.velocities,
            stepper._block_starts, stepper._leapfrog_work, 0.0, None, stepper._saved, layer,
            totals)
    run(1)
    best = float("inf")
    for _ in range(rounds):
        state.positions[...], state.velocities[...] = start
        started = time.perf_counter()
        run(steps)
        best = min(best, (time.perf_counter() - started) / steps)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--widths", default=f"{sim.model.boundaries.DEFAULT_LAYER_WIDTH},10",
                        help="layer widths in particles (default: the default layer's and 10)")
    parser.add_argument("--rounds", type=int, default=20, help="rounds per process")
    parser.add_argument("--steps", type=int, default=20, help="steps per round")
    parser.add_argument("--processes", type=int, default=5, help="processes per variant")
    parser.add_argument("--threads", type=int, default=1, help="threads of the steps")
    parser.add_argument("--variant", choices=VARIANTS, help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    widths = [int(w) for w in arguments.widths.split(",")]
    if arguments.variant:  # one process's timing, for the parent
        print(time_variant(widths[0], arguments.variant, arguments.rounds, arguments.steps,
                           arguments.threads))
        return
    for width in widths:
        measure(width, arguments.rounds, arguments.steps, arguments.processes, arguments.threads)


def measure(width: int, rounds: int, steps: int, processes: int, threads: int) -> None:
    """Time every variant in ``processes`` processes each, alternating, and print the medians."""
    times: dict[str, list[float]] = {variant: [] for variant in VARIANTS}
    for _ in range(processes):
        for variant in VARIANTS:
            output = subprocess.run(
                [sys.executable, __file__, "--widths", str(width), "--rounds", str(rounds),
                 "--steps", str(steps), "--threads", str(threads), "--variant", variant],
                check=True, capture_output=True, text=True).stdout
            times[variant].append(float(output.split()[-1]))
    plain = statistics.median(times["plain"])
    print(f"layer {width} particles deep, 682x383, {threads} thread(s), ms per step, median of "
          f"{processes} processes (ratio to the plain sweep; the processes' range):")
    for variant, seconds in times.items():
        median = statistics.median(seconds)
        print(f"  {variant:18s} {median * 1e3:7.3f} ms  {median / plain:5.2f}x  "
              f"({min(seconds) * 1e3:.3f}-{max(seconds) * 1e3:.3f})")


if __name__ == "__main__":
    main()
