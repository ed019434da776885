"""Bad command-line input: exit code 2, one clear line on stderr, no traceback, nothing lost."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest

from app.cli import main
from app.recording import Recorder, RecordingError
from app.recording.track import Track
from sim.scenes import building as scenes
from tests.test_recording import read_chunks, temporal, texts


def run_cli(arguments: list[str]) -> int:
    """``main(arguments)``, with argparse's SystemExit turned into its exit code."""
    try:
        return main(arguments)
    except SystemExit as exit_request:
        return int(exit_request.code or 0)


def assert_refused(capsys, arguments: list[str], *fragments: str) -> str:
    """The command exits with 2 and says why in one line naming every fragment."""
    assert run_cli(arguments) == 2
    error = capsys.readouterr().err
    lines = [line for line in error.splitlines() if line.strip()]
    assert len(lines) == 1, error
    assert "Traceback" not in error
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


# --- run: counts, durations, time steps ----------------------------------------------------------


@pytest.mark.parametrize(
    "option, value",
    [
        ("--duration", "inf"), ("--duration", "nan"), ("--duration", "-1"), ("--duration", "0"),
        ("--dt", "0"), ("--dt", "-1"), ("--dt", "nan"), ("--dt", "inf"), ("--dt", "abc"),
        ("--steps", "-5"), ("--steps", "0"), ("--steps", "2.5"),
    ],
)
def test_run_refuses_non_positive_or_non_finite_numbers(capsys, option, value):
    assert_refused(capsys, ["run", "chain", option, value, "--quiet"], option, value)


@pytest.mark.parametrize(
    "arguments",
    [["--dt", "1e-300"], ["--duration", "1e15"], ["--steps", "1000000000000"]],
)
def test_run_refuses_a_plan_too_long_and_says_how_long(capsys, arguments):
    line = assert_refused(capsys, ["run", "chain", *arguments, "--quiet"], "about", "limit")
    assert any(unit in line for unit in ("years", "days", "hours"))


@pytest.mark.parametrize(
    "arguments, fragment",
    [(["--dt", "1e300"], "dt (s) must be in (0, 1e+06]"),
     (["--set", "driver=column=0,frequency=0.6,amplitude=1e300,kind=force"],
      "driver amplitude (m) must be in [0, 1e+06]"),
     (["--threads", "100000"], "threads must be at most")],
)
def test_run_refuses_values_beyond_what_can_run_before_running(capsys, arguments, fragment):
    line = assert_refused(capsys, ["run", "chain", *arguments], fragment)
    assert "ran " not in capsys.readouterr().out, line


@pytest.mark.slow  # kernels of their own
def test_run_still_accepts_sensible_input(capsys):
    assert run_cli(["run", "chain", "--dt", "0.01", "--duration", "0.5", "--quiet"]) == 0
    assert "ran 50 steps" in capsys.readouterr().out


@pytest.mark.parametrize(
    "arguments",
    [["--set", "nx"], ["--set", "nx=0"], ["--set", "nx=-3"], ["--set", "nx=2.5"]],
)
def test_bad_overrides_are_one_line(capsys, arguments):
    assert_refused(capsys, ["run", "grid", *arguments, "--quiet"], "nx")


# --- record: options and output file ---------------------------------------------------------------


@pytest.mark.parametrize(
    "option, value",
    [
        ("--every", "0"), ("--every", "-2"), ("--steps", "0"), ("--duration", "nan"),
        ("--dt", "-0.1"), ("--jpeg-quality", "0"), ("--jpeg-quality", "200"),
        ("--field-scale", "0"), ("--positions", "0"), ("--positions", "some"),
    ],
)
def test_record_refuses_bad_options_before_running(tmp_path, capsys, option, value):
    output = tmp_path / "x.rrd"
    assert_refused(capsys, ["record", "chain", option, value, "-o", str(output), "--quiet"],
                   option)
    assert not list(tmp_path.iterdir())


def test_record_refuses_to_overwrite_without_force(tmp_path, capsys):
    output = tmp_path / "kept.rrd"
    output.write_bytes(b"precious")
    assert_refused(capsys, ["record", "chain", "--steps", "5", "-o", str(output), "--quiet"],
                   str(output), "--force")
    assert output.read_bytes() == b"precious"
    assert not list(tmp_path.glob("*.partial"))
    assert run_cli(["record", "chain", "--steps", "5", "-o", str(output), "--force",
                    "--quiet"]) == 0
    assert output.read_bytes() != b"precious"
    assert len(read_chunks(output)) > 0


