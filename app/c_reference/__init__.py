"""The hand-written C kernels of the lattice step, the yardstick ``oscillators bench`` measures
against: a fused symplectic (leapfrog) step, its OpenMP row-block version, and a fused RK4, built
with ``gcc -O3 -march=native -ffast-math`` (``ckernels.c``, ``ckernels_t.h``).

``METHODS`` lists what the C kernels implement: which integrator each matches, in which
precisions and whether on threads.  ``load()`` compiles them once per source version into a cache
directory (``$XDG_CACHE_HOME`` or ``~/.cache``, else a temporary one) and returns a
``CReference``, or None and the reason when no C compiler is available.  Arrays are the C
code's own layout: padded ``(ny + 2, nx + 2)`` fields whose ring holds the wall anchors; the
lattice is pre-tensioned (k = 1 N/m, L = 0.9 a) with random masses, so every spring does the same
work as in the project's undamped planar kernels.
"""

from __future__ import annotations

import ctypes
import dataclasses
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

_SOURCES = ("ckernels.c", "ckernels_t.h")


@dataclasses.dataclass(frozen=True)
class CMethod:
    """One method of the C kernels: the integrator it matches (its name in ``sim.integrators.registry``),
    what it is called, the precisions it runs in and whether it runs on OpenMP threads."""

    integrator: str
    label: str
    precisions: tuple[str, ...]
    threaded: bool
    runner: str
    """The ``CReference`` method that builds its step function."""

    def configuration(self, precision: str, threads: int) -> tuple[str, str, int]:
        """(integrator, precision, threads) of the C kernel nearest to the integrator run in
        ``precision`` on ``threads``: the same where the C method has it, else float64 / 1."""
        return (self.integrator, precision if precision in self.precisions else self.precisions[0],
                threads if self.threaded else 1)

    def describe(self, precision: str, threads: int) -> str:
        """``"C fused leapfrog, float32, 2 threads (OpenMP row blocks)"``."""
        kind = f"{threads} threads (OpenMP row blocks)" if threads > 1 else "1 thread"
        return f"{self.label}, {precision}, {kind}"


METHODS = (
    CMethod("verlet", "C fused leapfrog", ("float64", "float32"), threaded=True,
            runner="_leapfrog_runner"),
    CMethod("rk4", "C fused RK4", ("float64",), threaded=False, runner="_rk4_runner"),
)
"""What the C kernels implement, in the order ``oscillators bench`` measures them."""
_FLAGS = ("-O3", "-march=native", "-ffast-math", "-fopenmp", "-shared", "-fPIC", "-std=gnu11")


def _cache_directory() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    directory = Path(base) / "coupled-oscillators" / "c_reference"
    try:
        directory.mkdir(parents=True, exist_ok=True)
        return directory
    except OSError:
        return Path(tempfile.mkdtemp(prefix="oscillators-c-reference-"))


def build() -> tuple[Path | None, str]:
    """Compile the library if needed; returns (path, "") or (None, why it could not)."""
    compiler = shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")
    if compiler is None:
        return None, "no C compiler (gcc) found: C reference skipped"
    here = Path(__file__).parent
    try:
        digest = hashlib.sha256(b"".join((here / name).read_bytes() for name in _SOURCES))
    except OSError as error:
        return None, f"C reference sources missing ({error}): C reference skipped"
    digest.update(" ".join(_FLAGS).encode())
    library = _cache_directory() / f"libckernels-{digest.hexdigest()[:16]}.so"
    if not library.exists():
        partial = library.with_suffix(f".{os.getpid()}.tmp")
        command = [compiler, *_FLAGS, "-o", str(partial), str(here / "ckernels.c"), "-lm"]
        result = subprocess.run(command, capture_output=True, text=True)
        if result.returncode != 0:
            return None, f"C reference failed to compile: {result.stderr.strip()[:300]}"
        partial.replace(library)
    return library, ""


