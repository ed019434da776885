"""The web app gives the memory its threads freed back to the system (``app.memory``): measured
in a fresh process, a frame pattern whose freed arrays the heap keeps, before and after
``give_back``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

PATTERN = """
import ctypes, json
import numpy as np
from app import memory

# where glibc's dynamic threshold goes after a large free (mallopt(3): at most 32 MB; M_MMAP_THRESHOLD
# is -3): the frames below then come from the heap, as a running server's do
ctypes.CDLL("libc.so.6").mallopt(-3, 32 * 1024 * 1024)

def rss():
    return int(open("/proc/self/statm").read().split()[1]) * 4096

before = rss()
frames, kept = [], []
for k in range(20):  # a frame's arrays of a few MB, and a small array that stays after each
    frames.append(np.ones(300_000))
    kept.append(np.ones(300))
del frames
kept_by_heap = rss() - before
given = memory.give_back()
print(json.dumps({"retained": kept_by_heap, "given back": given, "after": rss() - before}))
"""


def measured() -> dict:
    done = subprocess.run([sys.executable, "-c", PATTERN], capture_output=True, text=True,
                          check=True, timeout=120)
    return json.loads(done.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_the_frames_freed_memory_goes_back_to_the_system():
    result = measured()
    assert result["given back"] is True, result
    assert result["retained"] > 20e6, result  # the heap keeps the freed frames under the pins
    assert result["after"] < 0.1 * result["retained"], result