def test_record_refuses_a_directory_as_output(tmp_path, capsys):
    assert_refused(capsys, ["record", "chain", "--steps", "5", "-o", f"{tmp_path}/", "--quiet"],
                   str(tmp_path), "directory")
    assert not list(tmp_path.iterdir())


def test_recorder_refuses_an_existing_file_unless_told_to_overwrite(tmp_path):
    scene = scenes.build("chain")
    output = tmp_path / "there.rrd"
    output.write_bytes(b"precious")
    with pytest.raises(RecordingError, match="already exists"):
        Recorder(output, scene)
    assert output.read_bytes() == b"precious"
    Recorder(output, scene, overwrite=True).close()
    assert len(read_chunks(output)) > 0


def _assert_stopped_cleanly(capsys, output: Path) -> list[tuple[int, str, str]]:
    """One error line; the file has its final name, reads back and ends with an ERROR entry."""
    error = capsys.readouterr().err
    lines = [line for line in error.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in error, error
    assert str(output) in lines[0]
    assert output.exists() and not Path(f"{output}.partial").exists()
    chunks = read_chunks(output)
    errors = [entry for entry in texts(chunks, "/log") if entry[2] == "ERROR"]
    assert len(errors) == 1
    steps = temporal(chunks, "/energy/total", "Scalars:scalars")
    assert 0 < len(steps) < 300  # the run stopped early, and what came before is there
    assert errors[0][0] == max(steps)
    return errors


def test_a_disk_that_fills_during_record_stops_it_and_keeps_a_readable_file(
    tmp_path, capsys, monkeypatch
):
    real = shutil.disk_usage
    calls = []

    def filling_disk(path):
        calls.append(path)  # the first look (before the run) sees space, later ones do not
        usage = real(path)
        return usage if len(calls) == 1 else usage._replace(free=0)

    monkeypatch.setattr(shutil, "disk_usage", filling_disk)
    output = tmp_path / "full.rrd"
    status = run_cli(["record", "grid", "--steps", "300", "--every", "1", "-o", str(output),
                      "--quiet"])
    assert status == 2
    errors = _assert_stopped_cleanly(capsys, output)
    assert "disk nearly full" in errors[0][1]


def test_a_write_error_during_record_stops_it_and_keeps_a_readable_file(
    tmp_path, capsys, monkeypatch
):
    real = Track.log_frame

    def failing_log_frame(track, frame):
        if track.frames_logged >= 20:
            raise OSError(errno.EIO, "Input/output error")
        real(track, frame)

    monkeypatch.setattr(Track, "log_frame", failing_log_frame)
    output = tmp_path / "broken.rrd"
    status = run_cli(["record", "grid", "--steps", "300", "--every", "1", "-o", str(output),
                      "--quiet"])
    assert status == 2
    errors = _assert_stopped_cleanly(capsys, output)
    assert "Input/output error" in errors[0][1]


# --- lattice size and memory ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "overrides, fragment",
    [
        (["nx=20000", "ny=20000"], "particles"), (["nx=1e12"], "nx must be at most"),
        (["ny=1e12"], "ny must be at most"), (["nx=0"], "nx"), (["ny=-4"], "ny"),
        (["nx=2.5"], "whole number"),
    ],
)
def test_huge_or_invalid_lattices_are_refused(capsys, overrides, fragment):
    arguments = [item for pair in overrides for item in ("--set", pair)]
    assert_refused(capsys, ["run", "grid", *arguments, "--steps", "1", "--quiet"], fragment)


def test_a_lattice_larger_than_the_memory_is_refused_before_allocating(monkeypatch):
    import tracemalloc

    import sim.model.limits

    monkeypatch.setattr(sim.model.limits, "available_memory", lambda: 100 * 2**20)
    tracemalloc.start()
    try:
        with pytest.raises(sim.model.ModelError, match=r"GB of memory.*0\.10 GB are available"):
            sim.model.Model.create(4000, 4000)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**20  # 16 million particles: nothing of that size was allocated


