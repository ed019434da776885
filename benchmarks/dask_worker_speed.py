"""How fast a Dask worker of a sweep steps the flagship with kernels it compiled itself.

Starts a real cluster (``dask scheduler`` and one ``dask worker`` process, one thread) on
127.0.0.1 with an empty numba cache (``NUMBA_CACHE_DIR`` a new folder), and asks the worker to
build the scene, make its kernels ready by stepping (compiled in the worker, as a sweep's first
run on a fresh cluster does) and time ``--steps`` steps; then a second worker process, on the
cache the first one wrote, does the same.  ``import sim`` in a worker asks numba for ``max``
(``sim.runtime.optimisation``), so both should step alike (``docs/web.md``, "Compiled apart").

    .venv/bin/python benchmarks/dask_worker_speed.py [--scene interference] [--integrator verlet]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.helpers import free_port  # noqa: E402


def timed_run(scene: str, integrator: str, steps: int) -> dict:
    """In the worker: seconds to make the kernels ready, then steps per second."""
    import sim

    simulation = sim.Simulation(sim.scenes.build(scene), integrator=integrator)
    started = time.perf_counter()
    simulation.step(65)
    ready = time.perf_counter() - started
    best = float("inf")
    for _ in range(3):
        started = time.perf_counter()
        simulation.step(steps)
        best = min(best, time.perf_counter() - started)
    return {"ready": ready, "steps_per_second": steps / best, "pid": os.getpid()}


def one_worker(address: str, env: dict, scene: str, integrator: str, steps: int) -> dict:
    from dask.distributed import Client

    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                               "--nthreads", "1", "--nworkers", "1", "--no-nanny"], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=60)
            return client.submit(timed_run, scene, integrator, steps, pure=False).result()
    finally:
        worker.terminate()
        worker.wait(10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--integrator", default="verlet")
    parser.add_argument("--steps", type=int, default=300)
    arguments = parser.parse_args()
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    with tempfile.TemporaryDirectory(prefix="dask-numba-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache,
               "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
        for key in ("NUMBA_OPT", "OSCILLATORS_NUMBA_OPT"):
            env.pop(key, None)
        scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                                      "--host", "127.0.0.1", "--port", str(port),
                                      "--dashboard-address", ":0"], env=env,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(3)
            for case in ("compiled in the worker (empty cache)", "a new worker reading that cache"):
                result = one_worker(address, env, arguments.scene, arguments.integrator,
                                    arguments.steps)
                print(f"{case:40s} ready after {result['ready']:5.1f} s, "
                      f"{result['steps_per_second']:8.1f} steps/s", flush=True)
        finally:
            scheduler.terminate()
            scheduler.wait(10)


if __name__ == "__main__":
    main()
