"""The kernel variants that test modules on both pytest-xdist workers need, compiled once.

With ``--dist loadfile`` each worker runs whole modules, and on a cold numba cache both workers
reach the variants many modules share (the grid's RK4 and Verlet loops, linear and not, with and
without dashpots) in their first minute, each compiling its own copy.  At the start of the
session each worker walks ``SHARED`` in its own order (the second worker from the end), holding a
file lock per variant while it rehearses it (``sim.runtime.warming.rehearse``): the first worker
to take a lock compiles the variant and numba writes it to its on-disk cache; the other, waiting
on that lock, then reads it from the cache in a fraction of a second.  So both workers compile
different variants at the same time and none twice.  Without xdist (one process) nothing is
done here: the tests compile what they need as they go.

The list follows the compile log (``tests/compile_log.py``): each entry was compiled by both
workers in a cold run of the default suite.
"""

from __future__ import annotations

import fcntl

import pytest

SHARED = (
    ("grid", "rk4", {}),
    ("grid", "verlet", {}),
    ("grid", "rk4", {"linear": True}),
    ("grid", "verlet", {"linear": True}),
    ("ionic", "rk4", {}),
    ("grid", "verlet", {"damping": 0.5, "drag": 0.3, "gravity": 9.81}),
    ("grid", "rk4", {"linear": True, "drag": 0.3}),
)
"""(preset, integrator, scene changes) of each variant shared by test modules on both workers."""


def rehearse(preset: str, integrator: str, changes: dict) -> None:
    """Compile (or read from numba's cache) what a run of this variant calls."""
    import sim
    from sim.runtime.warming import rehearse as rehearse_run

    scene = sim.scenes.build(preset, nx=6, ny=4, **changes)
    rehearse_run(scene, integrator, scene.dt, "float64", 1, steps=3)


@pytest.fixture(scope="session", autouse=True)
def shared_kernels(request, tmp_path_factory):
    """Each xdist worker rehearses ``SHARED`` before its first test, one lock per variant."""
    worker = getattr(request.config, "workerinput", {}).get("workerid")
    if worker is None:
        return
    folder = tmp_path_factory.getbasetemp().parent  # shared by the workers of this run
    number = int(worker.removeprefix("gw") or 0)
    order = SHARED if number % 2 == 0 else SHARED[::-1]
    for preset, integrator, changes in order:
        name = "-".join([preset, integrator, *map(str, changes)])
        with open(folder / f"kernels-{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            rehearse(preset, integrator, changes)
