"""Movie size and peak memory: ``oscillators movie`` run as its own process, as a user runs it.

    .venv/bin/python -m benchmarks.movie_memory                       # the flagship's default GIF
    .venv/bin/python -m benchmarks.movie_memory --suffix mp4          # its default MP4
    .venv/bin/python -m benchmarks.movie_memory -- --frames 1000      # more frames (extra args go
                                                                      # to `oscillators movie`)

Prints the file's size (MB = 10^6 bytes), its frame count, the wall time and the peak resident
memory of the command's process (``ru_maxrss`` of the child, MB = 2^20 bytes).  Movies are
encoded frame by frame as they are drawn, so the peak does not grow with the number of frames:
compare ``-- --frames 100`` with ``-- --frames 1000``.
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--suffix", default="gif", choices=("mp4", "webm", "gif"))
    parser.add_argument("extra", nargs="*", help="more arguments for `oscillators movie`")
    arguments = parser.parse_args()
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / f"movie.{arguments.suffix}"
        command = [sys.executable, "-m", "app.cli", "movie", arguments.scene, "-o", str(path),
                   "--quiet", *arguments.extra]
        started = time.perf_counter()
        subprocess.run(command, check=True, env=os.environ.copy())
        elapsed = time.perf_counter() - started
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # kB -> MB
        import av

        with av.open(str(path)) as container:
            frames = sum(1 for _ in container.decode(video=0))
        size = path.stat().st_size / 1e6
    print(f"oscillators movie {arguments.scene} -o movie.{arguments.suffix} "
          f"{' '.join(arguments.extra)}".rstrip())
    print(f"  file {size:.1f} MB, {frames} frames, {elapsed:.0f} s wall, peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