class CReference:
    """Steps per second of the C kernels on an nx x ny lattice."""

    STIFFNESS = 1.0
    REST_LENGTH = 0.9

    def __init__(self, library: Path) -> None:
        self.library = ctypes.CDLL(str(library))
        pointer, integer = ctypes.c_void_p, ctypes.c_int
        for suffix, real in (("d", ctypes.c_double), ("f", ctypes.c_float)):
            step = getattr(self.library, f"step_rowbuf_{suffix}")
            step.argtypes = [pointer] * 5 + [integer, integer, real, real, real, integer]
            step.restype = None
            parallel = getattr(self.library, f"step_rowbuf_omp_{suffix}")
            parallel.argtypes = [pointer] * 5 + [integer, integer, real, real, real, integer, integer]
            parallel.restype = None
        double = ctypes.c_double
        self.library.rk4_step_d.argtypes = (
            [pointer] * 5 + [integer, integer, double, double, double, pointer, pointer, integer]
        )
        self.library.rk4_step_d.restype = None

    @staticmethod
    def _state(nx: int, ny: int, dtype) -> list[np.ndarray]:
        """Padded (ny + 2, nx + 2) x, y, vx, vy, 1/m: a slightly disturbed pre-tensioned lattice."""
        generator = np.random.default_rng(0)
        rows, columns = np.meshgrid(np.arange(ny + 2.0), np.arange(nx + 2.0), indexing="ij")
        x, y = columns.copy(), rows.copy()
        x[1:-1, 1:-1] += 0.01 * generator.standard_normal((ny, nx))
        y[1:-1, 1:-1] += 0.01 * generator.standard_normal((ny, nx))
        velocity_x, velocity_y = np.zeros_like(x), np.zeros_like(x)
        inverse_mass = 1.0 / generator.uniform(0.5, 1.5, size=x.shape)
        return [np.ascontiguousarray(a, dtype=dtype) for a in (x, y, velocity_x, velocity_y,
                                                                 inverse_mass)]

    def step_function(self, method: str, nx: int, ny: int, dtype=np.float64, threads: int = 1):
        """A function ``run(steps)`` advancing a C lattice; ``method`` is the integrator of one
        of ``METHODS``: "verlet" (the symplectic leapfrog step, f64 or f32, OpenMP row blocks
        when threads > 1) or "rk4" (f64, serial)."""
        for candidate in METHODS:
            if candidate.integrator == method:
                arrays = self._state(nx, ny, dtype)
                return getattr(self, candidate.runner)(arrays, nx, ny, np.dtype(dtype).type, threads)
        raise ValueError(f"no C reference for {method!r}")

    def _constants(self, real):
        return real(self.STIFFNESS), real(self.STIFFNESS * self.REST_LENGTH), real(0.01)

    def _leapfrog_runner(self, arrays, nx: int, ny: int, real, threads: int):
        pointers = [a.ctypes.data for a in arrays]
        suffix = "f" if real is np.float32 else "d"
        k, k_rest, dt = self._constants(real)
        serial = getattr(self.library, f"step_rowbuf_{suffix}")
        parallel = getattr(self.library, f"step_rowbuf_omp_{suffix}")

        def leapfrog(steps: int, arrays=arrays) -> None:  # arrays: keeps the memory alive
            if threads == 1:
                serial(*pointers, nx + 2, ny + 2, k, k_rest, dt, steps)
            else:
                parallel(*pointers, nx + 2, ny + 2, k, k_rest, dt, steps, threads)

        return leapfrog

    def _rk4_runner(self, arrays, nx: int, ny: int, real, threads: int):
        pointers = [a.ctypes.data for a in arrays]
        k, k_rest, dt = self._constants(real)
        stage = np.stack(arrays[:4]).copy()
        accumulator = np.zeros_like(stage)
        step = self.library.rk4_step_d

        def run(steps: int, arrays=arrays) -> None:  # arrays: keeps the memory alive
            step(*pointers, nx + 2, ny + 2, k, k_rest, dt, stage.ctypes.data,
                 accumulator.ctypes.data, steps)

        return run


def load() -> tuple[CReference | None, str]:
    """The C reference, or (None, the reason it is unavailable)."""
    library, reason = build()
    if library is None:
        return None, reason
    try:
        return CReference(library), ""
    except OSError as error:
        return None, f"C reference could not be loaded: {error}"

