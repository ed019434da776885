"""Scene files from anyone: regular files of bounded size, arrays checked before they are read,
paths kept where they belong, and scenes as one downloadable/uploadable file."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import threading
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

import sim
from sim.scenes import building as scenes
from sim.scenes import scene_files
from sim.scenes.building import SceneError

REPO = Path(__file__).resolve().parent.parent


def assert_same_scene(loaded: sim.Scene, original: sim.Scene) -> None:
    assert (loaded.name, loaded.description, loaded.integrator) == (
        original.name, original.description, original.integrator)
    assert loaded.dt == original.dt and loaded.duration == original.duration
    np.testing.assert_array_equal(loaded.model.masses, original.model.masses)
    np.testing.assert_array_equal(loaded.initial_positions, original.initial_positions)
    np.testing.assert_array_equal(loaded.initial_velocities, original.initial_velocities)
    for key, value in original.model.parameters().items():
        assert getattr(loaded.model, key) == value, key


def npy_bytes(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array, allow_pickle=True)
    return buffer.getvalue()


def write_scene_with_arrays(directory: Path, members: dict[str, bytes], nx: int = 3,
                            ny: int = 2, array_file: str = "arrays.npz") -> Path:
    """A TOML scene of an nx x ny lattice naming ``array_file``, written from raw members."""
    with zipfile.ZipFile(directory / array_file, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, content in members.items():
            archive.writestr(name, content)
    path = directory / "scene.toml"
    path.write_text(f'[model]\nnx = {nx}\nny = {ny}\nmass = "arrays:masses"\n'
                    f'[arrays]\nfile = "{array_file}"\n')
    return path


# --- downloads and uploads ---------------------------------------------------------------------------


def test_a_scene_with_uneven_masses_round_trips_through_one_zip():
    scene = scenes.build("ionic", damping=0.25, gravity=(0.0, -2.0), linear=True)
    suffix, content = scene_files.to_bytes(scene)
    assert suffix == ".zip" and content.startswith(b"PK\x03\x04")
    with zipfile.ZipFile(io.BytesIO(content)) as archive:
        assert sorted(archive.namelist()) == ["scene.npz", "scene.toml"]
    assert not scene.model.uniform_mass
    assert_same_scene(scene_files.from_bytes(content, "ionic" + suffix), scene)


def test_a_scene_with_displacements_and_velocities_round_trips():
    base = scenes.build("grid", nx=7, ny=5, dim=3, rest_length=0.9)
    rng = np.random.default_rng(7)
    shape = base.initial_positions.shape
    scene = sim.Scene(
        name="shaken", model=base.model, description='quotes " and \\ kept', integrator="verlet",
        dt=0.005, duration=3.5,
        initial_positions=base.model.rest_positions + 0.05 * rng.standard_normal(shape),
        initial_velocities=0.1 * rng.standard_normal(shape),
    )
    suffix, content = scene_files.to_bytes(scene)
    assert suffix == ".zip"
    assert_same_scene(scene_files.from_bytes(content, "anything.bin"), scene)


def test_a_scene_needing_no_arrays_is_plain_toml():
    scene = scenes.build("grid")  # one particle displaced: written inline
    suffix, content = scene_files.to_bytes(scene)
    assert suffix == ".toml"
    assert b"[arrays]" not in content
    content.decode("utf-8")
    assert_same_scene(scene_files.from_bytes(content, "grid.toml"), scene)


def test_uploads_that_break_the_rules_are_refused(monkeypatch):
    _, good = scene_files.to_bytes(scenes.build("ionic"))
    with zipfile.ZipFile(io.BytesIO(good)) as archive:
        toml, npz = archive.read("scene.toml"), archive.read("scene.npz")

    def package(members: dict[str, bytes]) -> bytes:
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w") as archive:
            for name, content in members.items():
                archive.writestr(name, content)
        return buffer.getvalue()

    refused = {
        "a directory in the zip": package({"dir/scene.toml": toml, "scene.npz": npz}),
        "a parent path": package({"../scene.toml": toml, "scene.npz": npz}),
        "a third member": package({"scene.toml": toml, "scene.npz": npz, "extra.txt": b"x"}),
        "two tomls": package({"scene.toml": toml, "other.toml": toml}),
        "a missing npz": package({"scene.toml": toml}),
        "a toml naming arrays": toml,
        "binary rubbish": bytes(range(256)),
        "a broken zip": good[:200],
    }
    for what, content in refused.items():
        with pytest.raises(SceneError):
            scene_files.from_bytes(content, "upload.zip")
            pytest.fail(f"accepted {what}")
    monkeypatch.setattr(scene_files, "MAX_UPLOAD_BYTES", 100)
    with pytest.raises(SceneError, match="more than the 100 bytes allowed"):
        scene_files.from_bytes(good, "upload.zip")


def test_an_uploaded_toml_over_the_limit_is_refused(monkeypatch):
    monkeypatch.setattr(scene_files, "MAX_SCENE_FILE_BYTES", 100)
    with pytest.raises(SceneError, match="allowed"):
        scene_files.from_bytes(b"# " + b"x" * 200 + b"\n[model]\nnx = 2\n", "big.toml")


# --- files that are not what they claim --------------------------------------------------------------


def test_a_directory_or_a_device_is_not_a_scene_file(tmp_path):
    folder = tmp_path / "folder.toml"
    folder.mkdir()
    with pytest.raises(SceneError, match="not a regular file"):
        scene_files.load(folder)
    with pytest.raises(SceneError, match="not a regular file"):
        scene_files.load("/dev/zero")


def test_a_named_pipe_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    outcome: list[BaseException] = []

    def load() -> None:
        try:
            scene_files.load(fifo)
        except BaseException as error:  # noqa: BLE001 - examined below
            outcome.append(error)

    thread = threading.Thread(target=load, daemon=True)
    thread.start()
    thread.join(timeout=10)
    assert not thread.is_alive(), "loading a named pipe blocked"
    assert isinstance(outcome[0], SceneError) and "not a regular file" in str(outcome[0])


def test_the_command_line_refuses_a_named_pipe_as_a_scene_quickly(tmp_path):
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    result = subprocess.run(
        [sys.executable, "-m", "app.cli", "run", str(fifo), "--quiet"], cwd=REPO,
        capture_output=True, text=True, timeout=60,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "not a regular file" in lines[0] and "Traceback" not in result.stderr


def test_an_oversized_scene_file_is_refused(tmp_path):
    path = tmp_path / "huge.toml"
    path.write_text("[model]\nnx = 2\n" + "# padding\n" * (scene_files.MAX_SCENE_FILE_BYTES // 10 + 1))
    with pytest.raises(SceneError, match="allowed"):
        scene_files.load(path)


@pytest.mark.parametrize(
    "entry", ["../x.npz", "/etc/passwd", "sub/x.npz", "..", "", "a\\\\b.npz"],
)
def test_the_array_file_must_be_a_bare_name_beside_the_toml(tmp_path, entry):
    path = tmp_path / "scene.toml"
    path.write_text(f'[model]\nnx = 2\n[arrays]\nfile = "{entry}"\n')
    with pytest.raises(SceneError, match="bare name"):
        scene_files.load(path)


def test_the_array_file_must_be_a_regular_file(tmp_path):
    (tmp_path / "arrays.npz").mkdir()
    path = tmp_path / "scene.toml"
    path.write_text('[model]\nnx = 2\n[arrays]\nfile = "arrays.npz"\n')
    with pytest.raises(SceneError, match="not a regular file"):
        scene_files.load(path)


def test_within_keeps_the_scene_and_its_arrays_inside_a_directory(tmp_path):
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    scene = scenes.build("ionic")
    scene_files.save(scene, root / "ionic.toml")
    assert_same_scene(scene_files.load(root / "ionic.toml", within=root), scene)

    scene_files.save(scene, outside / "elsewhere.toml")
    (root / "link.toml").symlink_to(outside / "elsewhere.toml")
    with pytest.raises(SceneError, match="outside"):
        scene_files.load(root / "link.toml", within=root)
    with pytest.raises(SceneError, match="outside"):
        scene_files.load(root / ".." / "outside" / "elsewhere.toml", within=root)

    # a TOML inside whose array file is a symlink to one outside
    (root / "sneaky.toml").write_text(
        (outside / "elsewhere.toml").read_text().replace("elsewhere.npz", "sneaky.npz")
    )
    (root / "sneaky.npz").symlink_to(outside / "elsewhere.npz")
    with pytest.raises(SceneError, match="outside"):
        scene_files.load(root / "sneaky.toml", within=root)
    assert_same_scene(scene_files.load(root / "sneaky.toml"), scene)  # no root given: allowed


# --- array files -------------------------------------------------------------------------------------


def test_a_small_npz_claiming_a_huge_array_is_refused_without_allocating(tmp_path):
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (20000, 20000)}
    )
    path = write_scene_with_arrays(tmp_path, {"masses.npy": header.getvalue() + b"\0" * 64})
    tracemalloc.start()
    try:
        with pytest.raises(SceneError, match="shape"):
            scene_files.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 * 2**20


def test_a_highly_compressible_npz_member_is_refused_from_its_directory_size(tmp_path):
    bomb = npy_bytes(np.zeros((10_000, 1200)))  # 96 MB of zeros pack into about 100 kB
    path = write_scene_with_arrays(tmp_path, {"masses.npy": npy_bytes(np.ones((100, 100))),
                                              "velocities.npy": bomb}, nx=100, ny=100)
    assert path.with_name("arrays.npz").stat().st_size < 2**20
    tracemalloc.start()
    try:
        with pytest.raises(SceneError, match="unpacks to"):
            scene_files.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * 2**20


@pytest.mark.parametrize(
    "members, message",
    [
        ({"masses.npy": npy_bytes(np.ones((3, 2)))}, "shape"),
        ({"masses.npy": npy_bytes(np.ones((2, 3), dtype=complex))}, "dtype"),
        ({"masses.npy": npy_bytes(np.array([[object()] * 3] * 2, dtype=object))}, "dtype"),
        ({"masses.npy": npy_bytes(np.ones((2, 3))), "payload.npy": b"x"}, "unexpected member"),
        ({"masses.npy": npy_bytes(np.ones((2, 3))), "../velocities.npy": b"x"}, "unexpected"),
        ({"masses.npy": b"not an npy file at all"}, "array file"),
        ({"masses.npy": npy_bytes(np.ones((2, 3))),
          "velocities.npy": npy_bytes(np.zeros((6, 3)))}, "velocities has shape"),
    ],
)
def test_npz_members_are_checked_against_the_lattice(tmp_path, members, message):
    path = write_scene_with_arrays(tmp_path, members)
    with pytest.raises(SceneError, match=message):
        scene_files.load(path)


def test_flat_masses_are_accepted_as_save_might_have_written_them(tmp_path):
    masses = np.arange(1.0, 7.0)
    path = write_scene_with_arrays(tmp_path, {"masses.npy": npy_bytes(masses)})
    np.testing.assert_array_equal(scene_files.load(path).model.masses, masses.reshape(2, 3))


def test_the_command_line_refuses_bad_scene_files_in_one_line(tmp_path, capsys):
    from app.cli import main

    folder = tmp_path / "folder.toml"
    folder.mkdir()
    escape = tmp_path / "escape.toml"
    escape.write_text('[model]\nnx = 2\n[arrays]\nfile = "../x.npz"\n')
    for path in (folder, escape):
        assert main(["run", str(path), "--quiet"]) == 2
        error = capsys.readouterr().err
        assert len(error.strip().splitlines()) == 1 and str(path) in error


def test_the_cli_runs_a_downloaded_zip_scene(tmp_path, capsys):
    from app.cli import main

    scene = sim.scenes.build("ionic", nx=4, ny=3)
    suffix, content = sim.scenes.scene_files.to_bytes(scene)
    assert suffix == ".zip"
    archive = tmp_path / "ionic.zip"
    archive.write_bytes(content)
    assert main(["run", str(archive), "--steps", "3", "--quiet", "--json"]) == 0
    loaded = sim.scenes.scene_files.load_file(archive)
    np.testing.assert_array_equal(loaded.model.masses, scene.model.masses)
