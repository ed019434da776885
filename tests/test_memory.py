"""A server that drops large arrays gives their memory back (``app.memory``): measured in a fresh
process, the same allocation pattern with glibc's dynamic threshold and with it fixed."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

PATTERN = """
import json, sys
import numpy as np
from app import memory
fixed = memory.return_large_blocks() if sys.argv[1] == "fixed" else None

def rss():
    return int(open("/proc/self/statm").read().split()[1]) * 4096

big = np.ones(4_000_000); del big  # one large block freed: glibc raises its threshold
before = rss()
frames, kept = [], []
for k in range(20):  # a frame's arrays of a few MB, and a small array that stays after each
    frames.append(np.ones(300_000))
    kept.append(np.ones(300))
del frames
print(json.dumps({"fixed": fixed, "retained": rss() - before}))
"""


def retained(mode: str) -> dict:
    done = subprocess.run([sys.executable, "-c", PATTERN, mode], capture_output=True, text=True,
                          check=True, timeout=120)
    return json.loads(done.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_freed_frames_go_back_to_the_system_once_the_threshold_is_fixed():
    dynamic, fixed = retained("dynamic"), retained("fixed")
    assert fixed["fixed"] is True
    # with the dynamic threshold the heap keeps the freed frames under the small arrays
    assert dynamic["retained"] > 20e6, dynamic
    assert fixed["retained"] < 0.25 * dynamic["retained"], (fixed, dynamic)
