"""Recording overhead and file size per frame, per logging mode (``oscillators record``).

    .venv/bin/python -m benchmarks.recording_speed [--frames 100] [--quick]

For each scene (``grid`` 12x8, a 200x200 lattice, ``interference`` 682x383) and each logging
mode, the scene is first run for a few hundred steps unrecorded (so the field images show waves,
not a flat lattice), then ``--frames`` frames are recorded one step apart through a
``sim.runtime.runner.Runner``.  Printed per mode:

* ms/frame: wall time per recorded frame, simulation included;
* overhead: ms/frame above the same runner with a no-op subscriber, measured just before (the
  bare simulation: step, blow-up check and the frame's energy account, which the runner
  computes anyway); noisy when other processes share the cores;
* recorder: ms/frame spent in the recorder itself (colour map, encoding, rerun calls), the
  figure least disturbed by other load on the machine;
* KB/frame: (file size - size of the same recording with no frame) / frames, and the
  extrapolation to MB per 1000 frames; static data (rest positions, topology) is excluded.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: python benchmarks/recording_speed.py
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np

import sim
from app.recording import Recorder, RecordingOptions
from app.recording.field import video_available
from sim.runtime.runner import Runner


@dataclasses.dataclass(frozen=True)
class Case:
    label: str
    scene: str
    overrides: dict
    warmup_steps: int
    modes: dict[str, RecordingOptions]


def cases(quick: bool) -> list[Case]:
    big_modes = {
        "video (H.264)": RecordingOptions(field="video"),
        "video, in runner thread": RecordingOptions(field="video", background=False),
        "jpeg q80": RecordingOptions(field="jpeg"),
        "raw float32": RecordingOptions(field="raw"),
        "raw float16": RecordingOptions(field="raw", raw_dtype="float16"),
        "positions only": RecordingOptions(field="none", positions="all"),
    }
    if not video_available():
        big_modes = {k: v for k, v in big_modes.items() if "video" not in k}
    if quick:
        big_modes = {k: v for k, v in big_modes.items() if "runner thread" not in k}
    return [
        Case("grid 12x8", "grid", {}, 100, {
            "auto: particles + springs": RecordingOptions(),
            "auto, in runner thread": RecordingOptions(background=False),
        }),
        Case("lattice 200x200", "grid", {"nx": 200, "ny": 200}, 200, big_modes),
        Case("interference 682x383", "interference", {}, 300, big_modes),
    ]


def _simulation(case: Case) -> sim.Simulation:
    scene = sim.scenes.build(case.scene, **case.overrides)
    simulation = sim.Simulation(scene)
    simulation.step(case.warmup_steps)
    return simulation


def bare_ms_per_frame(case: Case, frames: int) -> float:
    runner = Runner(_simulation(case))
    runner.subscribe(lambda frame: None)
    runner.advance(2)
    started = time.perf_counter()
    runner.advance(frames)
    return (time.perf_counter() - started) / frames * 1e3


def record(
    case: Case, options: RecordingOptions, frames: int, path: Path
) -> tuple[float, float, int]:
    """(ms per frame, recorder's own ms per frame, file bytes) for ``frames`` frames (0: static
    data only)."""
    simulation = _simulation(case)
    runner = Runner(simulation)
    started = time.perf_counter()
    with Recorder(path, simulation.scene, options=options) as recorder:
        recorder.attach(runner)
        if frames:
            runner.advance(frames)
    elapsed = time.perf_counter() - started
    own = recorder.logging_seconds / max(frames, 1) * 1e3
    return elapsed / max(frames, 1) * 1e3, own, path.stat().st_size


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100, help="frames per measurement")
    parser.add_argument("--quick", action="store_true", help="fewer modes (no thread variants)")
    arguments = parser.parse_args(argv)
    np.seterr(all="ignore")
    frames = arguments.frames
    print(f"{frames} frames per measurement, one step apart; cpu count {os.cpu_count()}")
    header = (f"{'scene':22s} {'mode':27s} {'ms/frame':>9s} {'overhead':>9s} {'recorder':>9s} "
              f"{'kB/frame':>9s} {'MB/1000 fr':>10s}")
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as directory:
        for case in cases(arguments.quick):
            bare = bare_ms_per_frame(case, frames)
            print(f"{case.label:22s} {'bare simulation (runner)':27s} {bare:9.1f}", flush=True)
            for label, options in case.modes.items():
                # Measured again next to each mode: other load on the machine drifts.
                bare = bare_ms_per_frame(case, frames)
                _, _, static_bytes = record(case, options, 0, Path(directory, "static.rrd"))
                ms, own, total_bytes = record(case, options, frames, Path(directory, "run.rrd"))
                per_frame = (total_bytes - static_bytes) / frames
                print(f"{'':22s} {label:27s} {ms:9.1f} {ms - bare:9.1f} {own:9.1f} "
                      f"{per_frame / 1e3:9.1f} {per_frame * 1000 / 1e6:10.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
