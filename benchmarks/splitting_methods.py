"""Error against work (force evaluations) of every compiled integrator, and the energy error of a
long run: the figures of docs/accuracy.md ("Splitting methods").

Work-precision: the largest position error at T against a reference (the exact normal-mode
solution on the linear grid; Blanes-Moan at a 16 times smaller step on the nonlinear grid and the
FPU chain), for steps spaced so that every method spends the same force evaluations per second of
simulated time.  Long run: the largest relative energy error of the 12x8 grid over 2,000 s at
dt = 0.02 s.

    python benchmarks/splitting_methods.py --json splitting.json --plot docs/images/splitting.png
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import sim  # noqa: E402
from sim.integrators.registry import describe  # noqa: E402

METHODS = ("verlet", "yoshida4", "blanes-moan", "euler", "heun", "ralston3", "rk4")
EVALUATIONS_PER_SECOND = (12, 24, 48, 96, 192)
"""Force evaluations per simulated second of the work-precision sweeps."""


def scenes() -> dict[str, tuple[sim.Scene, float, str]]:
    """name: (scene, T (s), reference integrator)."""
    return {
        "linear grid": (sim.scenes.build("grid", linear=True, rest_length=0.9), 10.0, "exact"),
        "nonlinear grid": (sim.scenes.build("grid"), 10.0, "blanes-moan"),
        "FPU chain": (sim.scenes.build("fput"), 660.0, "blanes-moan"),
    }


def positions_at(scene: sim.Scene, name: str, dt: float, until: float) -> np.ndarray:
    """The positions at ``until`` (NaN where the run blew up: the step is unstable)."""
    simulation = sim.Simulation(scene, integrator=name, dt=dt)
    try:
        simulation.step(round(until / dt))
    except sim.BlowUpError:
        return np.full_like(scene.initial_positions, np.nan)
    return simulation.state.particle_positions().copy()


def work_precision(scene: sim.Scene, until: float, reference_name: str) -> dict:
    finest = describe(reference_name).force_evaluations / (16 * max(EVALUATIONS_PER_SECOND))
    reference = positions_at(scene, reference_name, 0.05 if reference_name == "exact"
                             else finest, until)
    scale = float(np.abs(scene.initial_positions - scene.model.rest_positions).max())
    table = {}
    for name in METHODS:
        evaluations = describe(name).force_evaluations
        rows = []
        for rate in EVALUATIONS_PER_SECOND:
            dt = evaluations / rate
            error = float(np.abs(positions_at(scene, name, dt, until) - reference).max()) / scale
            rows.append({"evaluations_per_second": rate, "dt": dt,
                         "relative_error": error if math.isfinite(error) else None})
        table[name] = rows
    return table


def long_run_energy(seconds: float = 2000.0, dt: float = 0.02) -> dict:
    scene = sim.scenes.build("grid")
    result = {}
    for name in METHODS:
        simulation = sim.Simulation(scene, integrator=name, dt=dt)
        start = simulation.energy().total
        series = []
        for _ in range(20):
            try:
                simulation.step(round(seconds / 20 / dt))
            except sim.BlowUpError:
                series.append(math.inf)
                break
            series.append(abs(simulation.energy().total - start) / start)
        result[name] = {"after_100_s": series[0], "largest": max(series), "at_end": series[-1],
                        "evaluations_per_second": describe(name).force_evaluations / dt}
    return result


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    figure, axes = plt.subplots(1, len(results), figsize=(13, 4.2), dpi=100, sharey=False)
    for axis, (scene_name, table) in zip(axes, results.items(), strict=True):
        for name, rows in table.items():
            colour = np.array(describe(name).colour) / 255.0
            xs = [row["evaluations_per_second"] for row in rows if row["relative_error"]]
            ys = [row["relative_error"] for row in rows if row["relative_error"]]
            axis.loglog(xs, ys, "o-", color=colour, label=describe(name).short_label)
        axis.set_xticks(EVALUATIONS_PER_SECOND, [str(rate) for rate in EVALUATIONS_PER_SECOND])
        axis.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        axis.set_title(scene_name)
        axis.set_xlabel("force evaluations per simulated second")
        axis.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("largest position error / initial displacement")
    axes[0].legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", help="write the figures to this JSON file")
    parser.add_argument("--plot", help="draw the work-precision picture to this PNG file")
    arguments = parser.parse_args()
    results = {name: work_precision(*case) for name, case in scenes().items()}
    energy = long_run_energy()
    for scene_name, table in results.items():
        print(f"\n{scene_name}: relative position error at equal force evaluations per second")
        print("method        " + "".join(f"{rate:>10d}" for rate in EVALUATIONS_PER_SECOND))
        for name, rows in table.items():
            print(f"{name:13s} " + "".join(
                f"{row['relative_error']:10.2e}" if row["relative_error"] is not None
                else f"{'unstable':>10s}" for row in rows))
    print("\n12x8 grid, dt = 0.02 s, 2,000 s: largest relative energy error")
    for name, row in energy.items():
        print(f"{name:13s} after 100 s {row['after_100_s']:.2e}   largest {row['largest']:.2e}"
              f"   ({row['evaluations_per_second']:.0f} evaluations/s)")
    if arguments.json:
        Path(arguments.json).write_text(json.dumps({"work_precision": results,
                                                    "long_run_energy": energy}, indent=2))
    if arguments.plot:
        plot(results, Path(arguments.plot))


if __name__ == "__main__":
    main()
