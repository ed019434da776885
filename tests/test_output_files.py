"""Files are written only where the user said, atomically: sanitised default names that stay in
their folder, exclusive ``.partial`` files never opened through a link, a second writer to one
path refused with one line, missing folders refused (``sim.storage.files`` and every writer)."""

from __future__ import annotations

import os
import threading

import pytest

import sim
from app.cli import main
from app.recording import Recorder, RecordingError
from sim.storage.files import AtomicFile, OutputError, default_output, safe_name


def scene_file(folder, name: str):
    path = folder / "s.toml"
    path.write_text(f'format = 1\nname = {name!r}\nduration = 0.2\n'
                    '[model]\nnx = 3\nny = 2\n', encoding="utf-8")
    return path


@pytest.mark.parametrize("name", ["/etc/cron.d/x", "../../x", "..", "a/../../b", "\x1b]0;t\x07"])
def test_default_names_stay_inside_their_folder(tmp_path, name):
    folder = tmp_path / "recordings"
    path = default_output(folder, name, ".rrd")
    assert path.parent == folder and path.name.endswith(".rrd")
    assert "/" not in safe_name(name) and not safe_name(name).startswith(".")


def test_record_without_output_writes_inside_recordings(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    path = scene_file(work, "../../x")
    assert main(["record", str(path), "--steps", "4", "--quiet"]) == 0
    written = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*.rrd"))
    assert [str(p) for p in written] == ["a/b/recordings/x.rrd"]


def test_a_symlinked_partial_is_never_written_through(tmp_path, capsys):
    target = tmp_path / "elsewhere"
    (tmp_path / "out.rrd.partial").symlink_to(target)
    assert main(["record", "grid", "--steps", "4", "--quiet", "-o", str(tmp_path / "out.rrd")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0 and "symbolic link" in error
    assert not target.exists() and not (tmp_path / "out.rrd").exists()


def test_a_symlinked_partial_stops_a_movie(tmp_path, capsys):
    target = tmp_path / "elsewhere"
    (tmp_path / "m.gif.partial").symlink_to(target)
    code = main(["movie", "chain", "--duration", "0.1", "--size", "160x90", "--quiet",
                 "-o", str(tmp_path / "m.gif")])
    assert code == 2 and "symbolic link" in capsys.readouterr().err
    assert not target.exists()


def test_missing_folders_are_an_error_not_created(tmp_path, capsys):
    output = tmp_path / "new" / "dir" / "x.rrd"
    assert main(["record", "grid", "--steps", "4", "--quiet", "-o", str(output)]) == 2
    error = capsys.readouterr().err
    assert "does not exist" in error and error.strip().count("\n") == 0
    assert not (tmp_path / "new").exists()


def test_a_second_writer_to_one_path_is_refused(tmp_path):
    scene = sim.scenes.build("grid", nx=4, ny=3)
    path = tmp_path / "same.rrd"
    first = Recorder(path, scene)
    with pytest.raises(RecordingError, match="another program is writing"):
        Recorder(path, scene)
    first.close()
    assert path.is_file() and not (tmp_path / "same.rrd.partial").exists()


@pytest.mark.slow
def test_two_record_processes_one_refused_and_the_file_readable(tmp_path):
    import subprocess
    import sys

    from rerun.chunk import RrdReader

    output = tmp_path / "both.rrd"
    command = [sys.executable, "-m", "app.cli", "record", "grid", "--set", "nx=6", "--set",
               "ny=4", "--steps", "400", "--quiet", "-o", str(output)]
    environment = {**os.environ, "PYTHONPATH": os.getcwd()}
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=environment) for _ in range(2)]
    results = [run.communicate(timeout=300) + (run.returncode,) for run in runs]
    codes = sorted(code for _, _, code in results)
    assert codes == [0, 2], results
    refused = next(err for _, err, code in results if code == 2)
    assert refused.strip().count("\n") == 0
    assert ("another program is writing" in refused or "already exists" in refused)
    assert RrdReader(output).stream().to_chunks()


def test_a_left_partial_is_named_and_kept(tmp_path):
    path = tmp_path / "x.png"
    (tmp_path / "x.png.partial").write_bytes(b"half")
    with pytest.raises(OutputError, match="left from an interrupted run"):
        AtomicFile(path)
    assert (tmp_path / "x.png.partial").read_bytes() == b"half"


def test_atomic_file_appears_only_complete_and_never_clobbers(tmp_path):
    path = tmp_path / "a.toml"
    seen = []
    with AtomicFile(path) as output:
        output.file.write(b"x" * 1000)
        seen.append(path.exists())
    assert seen == [False] and path.read_bytes() == b"x" * 1000
    with pytest.raises(OutputError, match="already exists"):
        AtomicFile(path)
    with pytest.raises(RuntimeError), AtomicFile(tmp_path / "b.toml") as output:
        raise RuntimeError("stopped")
    assert not list(tmp_path.glob("b.toml*"))


def test_concurrent_atomic_writers_threads(tmp_path):
    path = tmp_path / "c.bin"
    outcomes: list[str] = []
    barrier = threading.Barrier(4)

    def write() -> None:
        barrier.wait()
        try:
            with AtomicFile(path, overwrite=True) as output:
                output.file.write(b"y" * 100_000)
                barrier_done.wait(timeout=5)
            outcomes.append("wrote")
        except OutputError:
            outcomes.append("refused")

    barrier_done = threading.Event()
    threads = [threading.Thread(target=write) for _ in range(4)]
    for thread in threads:
        thread.start()
    threading.Timer(0.5, barrier_done.set).start()
    for thread in threads:
        thread.join()
    assert sorted(outcomes) == ["refused"] * 3 + ["wrote"]


def test_writers_racing_for_one_name_either_write_or_are_refused(tmp_path):
    """Many rounds of writers starting together: each one writes the whole file or is refused
    with a reason; none fails otherwise (a refused writer looking at the partial file while its
    creator locks it must not make the creator fail)."""
    path = tmp_path / "d.bin"
    unexpected: list[BaseException] = []
    for round_ in range(60):
        outcomes: list[str] = []
        barrier = threading.Barrier(6)

        def write(round_=round_, outcomes=outcomes, barrier=barrier) -> None:
            barrier.wait()
            try:
                with AtomicFile(path, overwrite=True) as output:
                    output.file.write(bytes([round_ % 256]) * 50_000)
                outcomes.append("wrote")
            except OutputError:
                outcomes.append("refused")
            except BaseException as error:  # noqa: BLE001 - what the test looks for
                unexpected.append(error)

        threads = [threading.Thread(target=write) for _ in range(6)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        assert "wrote" in outcomes and len(outcomes) + len(unexpected) == 6
        assert path.read_bytes() == bytes([round_ % 256]) * 50_000
    assert not unexpected, unexpected[:3]


def test_scene_files_and_pictures_go_through_the_same_writer(tmp_path):
    scene = sim.scenes.build("chain")
    (tmp_path / "s.toml.partial").symlink_to(tmp_path / "target")
    with pytest.raises(OutputError, match="symbolic link"):
        sim.scenes.scene_files.save(scene, tmp_path / "s.toml")
    assert not (tmp_path / "target").exists()
    with pytest.raises(OutputError, match="does not exist"):
        sim.scenes.scene_files.save(scene, tmp_path / "missing" / "s.toml")
    assert sim.scenes.scene_files.save(scene, tmp_path / "t.toml").is_file()


@pytest.mark.parametrize("command", ["accuracy", "slits", "reflection", "response"])
def test_a_study_picture_without_plot_goes_to_the_pictures_folder_not_the_current_one(
        command, tmp_path, monkeypatch, capsys):
    import argparse

    from app.cli import study_output

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit):
        main([command, "--help"])
    assert f"{study_output.DEFAULT_PICTURES_DIR}/" in " ".join(capsys.readouterr().out.split())
    arguments = argparse.Namespace(plot=None, no_plot=False)
    study_output.default_plot(arguments, "grid-x.png")
    assert arguments.plot == os.path.join("pictures", "grid-x.png")
    assert (tmp_path / "pictures").is_dir()
    assert not list(tmp_path.glob("*.png"))
