"""Recordings survive: a write that fails (a file-size limit standing in for a full disk), a
disk that fills during the run and SIGKILL leave a file that rerun's own reader
(``rerun.chunk.RrdReader``) reads back (SIGTERM: ``test_recording.test_signal_leaves_a_readable_file``);
the disk-space estimate is within 2x of the real size."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rerun as rr
from rerun.chunk import RrdReader

import sim
from app.cli import main
from app.recording import Recorder, RecordingError, RecordingOptions, destination
from sim.runtime.runner import Runner
from tests.test_recording import read_chunks, temporal, texts

REPO = Path(__file__).resolve().parent.parent

LIMITED = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # a write past the limit fails with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def errors_in(chunks: list) -> list:
    return [entry for entry in texts(chunks, "/log") if entry[2] == "ERROR"]


@pytest.mark.slow
def test_a_write_that_fails_mid_run_leaves_a_readable_file_ending_in_an_error(tmp_path):
    path = tmp_path / "limited.rrd"
    command = [sys.executable, "-c", LIMITED.format(limit=400_000), "record", "grid",
               "--steps", "3000", "--every", "2", "-o", str(path), "--quiet"]
    result = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=300,
                            env={**os.environ, "PYTHONPATH": str(REPO)})
    assert result.returncode == 2, result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert last.startswith("error: recording failed") and str(path) in last
    assert path.exists() and not Path(str(path) + ".partial").exists()
    chunks = read_chunks(path)
    steps = temporal(chunks, "/energy/total", "Scalars:scalars")
    assert len(steps) > 10
    errors = errors_in(chunks)
    assert errors and "recording stopped" in errors[-1][1]
    assert errors[-1][0] >= max(steps)  # at the last frame logged; the cut-off ones are lost


def test_a_disk_that_fills_during_the_run_ends_the_file_with_footer_and_error(tmp_path,
                                                                            monkeypatch):
    scene = sim.scenes.build("grid")
    free = {"bytes": 10**9}
    monkeypatch.setattr(destination, "free_bytes", lambda directory: free["bytes"])
    path = tmp_path / "filling.rrd"
    recorder = Recorder(path, scene, expected_frames=200)
    runner = Runner(sim.Simulation(scene))
    recorder.attach(runner)
    runner.advance(200, every=1)
    free["bytes"] = 100_000  # the disk fills: the next check stops the recording
    for _ in range(5):
        runner.advance(200, every=1)  # the runner detaches the failed recorder and goes on
    assert recorder.failure is not None
    with pytest.raises(RecordingError, match="disk nearly full"):
        recorder.close()
    part = destination.readable_part(path)
    assert part.complete and part.readable_bytes + 32 == part.total_bytes  # end message, footer
    chunks = read_chunks(path)
    errors = errors_in(chunks)
    assert errors and "disk nearly full" in errors[-1][1]


def test_a_disk_that_fills_before_the_first_write_says_so_and_leaves_no_file(
        tmp_path, monkeypatch, capsys):
    """The space check passed, then another writer took the disk before rerun wrote a byte:
    exit 2, one line naming the full disk, no file and no ``.partial`` left behind."""
    free = {"bytes": 10**9}
    monkeypatch.setattr(destination, "free_bytes", lambda directory: free["bytes"])

    def writer_finds_the_disk_full(stream, *args, **kwargs):
        free["bytes"] = 1_000
        raise RuntimeError("Failed to create file sink: No space left on device (os error 28)")

    monkeypatch.setattr(rr.RecordingStream, "save", writer_finds_the_disk_full)
    path = tmp_path / "late.rrd"
    assert main(["record", "grid", "--steps", "20", "--quiet", "-o", str(path)]) == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("error: recording failed") and "is full" in last, last
    assert "nothing was recorded" in last
    assert list(tmp_path.iterdir()) == []


def test_a_writer_error_at_the_start_on_a_disk_with_room_is_not_called_a_full_disk(
        tmp_path, monkeypatch):
    def writer_fails(stream, *args, **kwargs):
        raise RuntimeError("sink refused")

    monkeypatch.setattr(rr.RecordingStream, "save", writer_fails)
    path = tmp_path / "refused.rrd"
    with pytest.raises(RuntimeError, match="sink refused") as caught:
        Recorder(path, sim.scenes.build("grid"), expected_frames=10)
    assert not isinstance(caught.value, RecordingError)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_a_sigkilled_recorder_leaves_a_partial_that_reads_back(tmp_path, capsys):
    path = tmp_path / "killed.rrd"
    process = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "record", "interference", "--set", "nx=120",
         "--set", "ny=80", "--steps", "200000", "--every", "5", "--field", "jpeg",
         "-o", str(path), "--quiet"], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    partial = Path(str(path) + ".partial")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and (not partial.exists() or partial.stat().st_size < 1_500_000):
        time.sleep(0.1)
    process.send_signal(signal.SIGKILL)
    _, err = process.communicate(timeout=30)
    assert partial.exists() and not path.exists(), err
    part = destination.readable_part(partial)
    assert not part.complete
    # small messages: at most the last one (<= ~256 kB batched, plus one frame) is cut off
    assert part.total_bytes - part.readable_bytes < 400_000
    # the second writer is told what the left .partial is
    assert main(["record", "grid", "--steps", "2", "--quiet", "-o", str(path)]) == 2
    assert "oscillators record" in capsys.readouterr().err
    assert main(["record", str(partial)]) == 0
    assert "readable" in capsys.readouterr().out
    assert path.exists() and not partial.exists()
    assert path.stat().st_size == part.readable_bytes
    chunks = RrdReader(path).stream().to_chunks()
    steps = temporal(chunks, "/energy/total", "Scalars:scalars")
    assert len(steps) > 20 and max(steps) > 100


def test_the_disk_space_estimate_is_within_a_factor_two(tmp_path):
    for name, overrides, frames in (("grid", {}, 300), ("interference", {"nx": 100, "ny": 60}, 60),
                                    ("chain", {}, 400)):
        scene = sim.scenes.build(name, **overrides)
        path = tmp_path / f"{name}.rrd"
        runner = Runner(sim.Simulation(scene))
        options = RecordingOptions(frame_interval=0.0)
        with Recorder(path, scene, options=options, expected_frames=frames) as recorder:
            recorder.attach(runner)
            runner.publish()
            runner.advance(frames - 1, every=1)
        assert recorder.frames_logged == frames
        ratio = recorder.estimated_bytes / path.stat().st_size
        assert 0.5 <= ratio <= 2.0, (name, recorder.estimated_bytes, path.stat().st_size)


@pytest.mark.slow
def test_recordings_on_a_small_real_filesystem_that_another_writer_fills_all_read_back(tmp_path):
    """Four recorders on a 40 MB tmpfs while another program fills it: every recording stops
    with exit 2 and one line, and every file it leaves reads back whole with rerun's reader,
    its last entry the ERROR that says why (mounting needs root: skipped otherwise)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if os.geteuid() != 0 or subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=40m", "tmpfs", str(disk)],
            capture_output=True).returncode != 0:
        pytest.skip("mounting a small tmpfs needs root")
    try:
        recorders = [subprocess.Popen(
            [sys.executable, "-m", "app.cli", "record", "interference", "--set", "nx=120",
             "--set", "ny=80", "--steps", "20000", "--every", "5", "--field", "jpeg",
             "-o", str(disk / f"run{k}.rrd"), "--quiet"],  # each alone fits (about 20 MB)
            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for k in range(4)]
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:  # every recorder has written, 4 MB in all
            sizes = [path.stat().st_size for path in disk.glob("*.partial")]
            if len(sizes) == 4 and min(sizes) > 0 and sum(sizes) >= 4_000_000:
                break
            time.sleep(0.2)
        with open(disk / "filler", "wb") as filler:  # another writer takes what is left
            try:
                while True:
                    filler.write(b"\0" * 1_000_000)
                    filler.flush()
            except OSError:
                pass
        results = [process.communicate(timeout=300) for process in recorders]
        for process, (_, err) in zip(recorders, results, strict=True):
            assert process.returncode == 2, err
            assert err.strip().splitlines()[-1].startswith("error: recording failed"), err
        assert not list(disk.glob("*.partial"))
        for k in range(4):
            chunks = read_chunks(disk / f"run{k}.rrd")
            assert len(temporal(chunks, "/energy/total", "Scalars:scalars")) > 10
            errors = errors_in(chunks)
            assert errors and "recording stopped" in errors[-1][1], errors[-1:]
            assert "full" in errors[-1][1] and "full" in results[k][1]
    finally:
        subprocess.run(["umount", "-l", str(disk)], capture_output=True)


def test_a_flush_stuck_on_a_full_disk_stops_with_the_reason(tmp_path, monkeypatch):
    """Once rerun's file sink has failed to write (another program filled the disk), its flush
    waits out its whole timeout: the recording checks the disk between seconds of waiting and
    stops with the reason at once instead of seeming to hang."""
    from app.recording import destination

    class StuckStream:
        calls = 0

        def flush(self, timeout_sec: float) -> None:
            StuckStream.calls += 1
            raise RuntimeError(f"flush timed out after {timeout_sec} s")

    monkeypatch.setattr(destination, "free_bytes", lambda directory: 10_000)
    started = time.monotonic()
    with pytest.raises(destination.RecordingError, match="disk nearly full"):
        destination.flush(StuckStream(), tmp_path)
    assert StuckStream.calls == 1 and time.monotonic() - started < 1.0
    monkeypatch.setattr(destination, "free_bytes", lambda directory: 10**12)
    with pytest.raises(destination.RecordingError, match="did not finish writing in 2 s"):
        destination.flush(StuckStream(), tmp_path, timeout=2.0)
    assert StuckStream.calls >= 3


def test_a_close_stuck_in_rerun_is_given_up_after_its_time(monkeypatch):
    """rerun's disconnect after its file sink failed may wait for ever: it is given its time,
    then left behind (the file is ended by the recorder's own repair)."""
    from app.recording import destination

    class Stream:
        def __init__(self, seconds: float) -> None:
            self.seconds = seconds

        def disconnect(self) -> None:
            time.sleep(self.seconds)

    assert destination.disconnect(Stream(0.0), timeout=5.0)
    started = time.monotonic()
    assert not destination.disconnect(Stream(60.0), timeout=0.5)
    assert time.monotonic() - started < 2.0
