"""A long-running server gives the memory of large arrays back to the system when it frees them.

The web app makes and drops large arrays all the time, in several threads: each frame's
positions, strains and colours (a few MB each on the flagship's 261,206 particles), the panel's
mode energies, the pictures.  glibc's allocator serves a request of 128 kB or more from a
mapping of its own and unmaps it when freed, but after the first such free it raises that
threshold to the size freed (up to 32 MB, "dynamic mmap threshold", mallopt(3)): from then on
the frames' arrays come from the heap's arenas, which keep what is freed, so the server's
resident memory grows to the peak of every thread's arena.  ``serve interference --play``
with 20 pages measured 1,467 MB resident at its peak this way, and 586 MB with the threshold
fixed (``benchmarks/web_load.py``, ``docs/web.md``).

``return_large_blocks()`` fixes the threshold (which also stops its dynamic adjustment):
blocks of ``LARGE_BLOCK`` bytes or more are mapped on their own and go back to the system when
freed.  A no-op where the C library is not glibc.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

LARGE_BLOCK = 256 * 1024
"""Bytes from which a block is mapped on its own (glibc's default start is 128 kB)."""
M_MMAP_THRESHOLD = -3
"""glibc's mallopt parameter number for the threshold (malloc.h)."""


def return_large_blocks(threshold: int = LARGE_BLOCK) -> bool:
    """Fix glibc's mmap threshold at ``threshold`` bytes for this process; returns whether the
    C library took it (False off glibc)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return mallopt(M_MMAP_THRESHOLD, int(threshold)) == 1
