"""A long-running server gives the memory its threads freed back to the system now and then.

The web app makes and drops large arrays all the time, in several threads: each frame's
positions, strains and colours (a few MB each on the flagship's 261,206 particles), the panel's
mode energies, the pictures.  glibc's allocator serves a request of 128 kB or more from a
mapping of its own and unmaps it when freed, but after the first such free it raises that
threshold to the size freed (up to 32 MB, "dynamic mmap threshold", mallopt(3)): from then on
the frames' arrays come from the heap and the threads' arenas, which keep what is freed, so the
server's resident memory grows toward the sum of every arena's peak (``benchmarks/web_load.py``;
figures in ``docs/web.md``, "The server's memory").

Fixing the threshold low would map and unmap each of those arrays (a large numpy temporary then
has its pages faulted in again every time).  Instead the app keeps the
allocator as it is and calls ``give_back()`` every ``GIVE_BACK_SECONDS``: glibc's
``malloc_trim(0)`` returns the free pages of every arena to the system (a few milliseconds).
A no-op where the C library is not glibc.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys

GIVE_BACK_SECONDS = 2.0
"""Seconds between two returns of freed memory to the system while the web app runs."""


@functools.cache
def _trim():
    if not sys.platform.startswith("linux"):
        return None
    try:
        trim = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):
        return None
    trim.argtypes = (ctypes.c_size_t,)
    trim.restype = ctypes.c_int
    return trim


def give_back() -> bool:
    """Return the free memory of every allocator arena to the system (glibc's
    ``malloc_trim(0)``); returns whether the C library could (False off glibc)."""
    trim = _trim()
    if trim is None:
        return False
    trim(0)
    return True
