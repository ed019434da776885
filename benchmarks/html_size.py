"""Size and peak memory of a run shared as one HTML page (``oscillators movie SCENE -o X.html``),
each made by its own process, as a user makes it.

    .venv/bin/python -m benchmarks.html_size                        # the grid and the flagship
    .venv/bin/python -m benchmarks.html_size --scenes grid          # one scene
    .venv/bin/python -m benchmarks.html_size -- --fps 10            # extra args go to `movie`

Prints, per scene: the file's size (MB = 10^6 bytes), what the command said of its length
(frames and simulated seconds), the wall time and the peak resident memory of the command's
process (``ru_maxrss`` of that child alone, MB = 2^20 bytes).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def measure(scene: str, extra: list[str]) -> str:
    """One scene's page made in a fresh process: its size, length, time and peak memory."""
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / f"{scene}.html"
        command = [sys.executable, "-m", "app.cli", "movie", scene, "-o", str(path), *extra]
        started = time.perf_counter()
        before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        done = subprocess.run(command, check=True, env=os.environ.copy(), capture_output=True,
                              text=True)
        elapsed = time.perf_counter() - started
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        said = [line for line in done.stdout.splitlines() if line.startswith("wrote")]
        length = said[-1].split(": ", 1)[1].split(" (")[0] if said else "?"
        if peak <= before:  # an earlier child was larger: ru_maxrss keeps the largest
            peak_text = f"<= {peak / 1024:.0f} MB"
        else:
            peak_text = f"{peak / 1024:.0f} MB"
        return (f"{scene}: {path.stat().st_size / 1e6:.2f} MB, {length}; made in {elapsed:.0f} s, "
                f"peak RSS {peak_text}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="grid,interference",
                        help="comma-separated scenes (default: grid,interference)")
    parser.add_argument("extra", nargs="*", help="more arguments for `oscillators movie`")
    arguments = parser.parse_args()
    for scene in arguments.scenes.split(","):  # smallest first: each peak is its own
        print(measure(scene.strip(), arguments.extra), flush=True)


if __name__ == "__main__":
    main()
