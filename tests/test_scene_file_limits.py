"""Scene files are bounded by what is read, not by what they announce: a zip whose directory
under-states its member is refused while it inflates, with little memory; the page opens no
lattice larger than its particle limit, from an upload or from the server's scene folder."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest
import viser

import sim
from app.web.scene_files import MAX_PAGE_PARTICLES, SceneDirectory
from tests.helpers import wait_for
from tests.lying_zip import many_member_zip, write_lying_zip
from tests.test_web_safety import send

REPO = Path(__file__).resolve().parent.parent
INFLATED = 400_000_000
"""What the lying TOML inflates to: far more than the 100 MB a refusal may cost."""


def run_cli(arguments: list[str], cwd: Path) -> tuple[int, float, str]:
    """Exit code, peak resident MB (the child's own ``ru_maxrss``) and stderr of
    ``oscillators ARGUMENTS`` run in a child process."""
    process = subprocess.Popen([sys.executable, "-m", "app.cli", *arguments], cwd=cwd,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               env={**os.environ, "PYTHONPATH": str(REPO)})
    error = process.stderr.read().decode()
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    return process.returncode, usage.ru_maxrss / 1024, error


def test_a_zip_that_understates_its_toml_is_refused_with_little_memory(tmp_path):
    bomb = write_lying_zip(tmp_path / "bomb.zip", INFLATED)
    assert bomb.stat().st_size < INFLATED / 100
    broken = tmp_path / "broken.zip"
    broken.write_bytes(b"PK\x03\x04 not a zip")
    code, idle, error = run_cli(["run", broken.name], tmp_path)
    assert code == 2 and "broken.zip" in error
    code, peak, error = run_cli(["run", bomb.name], tmp_path)
    assert code == 2 and "bomb.zip" in error, error
    assert peak - idle < 100, f"peak {peak:.0f} MB refusing the lying zip, {idle:.0f} MB " \
                              "refusing a broken one"


def test_a_member_is_refused_the_moment_it_inflates_past_the_limit(tmp_path):
    """The running count, not the directory's stated size, stops a member."""
    import zipfile

    text = b'name = "x"\n' + b" " * (2 * 2**20)
    with zipfile.ZipFile(tmp_path / "big.zip", "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("scene.toml", text)
    with pytest.raises(sim.SceneError, match="larger than the 1,048,576 bytes"):
        sim.scenes.scene_files.from_bytes((tmp_path / "big.zip").read_bytes(), "big.zip")
    with zipfile.ZipFile(tmp_path / "big.zip") as archive:
        with pytest.raises(sim.SceneError, match="unpacks to more than the 1,048,576 bytes"):
            sim.scenes.scene_archives.read_member(archive, archive.infolist()[0], 2**20, "big.zip")


MANY = 700_000
"""Members of the many-member zip: 61 MB, under the upload limit; most of it directory."""


def test_a_zip_of_many_members_is_refused_before_its_directory_is_read(tmp_path):
    """``zipfile`` reads the whole directory as it opens an archive; the end record is read
    first, so the refusal costs a few MB whatever the member count."""
    (tmp_path / "many.zip").write_bytes(many_member_zip(MANY))
    (tmp_path / "broken.zip").write_bytes(b"PK\x03\x04 not a zip")
    _, idle, _ = run_cli(["run", "broken.zip"], tmp_path)
    code, peak, error = run_cli(["run", "many.zip"], tmp_path)
    assert code == 2 and f"lists {MANY:,} members; at most 2" in error, error
    assert error.count("\n") <= 2, error
    assert peak - idle < 8, f"peak {peak:.0f} MB refusing {MANY:,} members, {idle:.0f} MB idle"


def test_an_uploaded_zip_of_many_members_is_refused_with_little_memory(web_app):
    """The page's upload: the archive's own bytes, and a few kB more to refuse it."""
    import tracemalloc

    data = many_member_zip(MANY)
    before = web_app.runner.simulation.model
    tracemalloc.start()
    try:
        send(web_app.panel.scene.files.upload_button, viser.UploadedFile("many.zip", data))
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    said = web_app.panel.scene.message.content
    assert "could not open many.zip" in said and f"{MANY:,} members" in said, said
    assert web_app.runner.simulation.model is before
    assert peak < 2**20, f"{peak:,} bytes traced refusing {MANY:,} members"
    npz = many_member_zip(4)
    with pytest.raises(sim.SceneError, match="lists 4 members; at most 3"):
        sim.scenes.scene_archives.read_arrays(io.BytesIO(npz), 2, 2, 2, "arrays.npz")


LARGE = f'name = "large"\n[model]\nnx = 2000\nny = {MAX_PAGE_PARTICLES // 2000 + 1}\n'


def test_the_page_refuses_an_upload_larger_than_its_particle_limit(web_app):
    files = web_app.panel.scene.files
    before = web_app.runner.simulation.model.n_particles
    send(files.upload_button, viser.UploadedFile("large.toml", LARGE.encode()))
    said = web_app.panel.scene.message.content
    assert "could not open large.toml" in said and f"{MAX_PAGE_PARTICLES:,}" in said, said
    assert web_app.runner.simulation.model.n_particles == before


def test_the_page_refuses_a_listed_file_larger_than_its_particle_limit(tmp_path):
    (tmp_path / "large.toml").write_text(LARGE)
    with pytest.raises(sim.SceneError, match="particles, more than the 1,000,000"):
        SceneDirectory(tmp_path).load("large.toml")


def test_quick_preset_and_build_presses_end_on_the_last_preset_whole(web_app, monkeypatch):
    """40 Preset + Build presses at 10 a second, each value stored in the order it arrives and
    each press handled on its own thread, as viser does, with builds that take 0-0.4 s (as large
    lattices do): one build at a time, the last press wins, and the scene is the preset at its
    own size."""
    import random
    import threading
    import time

    from tests.test_web_safety import press, settle

    build = sim.scenes.build
    delays = random.Random(7)

    def slow_build(*arguments, **overrides):
        time.sleep(0.4 * delays.random())
        return build(*arguments, **overrides)

    monkeypatch.setattr(sim.scenes, "build", slow_build)  # as the folder calls it
    panel = web_app.panel.scene
    names = ["chain", "square", "grid", "single"]
    threads = []
    for index in range(40):
        name = names[index % len(names)]
        panel.preset._impl.value = name  # viser stores a value in its event loop, in order,
        for action in (lambda: send(panel.preset),  # then runs the callbacks on its threads
                       lambda: press(panel.build_button)):
            thread = threading.Thread(target=action)
            thread.start()
            threads.append(thread)
            time.sleep(0.05)
    for thread in threads:
        thread.join(timeout=120)
    settle(web_app)
    last = names[39 % len(names)]
    expected = build(last)
    model = web_app.runner.simulation.model
    assert web_app.runner.simulation.scene.name == last
    assert (model.nx, model.ny) == (expected.model.nx, expected.model.ny)
    assert (panel.nx.value, panel.ny.value) == (model.nx, model.ny)
    assert panel.preset.value == last


def test_a_press_made_while_a_build_runs_builds_what_the_page_showed(web_app, monkeypatch):
    """Chain is building; the page picks single and presses Build: the press waits, and once
    chain is shown it builds single, not the chain that the finished build put in the
    widgets."""
    import threading

    from tests.test_web_safety import press, settle

    build = sim.scenes.build
    building, release = threading.Event(), threading.Event()

    def held_build(name, **overrides):
        if name == "chain":
            building.set()
            assert release.wait(60)
        return build(name, **overrides)

    monkeypatch.setattr(sim.scenes, "build", held_build)
    panel = web_app.panel.scene
    panel.preset._impl.value = "chain"
    send(panel.preset)
    first = threading.Thread(target=press, args=(panel.build_button,))
    first.start()
    assert building.wait(60)
    panel.preset._impl.value = "single"  # viser stores the page's value at once
    send(panel.preset)
    second = threading.Thread(target=press, args=(panel.build_button,))
    second.start()
    assert wait_for(lambda: panel._presses == 2)
    release.set()
    first.join(60)
    second.join(60)
    settle(web_app)
    assert web_app.runner.simulation.scene.name == "single"
    assert panel.preset.value == "single"
    assert (panel.nx.value, panel.ny.value) == (1, 1)
