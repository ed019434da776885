"""Kernel variants chosen per host by measurement, not by CPU name.

Which way of computing 1/sqrt is faster in the float64 spring loops depends on the CPU and on the
loop: with 512-bit vectors and slow double square roots the single-precision estimate refined by
two Newton steps wins; where double square root and division are fast (e.g. 256-bit AVX2 cores)
plain ``1 / sqrt(x)`` can.  On one AVX2 host the estimate was 10 % faster in RK4's force sweeps
and 25 % slower in Verlet's fused leapfrog, so each loop family (``LOOPS``) is measured on its
own loop.  ``inverse_sqrt_estimate(loop)`` times both variants at first use, keeps the answer in
a small JSON file under the user's cache directory (keyed by the loop, the CPU's name and
features and the numba version, so another host or compiler measures again) and returns it.
``OSCILLATORS_INVERSE_SQRT=estimate`` or ``=divide`` forces a variant for every loop.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np


def _host_key() -> str:
    import llvmlite.binding as llvm
    import numba

    text = f"{llvm.get_host_cpu_name()}|{llvm.get_host_cpu_features().flatten()}|{numba.__version__}"
    text += f"|{os.environ.get('NUMBA_CPU_NAME', '')}|{os.environ.get('NUMBA_CPU_FEATURES', '')}"
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def _cache_file() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "coupled-oscillators" / "host_tuning.json"


LOOPS = ("sweep", "leapfrog")
"""The loop families measured apart: the force sweeps (``sim.loops.row_sweep.accelerations``: RK4,
Heun, Euler, damped Verlet) and undamped Verlet's fused leapfrog (``sim.loops.leapfrog``)."""


def _loop_seconds(loop: str, estimate: object) -> float:
    """Best time of ``loop`` (float64) over a 512 x 64 pre-tensioned lattice."""
    from sim.forces.springs import SpringParameters
    from sim.forces.terms import Terms
    from sim.loops.leapfrog import LeapfrogWork, leapfrog_steps
    from sim.loops.row_sweep import accelerations

    nx, ny = 512, 64
    generator = np.random.default_rng(0)
    rows, columns = np.meshgrid(np.arange(ny, dtype=float), np.arange(nx, dtype=float), indexing="ij")
    position = np.stack([columns, rows]) + 0.01 * generator.standard_normal((2, ny, nx))
    velocity = np.zeros_like(position)
    out = np.zeros_like(position)
    parameters = SpringParameters(1.0, 0.9, 0.1, 1.0, 0.0, 0.0, inverse_sqrt_estimate=estimate)
    inverse_mass = np.ones((ny, nx))
    inverse_mass.setflags(write=False)  # as the model's (``sim.model.read_only``)
    # a planar lattice of equal masses, nonlinear springs, no other term
    terms = Terms(linear=None, out_of_plane=None, inverse_mass=inverse_mass,
                  uniform_inverse_mass=1.0)
    if loop == "leapfrog":  # on one thread
        block_starts = np.array([0, ny], dtype=np.int64)
        work = LeapfrogWork(np.zeros((2, 3, nx)), np.zeros((1, 3, nx)), np.zeros((1, 3, nx + 1)))
        arguments = (np.full((1, 2), 0.01), terms, parameters, position, velocity, block_starts,
                     work, 0.0, None, np.zeros((1, 3)), None, np.zeros((1, 2)))

        def run() -> None:
            leapfrog_steps(*arguments)
    else:
        arguments = (terms, parameters, position, velocity, out)

        def run() -> None:
            accelerations(*arguments)
    run()  # compile
    best = float("inf")
    for _ in range(15):
        started = time.perf_counter()
        for _ in range(4):
            run()
        best = min(best, time.perf_counter() - started)
    return best


@functools.cache
def inverse_sqrt_estimate(loop: str = "sweep") -> object:
    """True if the estimate-and-Newton 1/sqrt is faster in float64 in ``loop`` (one of
    ``LOOPS``) on this host, else None (the value ``SpringParameters.inverse_sqrt_estimate``
    takes)."""
    if loop not in LOOPS:
        raise ValueError(f"no loop family {loop!r}; one of {', '.join(LOOPS)}")
    forced = os.environ.get("OSCILLATORS_INVERSE_SQRT", "").strip().lower()
    if forced in ("estimate", "divide"):
        return True if forced == "estimate" else None
    try:
        key = f"{loop}|{_host_key()}"
    except Exception:  # no host information: keep the portable variant
        return None
    path = _cache_file()
    try:
        known = json.loads(path.read_text())
    except (OSError, ValueError):
        known = {}
    if key in known and isinstance(known[key], dict) and "estimate_faster" in known[key]:
        return True if known[key]["estimate_faster"] else None
    divide, estimate = _measured(loop)
    estimate_faster = estimate < 0.97 * divide
    known[key] = {"estimate_faster": estimate_faster, "divide_seconds": divide,
                  "estimate_seconds": estimate}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.with_suffix(f".{os.getpid()}.tmp")
        partial.write_text(json.dumps(known, indent=1))
        partial.replace(path)
    except OSError:
        pass  # measured again next time
    return True if estimate_faster else None


def _measured(loop: str) -> tuple[float, float]:
    """The best times of ``loop`` with 1/sqrt(x) and with the estimate, measured in a child
    process that reads both from numba's cache, after another child compiled them: a kernel
    compiled in a process runs slower there than one read from the cache ("Compiled apart" in
    ``sim.runtime.warming``), and the loops compiled here would stay in this process.
    Measured here if a child fails."""
    import subprocess
    import sys

    environment = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    environment["PYTHONPATH"] = os.pathsep.join(
        [root, *filter(None, [environment.get("PYTHONPATH")])])
    try:
        for _ in range(2):  # compile, then measure what the cache holds
            result = subprocess.run([sys.executable, "-m", "sim.loops.host_tuning", loop],
                                    capture_output=True, env=environment, check=True,
                                    timeout=600)
        divide, estimate = (float(word) for word in result.stdout.split()[-2:])
        return divide, estimate
    except (OSError, ValueError, subprocess.SubprocessError):
        return _loop_seconds(loop, None), _loop_seconds(loop, True)


def describe() -> str:
    """One line for benchmark output."""
    chosen = ", ".join(
        f"{loop} {'estimate + 2 Newton steps' if inverse_sqrt_estimate(loop) else '1/sqrt(x)'}"
        for loop in LOOPS)
    return f"float64 1/sqrt: {chosen} (measured at first use)"


if __name__ == "__main__":  # the child of ``_measured``: prints the two times
    import sys

    print(_loop_seconds(sys.argv[1], None), _loop_seconds(sys.argv[1], True))
