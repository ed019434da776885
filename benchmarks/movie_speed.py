"""Movie rendering speed: ``interference`` (682x383) at 720p, 1000 frames over the scene's 150 s.

    .venv/bin/python -m benchmarks.movie_speed                 # the goal: < 60 s, < 20 MB
    .venv/bin/python -m benchmarks.movie_speed --frames 200    # a quicker look

Prints wall time, frames per second and file size (MB = 10^6 bytes), and the time of the same
run without a movie (simulation only), measured in the same process after a warm-up that
compiles the kernels.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="interference")
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--size", default="1280x720")
    parser.add_argument("--suffix", default="mp4", choices=("mp4", "webm", "gif"))
    arguments = parser.parse_args()

    import sim
    from app.movie import render_movie

    width, height = (int(v) for v in arguments.size.split("x"))
    scene = sim.scenes.build(arguments.scene)
    with tempfile.TemporaryDirectory() as directory:
        warm = Path(directory) / f"warm.{arguments.suffix}"
        render_movie(scene, warm, frames=3, duration=0.2, size=(width, height), progress=False)
        simulation = sim.Simulation(scene)
        steps = int(round(scene.duration / simulation.dt))
        started = time.perf_counter()
        simulation.step(steps)
        bare = time.perf_counter() - started
        path = Path(directory) / f"movie.{arguments.suffix}"
        started = time.perf_counter()
        render_movie(scene, path, frames=arguments.frames, size=(width, height), progress=False)
        elapsed = time.perf_counter() - started
        size = path.stat().st_size / 1e6
    print(f"{arguments.scene} {scene.model.nx}x{scene.model.ny}, {arguments.frames} frames at "
          f"{width}x{height} .{arguments.suffix}, {scene.duration:g} s simulated; "
          f"cpu count {os.cpu_count()}")
    print(f"movie: {elapsed:.1f} s wall ({arguments.frames / elapsed:.1f} frames/s), {size:.2f} MB")
    print(f"the same {steps} steps without a movie: {bare:.1f} s")


if __name__ == "__main__":
    main()
