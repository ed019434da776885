"""File sizes of the default recordings: every preset, a comparison and the web app's recording.

    .venv/bin/python -m benchmarks.recording_sizes            # all (about 1 minute on 2 cores)
    .venv/bin/python -m benchmarks.recording_sizes grid chain # some presets only

Sizes in MB = 10^6 bytes.  The web case is what ``app/web/recording.py`` does: a ``Recorder``
with the defaults attached to a runner that publishes a frame every step (the web app's pace on
small lattices: one step per frame, 60 frames per second of wall time), here for 60 s of wall
time (3600 published frames).  Also prints the largest position error of float32 storage
against the float64 state, in metres and in pixels of a 1920-pixel-wide view of the lattice.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def record(arguments: list[str], path: Path) -> tuple[float, float]:
    from app.cli import main

    started = time.perf_counter()
    status = main(["record", *arguments, "-o", str(path), "--quiet", "--force"])
    if status != 0:
        raise SystemExit(f"record {arguments} failed with status {status}")
    return path.stat().st_size / 1e6, time.perf_counter() - started


def web_recording(directory: Path, name: str = "grid", frames: int = 3600) -> tuple[float, int]:
    import sim
    from app.recording import Recorder
    from sim.runtime.runner import Runner

    scene = sim.scenes.build(name)
    runner = Runner(sim.Simulation(scene))
    path = directory / f"web-{name}.rrd"
    recorder = Recorder(path, scene, integrator=scene.integrator, dt=scene.dt)
    recorder.attach(runner, snapshot=True)
    runner.play()  # frames published while playing, as the web app's loop publishes them
    runner.advance(frames, every=1)
    runner.pause()
    recorder.close()
    return path.stat().st_size / 1e6, recorder.frames_logged


def float32_error(name: str) -> tuple[float, float]:
    """Largest |float32(x) - x| (m) over a run of the preset, and that in 1920-pixel views."""
    import sim

    scene = sim.scenes.build(name)
    simulation = sim.Simulation(scene)
    worst = 0.0
    for _ in range(20):
        simulation.step(max(1, int(scene.duration / scene.dt) // 20))
        positions = simulation.peek_positions()
        worst = max(worst, float(np.abs(positions.astype(np.float32) - positions).max()))
    width = (max(scene.model.nx, scene.model.ny) + 1) * scene.model.spacing
    return worst, worst / width * 1920


def main(names: list[str]) -> None:
    import sim

    presets = names or sim.scenes.names()
    with tempfile.TemporaryDirectory() as directory:
        folder = Path(directory)
        print(f"{'recording':48s} {'MB':>6s} {'seconds':>8s}")
        for name in presets:
            size, seconds = record([name], folder / f"{name}.rrd")
            print(f"{'oscillators record ' + name:48s} {size:6.2f} {seconds:8.1f}", flush=True)
        if not names:
            size, seconds = record(["grid", "--compare", "euler,verlet,rk4"], folder / "cmp.rrd")
            print(f"{'oscillators record grid --compare euler,verlet,rk4':48s} {size:6.2f} "
                  f"{seconds:8.1f}")
            size, seconds = record(["membrane", "--compare", "verlet,rk4"], folder / "cmp3.rrd")
            print(f"{'oscillators record membrane --compare verlet,rk4':48s} {size:6.2f} "
                  f"{seconds:8.1f}")
            for scene in ("grid", "membrane"):
                size, frames = web_recording(folder, scene)
                print(f"{'web app, ' + scene + ', 60 s (3600 steps), ' + str(frames) + ' frames':48s}"
                      f" {size:6.2f}")
            for scene in ("grid", "membrane"):
                metres, pixels = float32_error(scene)
                print(f"float32 positions, {scene}: largest error {metres:.2g} m = {pixels:.2g} "
                      "pixel of a 1920-pixel view")


if __name__ == "__main__":
    main(sys.argv[1:])
