"""A server that drops large arrays gives their memory back (``app.memory``): measured in a fresh
process, the same allocation pattern with the threshold where glibc's dynamic adjustment takes
it after a large block is freed (32 MB, mallopt(3)) and with it fixed at ``LARGE_BLOCK``."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

PATTERN = """
import json, os, resource, sys
import numpy as np
from app import memory
threshold = memory.LARGE_BLOCK if sys.argv[1] == "fixed" else 32 * 1024 * 1024
fixed = memory.return_large_blocks(threshold)

def rss():
    return int(open("/proc/self/statm").read().split()[1]) * 4096

before = rss()
frames, kept = [], []
for k in range(20):  # a frame's arrays of a few MB, and a small array that stays after each
    frames.append(np.ones(300_000))
    kept.append(np.ones(300))
del frames
print(json.dumps({"fixed": fixed, "retained": rss() - before,
                  "environment": {k: v for k, v in os.environ.items() if "MALLOC" in k
                                  or "GLIBC" in k or "PRELOAD" in k},
                  "data limit": resource.getrlimit(resource.RLIMIT_DATA)}))
"""


def retained(mode: str) -> dict:
    done = subprocess.run([sys.executable, "-c", PATTERN, mode], capture_output=True, text=True,
                          check=True, timeout=120)
    return json.loads(done.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_freed_frames_go_back_to_the_system_once_the_threshold_is_fixed():
    raised, fixed = retained("raised"), retained("fixed")
    assert fixed["fixed"] is True and raised["fixed"] is True
    # with the threshold raised the heap keeps the freed frames under the small arrays
    assert raised["retained"] > 20e6, raised
    assert fixed["retained"] < 0.25 * raised["retained"], (fixed, raised)
