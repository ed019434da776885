"""The lattice's size limits: how large a lattice may be, and whether it fits in memory now.

``nx`` and ``ny`` are at most ``MAX_SIDE`` and the lattice has at most ``MAX_PARTICLES``
particles; ``check_size`` also refuses a lattice whose simulation would not fit in the memory
available now (``estimated_bytes``, checked before any array is allocated).
"""

from __future__ import annotations

import psutil


class ModelError(ValueError):
    """An invalid lattice parameter (the message says which one and why)."""


MAX_SIDE = 20_000
"""Largest nx or ny (a 20,000-particle chain; the paper's largest run is 682x383)."""

MAX_PARTICLES = 20_000_000
"""Largest nx * ny: about 5 GB for a 2-D simulation (see ``estimated_bytes``), and still about 4
RK4 steps per second."""


def estimated_bytes(nx: int, ny: int, dim: int) -> int:
    """Memory (bytes) a ``Simulation`` of an nx x ny lattice in ``dim`` dimensions needs at its
    peak, a slightly generous estimate (measured peaks: 225 bytes per particle in 2-D, 330 in 3-D).

    Per particle, in float64 (8 bytes) per component (dim of them):
      2 state (positions, velocities) + 2 blow-up checkpoint + 2 scene initial condition
      + 1 rest positions + 2 integrator work arrays (Verlet; RK4 and Heun keep a few rows only)
      + 3 temporaries of the energy and strain evaluations  = 12 arrays: 96 * dim bytes;
    plus masses and inverse masses (16 bytes) and about 2 springs per particle, each with two
    int64 end indices and a float64 strain (48 bytes).  2-D: 256 bytes, 3-D: 352 bytes.
    """
    particles = nx * ny
    springs = ny * (nx + 1) + (ny + 1) * nx
    return particles * (96 * dim + 16) + springs * 24


def available_memory() -> int | None:
    """Bytes of memory available now to a new process without swapping (``psutil``: Linux's
    MemAvailable); None when it cannot be read."""
    try:
        return int(psutil.virtual_memory().available)
    except (OSError, RuntimeError, AttributeError, NotImplementedError):
        return None


def check_size(nx: int, ny: int, dim: int) -> None:
    """Raise ``ModelError`` if the lattice exceeds ``MAX_SIDE`` / ``MAX_PARTICLES`` or if its
    simulation would need more memory than is available (``estimated_bytes``)."""
    for name, value in (("nx", nx), ("ny", ny)):
        if value > MAX_SIDE:
            raise ModelError(f"{name} must be at most {MAX_SIDE:,}, got {value:,}")
    if nx * ny > MAX_PARTICLES:
        raise ModelError(f"{nx}x{ny} = {nx * ny:,} particles is more than the {MAX_PARTICLES:,} allowed")
    needed = estimated_bytes(nx, ny, dim)
    available = available_memory()
    if available is not None and needed > available:
        raise ModelError(
            f"a {nx}x{ny} lattice in {dim}-D needs about {needed / 2**30:.2f} GB of memory "
            f"({needed / (nx * ny):.0f} bytes per particle), only {available / 2**30:.2f} GB "
            "are available; use a smaller nx/ny"
        )
