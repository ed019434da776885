"""How the step's size changes the catenary's motion: the observed order of convergence.

    .venv/bin/python benchmarks/catenary_order.py                 # the preset, RK4 and Verlet
    .venv/bin/python benchmarks/catenary_order.py --gravity 0.981 # a tenth of the gravity

Runs the catenary preset to ``--time`` seconds at a step halved five times from 0.01 s and prints,
for each integrator, the largest change of any particle's position between consecutive halvings
(m).  A method of order p divides it by 2^p at each halving while the forces are smooth; the
preset's lattice sags through its bottom wall, where the springs to the wall anchors pass through
zero length and their force jumps, and the changes stop shrinking at the method's order
(docs/accuracy.md, "choose").
"""

from __future__ import annotations

import argparse

import numpy as np

import sim


def changes(integrator: str, time: float, gravity: float | None) -> list[float]:
    """Largest position change (m) between consecutive halvings of the step."""
    overrides = {} if gravity is None else {"gravity": gravity}
    positions = []
    for steps in (75, 150, 300, 600, 1200, 2400):
        simulation = sim.Simulation(sim.scenes.build("catenary", **overrides),
                                    integrator=integrator, dt=time / steps)
        simulation.step(steps)
        positions.append(np.array(simulation.state.positions, dtype=float))
    return [float(np.abs(a - b).max()) for a, b in zip(positions[:-1], positions[1:], strict=True)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--time", type=float, default=0.75, help="end time (s), default 0.75")
    parser.add_argument("--gravity", type=float, default=None,
                        help="gravity (m/s^2) instead of the preset's 9.81")
    parser.add_argument("--integrators", default="rk4,verlet", help="default rk4,verlet")
    arguments = parser.parse_args()
    for name in arguments.integrators.split(","):
        values = changes(name, arguments.time, arguments.gravity)
        ratios = [a / b for a, b in zip(values[:-1], values[1:], strict=True) if b > 0]
        print(f"{name:8s} changes {', '.join(f'{v:.2g}' for v in values)} m; "
              f"ratios {', '.join(f'{r:.1f}' for r in ratios)}")


if __name__ == "__main__":
    main()