@pytest.mark.slow  # 300x200 lattices in 2-D and 3-D, the 3-D leapfrog compiled for it
def test_the_memory_estimate_covers_a_real_simulation():
    import tracemalloc

    import sim
    from sim.model.lattice import estimated_bytes

    for dim in (2, 3):  # compile the kernels first: numba's compiler allocates too
        warm = sim.Simulation(sim.scenes.build("grid", nx=8, ny=8, dim=dim), integrator="verlet")
        warm.step(70)
        warm.energy()
        warm.strains()
    for dim in (2, 3):
        tracemalloc.start()
        try:
            scene = sim.scenes.build("grid", nx=300, ny=200, dim=dim)
            simulation = sim.Simulation(scene, integrator="verlet")
            simulation.step(70)  # past a blow-up checkpoint
            simulation.energy()
            simulation.strains()
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak <= estimated_bytes(300, 200, dim)


# --- the study commands ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "arguments, fragment",
    [
        (["stability", "--precision", "0"], "--precision"),
        (["stability", "--precision", "-0.1"], "--precision"),
        (["stability", "--precision", "1e-300"], "--precision"),
        (["stability", "--precision", "nan"], "--precision"),
        (["stability", "--steps", "0"], "--steps"),
        (["stability", "--steps", "-5"], "--steps"),
        (["stability", "--steps", "10000000000"], "--steps"),
        (["stability", "--cases"], "--cases"),
        (["stability", "--cases", "no-such-case"], "no-such-case"),
        (["stability", "--integrators"], "--integrators"),
        (["stability", "--integrators", "leapfrog"], "leapfrog"),
        (["stability", "--plot", "/no/such/directory/s.png"], "/no/such/directory"),
        (["accuracy", "--dts"], "--dts"),
        (["accuracy", "--dts", "0.01", "0"], "--dts"),
        (["accuracy", "--dts", "inf"], "--dts"),
        (["accuracy", "--until", "0"], "--until"),
        (["accuracy", "--until", "nan"], "--until"),
        (["accuracy", "--tolerance", "0"], "--tolerance"),
        (["accuracy", "--tolerance", "2"], "--tolerance"),
        (["accuracy", "--integrators"], "--integrators"),
        (["accuracy", "--dts", "1e-12"], "limit"),
        (["accuracy", "--plot", "picture.txt"], "--plot"),
        (["dispersion", "--particles", "0"], "--particles"),
        (["dispersion", "--particles", "-3"], "--particles"),
        (["dispersion", "--particles", "100000000"], "--particles"),
        (["dispersion", "--stiffness", "0"], "--stiffness"),
        (["dispersion", "--mass", "-1"], "--mass"),
        (["dispersion", "--heavy", "inf"], "--heavy"),
        (["dispersion", "--stiffness", "1e12"], "limit"),
    ],
)
def test_study_options_are_checked_before_anything_runs(capsys, arguments, fragment):
    assert_refused(capsys, [*arguments, "--quiet"], fragment)


def test_a_recorder_whose_writes_fail_closes_its_file_and_the_runner_goes_on(
    tmp_path, monkeypatch
):
    import sim
    from sim.runtime.runner import Runner

    real = shutil.disk_usage
    calls = []

    def filling_disk(path):
        calls.append(path)
        usage = real(path)
        return usage if len(calls) == 1 else usage._replace(free=0)

    monkeypatch.setattr(shutil, "disk_usage", filling_disk)
    scene = sim.scenes.build("grid")
    runner = Runner(sim.Simulation(scene))
    output = tmp_path / "live.rrd"
    recorder = Recorder(output, scene)
    recorder.attach(runner)
    runner.advance(120, every=1)  # the recorder fails at its first flush (50 frames)
    assert runner.simulation.step_count == 120  # the simulation was not stopped
    assert recorder.failure is not None
    assert output.exists() and not Path(f"{output}.partial").exists()  # closed by on_error
    with pytest.raises(RecordingError, match="disk nearly full"):
        recorder.close()
    chunks = read_chunks(output)
    errors = [entry for entry in texts(chunks, "/log") if entry[2] == "ERROR"]
    assert len(errors) == 1 and errors[0][0] < 120


