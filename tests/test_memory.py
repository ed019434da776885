"""A server that drops large arrays gives their memory back (``app.memory``): measured in a fresh
process, the same allocation pattern with glibc's dynamic threshold and with it fixed."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

PATTERN = """
import json, sys, threading
import numpy as np
from app import memory
fixed = memory.return_large_blocks() if sys.argv[1] == "fixed" else None

def rss():
    return int(open("/proc/self/statm").read().split()[1]) * 4096

def frames():
    keep = []
    for k in range(60):  # each frame: arrays of a few MB, a small object kept now and then
        arrays = [np.ones(300_000 + 1000 * k) for _ in range(4)]
        if k % 3 == 0:
            keep.append(bytes(200))
        del arrays
    return keep

kept = []
big = np.ones(4_000_000); del big  # one large block freed: glibc raises its threshold
before = rss()
threads = [threading.Thread(target=lambda: kept.append(frames())) for _ in range(3)]
for thread in threads: thread.start()
for thread in threads: thread.join()
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
    # with the dynamic threshold the threads' arenas keep tens of MB of freed frames
    assert dynamic["retained"] > 20e6, dynamic
    assert fixed["retained"] < 0.25 * dynamic["retained"], (fixed, dynamic)
