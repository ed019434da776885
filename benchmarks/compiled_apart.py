"""How fast a process steps with kernels it compiled itself, against kernels a child process
compiled and it read from numba's cache (``sim.runtime.warming``, ``sim.runtime.optimisation``,
``docs/web.md``, "Compiled apart").

    .venv/bin/python benchmarks/compiled_apart.py                   # interference, Verlet
    .venv/bin/python benchmarks/compiled_apart.py --integrator rk4 --precision float32
    .venv/bin/python benchmarks/compiled_apart.py --threads 2
    .venv/bin/python benchmarks/compiled_apart.py --scene grid --steps 5000 --fresh-host

Each case runs in a process of its own with an empty numba cache (a new temporary folder): it
builds the scene, has a ``KernelPreparer`` make its kernels ready, either rehearsing in its own
thread ("here": compiled in the process that steps, as a script or a notebook does) or as the
page's preparer does ("apart"), then times ``--steps`` steps; the cases "here" at numba's
default level and at ``max`` (what ``import sim`` sets), "apart" at the default level (the
command line and the page), and a process that reads the cache each "here" or "apart" case left.
``--fresh-host`` also empties the per-host 1/sqrt choice (``sim.loops.host_tuning``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

CASE = """
import json, sys, time
import sim
from sim.runtime.warming import KernelPreparer, compiles_started, kernel_key, rehearse_simulation
mode, scene, steps, integrator, precision, threads = sys.argv[1:7]
steps, threads = int(steps), int(threads)
started = time.perf_counter()
simulation = sim.Simulation(sim.scenes.build(scene), integrator=integrator, precision=precision,
                            threads=threads)
built = time.perf_counter() - started
preparer = KernelPreparer(rehearse_simulation if mode == "here" else None)
key = kernel_key(simulation, 64)
while preparer.prepare(key, simulation, 64) is not None:
    time.sleep(0.05)
ready = time.perf_counter() - started
simulation.step(64)
before = compiles_started()
clock = time.perf_counter()
simulation.step(steps)
rate = steps / (time.perf_counter() - clock)
print(json.dumps({"built": built, "ready": ready, "steps_per_second": rate,
                  "compiles_while_stepping": compiles_started() - before}))
"""


def run(mode: str, arguments: argparse.Namespace, environment: dict) -> dict:
    result = subprocess.run([sys.executable, "-c", CASE, mode, arguments.scene,
                             str(arguments.steps), arguments.integrator, arguments.precision,
                             str(arguments.threads)],
                            capture_output=True, text=True, env=environment, check=True,
                            cwd=Path(__file__).resolve().parent.parent)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--integrator", default="verlet")
    parser.add_argument("--precision", default="float64")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--fresh-host", action="store_true",
                        help="also measure the 1/sqrt choice anew (an empty user cache)")
    arguments = parser.parse_args()
    default = {"OSCILLATORS_NUMBA_OPT": "0"}  # numba's default level, as the command line
    for name, mode, level in (("here, default level", "here", default), ("here, max", "here", {}),
                              ("apart, default level", "apart", default)):
        with tempfile.TemporaryDirectory() as folder:
            environment = {key: value for key, value in os.environ.items()
                           if key not in ("NUMBA_OPT", "OSCILLATORS_NUMBA_OPT")}
            environment.update(level, NUMBA_CACHE_DIR=str(Path(folder) / "numba"))
            if arguments.fresh_host:
                environment["XDG_CACHE_HOME"] = str(Path(folder) / "user")
            cases = [(name, run(mode, arguments, environment)),
                     ("  its cache, read", run("apart", arguments, environment))]
            for case, figures in cases:
                print(f"{case:22s} built {figures['built']:5.1f} s, ready {figures['ready']:5.1f} s, "
                      f"{figures['steps_per_second']:7.0f} steps/s, "
                      f"{figures['compiles_while_stepping']} compiles while stepping", flush=True)

if __name__ == "__main__":
    main()