def test_the_accuracy_library_still_refuses_a_reference_beyond_the_rk4_limit():
    import sim
    from app.study.accuracy import accuracy_study

    with pytest.raises(ValueError, match="too long for a numerical reference"):
        accuracy_study(sim.scenes.build("chain"), integrators=["verlet"], dts=[1.0], until=1e12)


def test_serve_refuses_a_recordings_dir_that_does_not_exist_and_creates_nothing(tmp_path):
    import subprocess
    import sys

    missing = tmp_path / "a" / "b" / "c"
    result = subprocess.run(
        [sys.executable, "-m", "app.cli", "serve", "chain", "--port", "0", "--recordings-dir",
         str(missing)], capture_output=True, text=True, timeout=120,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)})
    assert result.returncode == 2
    assert f"--recordings-dir {missing} is not an existing directory" in result.stderr
    assert not (tmp_path / "a").exists()


def test_an_error_entry_cut_by_a_full_disk_is_cut_back_to_the_last_whole_message(
    tmp_path, monkeypatch
):
    """A recording whose writer failed mid-message on a full disk is ended by
    ``end_readably``; when its ERROR entry is written only in part (a full disk), the file is
    cut back to its last whole message, so it still reads back with what came before."""
    import types

    import rerun as rr

    import app.recording.destination as destination

    path = tmp_path / "full.rrd"
    stream = rr.RecordingStream("full-disk", recording_id="r", send_properties=False)
    stream.save(str(path))
    for step in range(30):
        stream.set_time("step", sequence=step)
        stream.log("/energy/total", rr.Scalars(float(step)))
    stream.disconnect()
    whole = destination.readable_part(path)
    assert whole.complete
    data = path.read_bytes()
    path.write_bytes(data[: whole.readable_bytes - 40])  # cut inside its last messages

    real_pwrite = os.pwrite

    def half_pwrite(descriptor, payload, offset):
        real_pwrite(descriptor, payload[: len(payload) // 2], offset)
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(destination.os, "pwrite", half_pwrite)
    descriptor = os.open(path, os.O_RDWR)
    try:
        output = types.SimpleNamespace(library_path=str(path), descriptor=descriptor)
        destination.end_readably(output, "full-disk", "r", "recording stopped: disk full",
                                 [("/log", 29, 0.29)])
    finally:
        os.close(descriptor)
    part = destination.readable_part(path)
    assert part.readable_bytes == part.total_bytes and part.messages > 0
    steps = temporal(read_chunks(path), "/energy/total", "Scalars:scalars")
    assert 0 < len(steps) <= 30


@pytest.mark.parametrize("arguments, fragment", [
    (["--packet", "inf,0"], "finite"),
    (["--packet", "0.5,nan"], "finite"),
    (["--set", "nx=３"], "ASCII"),
    (["--steps", "３"], "ASCII"),
    (["--dt", "０.01"], "ASCII"),
])
def test_infinite_packets_and_non_ascii_numbers_are_one_line(capsys, arguments, fragment):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy warning reaches the terminal first
        assert_refused(capsys, ["run", "grid", *arguments, "--steps", "1", "--quiet"]
                       if "--steps" not in arguments else ["run", "grid", *arguments, "--quiet"],
                       fragment)


LOADED_AFTER = """
import json, sys
from app.cli import main
try:
    main({argv!r})
except SystemExit:
    pass
print(json.dumps(sorted(name for name in ("numba", "rerun", "viser", "sim", "matplotlib")
                        if name in sys.modules)))
"""


@pytest.mark.parametrize("argv, loaded", [
    (["--help"], []), (["warm", "--help"], []), (["run", "--help"], ["numba", "sim"]),
    (["serve", "--help"], ["numba", "sim"]), (["record", "--help"], ["numba", "sim"]),
    (["movie", "--help"], ["numba", "sim"]),
])
def test_help_loads_only_what_the_command_needs(argv, loaded):
    """``oscillators --help`` lists the commands without importing them (it answers in tens of
    milliseconds); a command's help imports that command's module only, without viser or rerun."""
    import json
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-c", LOADED_AFTER.format(argv=argv)],
                            capture_output=True, text=True, timeout=120, check=True)
    assert json.loads(result.stdout.strip().splitlines()[-1]) == loaded
