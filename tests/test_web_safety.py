"""The web app is safe to run in a classroom: checked values, no server paths, contained failures.

Events "from a page" are made the way viser makes them for a browser's message: the widget's
value is set and its callbacks run with an event that names a client (``press`` / ``send``).
Events the server makes itself (assigning ``.value``) name no client; the panel must ignore them.
The Host/Origin checks are tested over real HTTP and websocket connections.
"""

from __future__ import annotations

import asyncio
import http.client
import inspect
import os
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import viser
import websockets.exceptions
from websockets.sync.client import connect

import sim
from app.web import frames
from app.web.app import WebApp
from app.web.scene_files import SceneDirectory, SceneFileRefused
from tests.helpers import free_port, wait_for


class PageClient:
    """Stands in for a connected browser: keeps what the server sends it to download."""

    client_id = 1

    def __init__(self) -> None:
        self.downloads: list[tuple[str, bytes]] = []

    def send_file_download(self, name: str, content: bytes, chunk_size: int = 0,
                           save_immediately: bool = False) -> None:
        self.downloads.append((name, content))


def send(handle: Any, value: Any = None, client: PageClient | None = None) -> None:
    """Do what viser does when a page sends ``value`` for ``handle``: store it unchecked (the page
    may send anything) and run the callbacks with an event naming the client."""
    if value is not None:
        handle._impl.value = value
    event = viser.GuiEvent(client=client or PageClient(), client_id=1, target=handle)
    for callback in list(handle._impl.update_cb):
        result = callback(event)
        if inspect.iscoroutine(result):
            asyncio.run(result)


def press(handle: Any, client: PageClient | None = None) -> None:
    send(handle, True, client)


def settle(app: WebApp) -> None:
    """Let viser's event loop run what the server scheduled, then the runner's command queue."""
    for _ in range(3):
        asyncio.run_coroutine_threadsafe(asyncio.sleep(0.01), app.server.get_event_loop()).result(5)
    app.runner.post(lambda simulation: None).result(timeout=10)


@pytest.fixture
def folders(tmp_path: Path) -> tuple[Path, Path]:
    scenes, recordings = tmp_path / "scenes", tmp_path / "recordings"
    scenes.mkdir()
    return scenes, recordings


@pytest.fixture
def web_app(folders):
    scenes, recordings = folders
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port(),
                 scenes_dir=scenes, recordings_dir=recordings)
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None)
    yield app
    app.stop()


def assert_same_scene(simulation: sim.Simulation, expected: sim.Scene) -> None:
    model, wanted = simulation.model, expected.model
    assert model.parameters() == wanted.parameters()
    for field in ("nx", "ny", "dim", "spacing", "stiffness", "rest_length", "damping", "drag",
                  "linear"):
        assert getattr(model, field) == getattr(wanted, field), field
    assert tuple(model.gravity) == tuple(wanted.gravity)
    np.testing.assert_array_equal(model.masses, wanted.masses)
    np.testing.assert_array_equal(simulation.scene.initial_positions, expected.initial_positions)
    np.testing.assert_array_equal(simulation.scene.initial_velocities,
                                  expected.initial_velocities)
    assert simulation.integrator == expected.integrator
    assert simulation.dt == expected.dt


# --- the panel is a view ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", [n for n in sim.scenes.names() if n != "interference"])
def test_a_preset_built_in_the_page_is_exactly_the_preset(web_app, name):
    panel = web_app.panel
    send(panel.scene.preset, name)
    press(panel.scene.build_button)
    settle(web_app)
    assert_same_scene(web_app.runner.simulation, sim.scenes.build(name))
    assert name in panel.scene.info.content
    # showing the scene assigned many widget values; none of them may have posted a change
    settle(web_app)
    assert_same_scene(web_app.runner.simulation, sim.scenes.build(name))


@pytest.mark.slow
def test_the_interference_preset_built_in_the_page_is_exactly_the_preset(web_app):
    send(web_app.panel.scene.preset, "interference")
    press(web_app.panel.scene.build_button)
    settle(web_app)
    assert_same_scene(web_app.runner.simulation, sim.scenes.build("interference"))


def test_typed_size_is_the_only_change_to_the_preset(web_app):
    panel = web_app.panel
    send(panel.scene.preset, "catenary")
    send(panel.scene.nx, 9)
    press(panel.scene.build_button)
    settle(web_app)
    assert_same_scene(web_app.runner.simulation, sim.scenes.build("catenary", nx=9))


def chain_with_masses() -> sim.Scene:
    scene = sim.scenes.build("chain")
    model = scene.model.replace(mass=np.array([1.0, 2.0, 3.0, 4.0, 5.0]))
    positions = model.rest_positions.copy()
    positions[1] += (0.1, -0.2)
    velocities = np.zeros_like(positions)
    velocities[3] = (0.5, 0.25)
    return sim.Scene(name="heavy-chain", model=model, description="masses 1 to 5 kg",
                     integrator="verlet", dt=0.02, initial_positions=positions,
                     initial_velocities=velocities, duration=12.0)


def test_download_then_upload_gives_back_the_same_scene(web_app):
    panel = web_app.panel
    scene = chain_with_masses()
    web_app.replace_scene(scene, source="test")
    client = PageClient()
    press(panel.scene.files.download_button, client)
    (name, content), = client.downloads
    assert name.startswith("heavy-chain")
    web_app.replace_scene(sim.scenes.build("grid"), source="test")
    send(panel.scene.files.upload_button, viser.UploadedFile(name, content))
    settle(web_app)
    assert_same_scene(web_app.runner.simulation, scene)
    assert "heavy-chain" in panel.scene.info.content and "5x1" in panel.scene.info.content


def test_a_scene_file_in_the_scenes_directory_opens_by_name(web_app, folders):
    scenes, _ = folders
    scene = chain_with_masses()
    sim.scenes.scene_files.save(scene, scenes / "lesson.toml")
    panel = web_app.panel
    press(panel.scene.files.list_button)
    assert panel.scene.files.server_scenes.options == ("lesson.toml",)
    send(panel.scene.files.server_scenes, "lesson.toml")
    press(panel.scene.files.open_button)
    settle(web_app)
    assert_same_scene(web_app.runner.simulation, scene)
    assert "lesson.toml" in panel.scene.info.content


# --- every value from the page is checked --------------------------------------------------------


def test_bad_values_from_the_page_are_refused_and_change_nothing(web_app):
    panel = web_app.panel
    simulation = web_app.runner.simulation
    dt, stiffness = simulation.dt, simulation.model.stiffness
    for bad in (-0.01, 0.0, float("nan"), float("inf"), 1e9):
        send(panel.integrator.dt, bad)
        settle(web_app)
        assert web_app.runner.simulation.dt == dt
        assert "refused" in panel.integrator.message.content
        assert panel.integrator.dt.value == dt  # the widget shows the simulation's dt again, not a clamp
    steps_per_frame = web_app.runner.steps_per_frame
    send(panel.integrator.steps_per_frame, 1e9)
    assert web_app.runner.steps_per_frame == steps_per_frame
    assert "steps per frame" in panel.integrator.message.content
    send(panel.integrator.method, "warp-drive")
    settle(web_app)
    assert web_app.runner.simulation.integrator == simulation.integrator
    for bad in (1e9, float("nan"), -5.0):
        send(panel.physics.stiffness, bad)
        settle(web_app)
        assert web_app.runner.simulation.model.stiffness == stiffness
        assert "refused" in panel.physics.message.content
    model = web_app.runner.simulation.model
    for nx in (1e12, 0, -4, 2.5, 3000):
        send(panel.scene.nx, nx)
        press(panel.scene.build_button)
        assert web_app.runner.simulation.model is model
        assert "could not build" in panel.scene.message.content
    send(panel.scene.nx, 2000)
    send(panel.scene.ny, 2000)
    press(panel.scene.build_button)
    assert web_app.runner.simulation.model is model
    assert "particles" in panel.scene.message.content
    send(panel.selection.row, 10**6)
    press(panel.selection.select_buttons)
    assert "row" in panel.selection.message.content
    send(panel.view.color_by, "<script>")
    assert "&lt;script&gt;" in panel.view.message.content
    send(panel.view.picture_rate, "1000")
    assert web_app.view.settings.picture_rate == frames.DEFAULT_FPS
    assert "pictures per second" in panel.view.message.content
    send(panel.view.picture_rate, "at most 4")
    assert web_app.view.settings.picture_rate == 4.0


def test_text_from_the_page_is_shown_as_text(web_app):
    panel = web_app.panel
    name = '<img src=x onerror="alert(1)"><b>lesson</b>.toml'
    send(panel.scene.files.upload_button, viser.UploadedFile(name, b"not [a scene"))
    message = panel.scene.message.content
    assert "could not open" in message
    assert "<img" not in message and "<b>" not in message
    assert "&lt;img" in message


def test_programmatic_values_post_no_commands(web_app):
    """The server assigning widget values (as it does to show a scene) must not change it."""
    panel = web_app.panel
    before = web_app.runner.simulation.model
    panel.physics.stiffness.value = 77.0
    panel.physics.damping_on.value = True
    panel.physics.gravity_on.value = True
    panel.physics.mass_pattern.value = "ionic"
    panel.integrator.dt.value = 0.5
    settle(web_app)
    assert web_app.runner.simulation.model is before
    assert web_app.runner.simulation.dt != 0.5


# --- files: by name, in one directory ---------------------------------------------------------------


def test_only_regular_scene_files_inside_the_directory_are_offered(tmp_path):
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    sim.scenes.scene_files.save(sim.scenes.build("chain"), scenes / "chain.toml")
    outside = tmp_path / "secret.toml"
    sim.scenes.scene_files.save(sim.scenes.build("single"), outside)
    (scenes / "escape.toml").symlink_to(outside)
    (scenes / "folder.toml").mkdir()
    os.mkfifo(scenes / "pipe.toml")
    (scenes / "notes.txt").write_text("not a scene")
    directory = SceneDirectory(scenes)
    assert directory.names() == ["chain.toml"]
    assert directory.load("chain.toml").model.nx == 5
    for name in ("escape.toml", "pipe.toml", "folder.toml", "../secret.toml", str(outside),
                 "/dev/zero", "notes.txt", "missing.toml", None):
        with pytest.raises(SceneFileRefused):
            directory.load(name)  # type: ignore[arg-type]


def test_a_missing_scenes_directory_lists_nothing_and_is_not_created(tmp_path):
    directory = SceneDirectory(tmp_path / "nowhere")
    assert directory.names() == []
    assert not (tmp_path / "nowhere").exists()


# --- who may connect -----------------------------------------------------------------------------


def _websocket(app: WebApp, origin: str | None) -> bool:
    """Whether a websocket handshake with this Origin header is accepted."""
    url = f"ws://127.0.0.1:{app.server.get_port()}"
    try:
        with connect(url, origin=origin, subprotocols=["viser-v1.1.1"], open_timeout=10):
            return True
    except websockets.exceptions.InvalidStatus as refused:
        assert refused.response.status_code == 403
        return False


def test_a_foreign_page_may_not_open_the_websocket(web_app):
    port = web_app.server.get_port()
    assert not _websocket(web_app, "http://evil.example")
    assert not _websocket(web_app, f"http://127.0.0.1:{port + 1}")
    assert _websocket(web_app, f"http://127.0.0.1:{port}")
    assert web_app.access.refused >= 2


def test_allow_origin_admits_that_page_only(folders):
    scenes, recordings = folders
    app = WebApp(sim.Simulation(sim.scenes.build("single")), port=free_port(),
                 scenes_dir=scenes, recordings_dir=recordings,
                 allow_origins=["http://teacher.example:9000"])
    app.start()
    try:
        assert _websocket(app, "http://teacher.example:9000")
        assert not _websocket(app, "http://student.example:9000")
    finally:
        app.stop()


def test_a_rebound_host_name_is_refused(web_app):
    port = web_app.server.get_port()
    for host, status in ((f"attacker.example:{port}", 403), (f"127.0.0.1:{port}", 200),
                         (f"localhost:{port}", 200)):
        connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        connection.request("GET", "/", headers={"Host": host})
        assert connection.getresponse().status == status, host
        connection.close()


# --- failures are contained --------------------------------------------------------------------------


def test_a_failing_subscriber_is_detached_and_the_simulation_goes_on(web_app):
    failures: list[BaseException] = []

    def broken(frame: Any) -> None:
        raise OSError(28, "No space left on device")

    web_app.runner.subscribe(broken, on_error=failures.append)
    web_app.runner.play()
    step = web_app.runner.simulation.step_count
    assert wait_for(lambda: web_app.runner.simulation.step_count > step + 50)
    assert len(failures) == 1 and "No space left" in str(failures[0])
    assert wait_for(lambda: "No space left" in web_app.panel.run.part_html.content)
    assert web_app.panel.run.part_html.visible
    web_app.control.reset().result(timeout=5)
    assert wait_for(lambda: web_app.runner.simulation.step_count > 10)  # Reset and Play still work


def test_double_click_on_record_and_stopping_the_server_leave_valid_recordings(folders):
    from tests.test_recording import read_chunks

    scenes, recordings = folders
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=6, ny=4)), port=free_port(),
                 scenes_dir=scenes, recordings_dir=recordings)
    app.start()
    try:
        app.runner.play()
        clicks = [threading.Thread(target=press, args=(app.panel.recording.record_button,))
                  for _ in range(2)]
        for click in clicks:
            click.start()
        for click in clicks:
            click.join(30)
        press(app.panel.recording.record_button)  # start (or stop) once more: a new, unique file
        assert wait_for(lambda: app.runner.simulation.step_count > 30)
    finally:
        app.stop()  # closes whatever is still recording
    files = sorted(recordings.glob("*"))
    assert files and all(path.suffix == ".rrd" for path in files), files  # no .partial left
    assert len({path.name for path in files}) == len(files)
    for path in files:
        assert read_chunks(path)  # rerun reads every file back


# --- accuracy in the page ---------------------------------------------------------------------------


@pytest.mark.slow  # the absorbing layer's kernels on a page
def test_the_page_shows_the_energy_balance_error_and_explains_it(web_app):
    panel = web_app.panel
    accuracy = panel.accuracy
    send(panel.integrator.method, "euler")
    send(panel.integrator.dt, 0.02)
    web_app.runner.play()
    assert wait_for(lambda: "energy-balance error" in accuracy.live.content
                    and "#c0392b" in accuracy.live.content)  # far above 1 %: red
    web_app.runner.pause()
    assert accuracy.why.visible and "adds energy" in accuracy.why.content
    assert wait_for(lambda: "euler at dt = 0.02" in accuracy.predicted.content)
    assert "unstable" in accuracy.predicted.content  # Euler grows at every dt when undamped


def test_choose_for_me_sets_a_run_that_meets_the_tolerance(web_app):
    panel = web_app.panel
    accuracy = panel.accuracy
    send(accuracy.tolerance, 0.1)  # %
    press(accuracy.choose_button)
    assert "verified" in accuracy.message.content, accuracy.message.content
    press(accuracy.apply_button)
    settle(web_app)
    simulation = web_app.runner.simulation
    answer = accuracy._answer
    assert (simulation.integrator, simulation.dt) == (answer.integrator, answer.dt)
    assert answer.error <= 1e-3  # verified by running it over the scene's duration


@pytest.mark.slow  # the linearised springs' own kernels on a page
def test_linearised_springs_offer_the_exact_solver(web_app):
    panel = web_app.panel
    assert "exact" not in panel.integrator.method.options
    send(panel.physics.linear, True)
    settle(web_app)
    assert wait_for(lambda: "exact" in panel.integrator.method.options)
    send(panel.integrator.method, "exact")
    settle(web_app)
    assert web_app.runner.simulation.integrator == "exact"
    web_app.runner.play()
    assert wait_for(lambda: web_app.runner.simulation.step_count > 20)
    web_app.runner.pause()
    settle(web_app)
    assert abs(web_app.runner.simulation.energy_balance_error()) < 1e-12
    assert wait_for(lambda: "no time-step error" in panel.accuracy.predicted.content)


@pytest.mark.slow  # float32 and threaded kernels of their own
def test_precision_and_threads_from_the_page_are_checked_and_applied(web_app):
    panel = web_app.panel
    send(panel.integrator.precision, "float16")
    settle(web_app)
    assert web_app.runner.simulation.precision == "float64"
    assert "precision" in panel.integrator.message.content
    send(panel.integrator.precision, "float32")
    settle(web_app)
    assert web_app.runner.simulation.precision == "float32"
    send(panel.integrator.threads, 10**6)
    settle(web_app)
    assert web_app.runner.simulation.threads == 1
    send(panel.integrator.threads, 1)
    settle(web_app)
    web_app.runner.play()
    steps = web_app.runner.simulation.step_count
    # the first float32 steps compile their kernels: minutes on a loaded machine with a cold cache
    assert wait_for(lambda: web_app.runner.simulation.step_count > steps + 20, timeout=400)
    web_app.runner.pause()
    assert np.isfinite(web_app.runner.simulation.peek_positions()).all()


@pytest.mark.slow  # renders the whole run; the page's recording download is tested by default
def test_download_a_movie_of_the_current_run(web_app):
    import av

    client = PageClient()
    press(web_app.panel.recording.movie_button, client)
    assert wait_for(lambda: client.downloads, timeout=600)  # made in the background
    (name, content), = client.downloads
    assert name.endswith(".mp4") and "sent" in web_app.panel.recording.movie_text.content
    path = Path(web_app.scene_files.root) / "movie.mp4"
    path.write_bytes(content)
    with av.open(str(path)) as container:
        assert sum(1 for _ in container.decode(video=0)) > 10
    path.unlink()


def test_a_refused_value_is_replaced_by_the_value_in_use_in_every_folder(web_app):
    """The server assigns the value in use back (viser sends it to every page), so no page keeps
    showing a value the simulation does not use."""
    panel = web_app.panel
    model = web_app.runner.simulation.model
    cases = [
        (panel.physics.stiffness, -5.0, float(model.stiffness)),
        (panel.physics.gravity, float("nan"), panel.physics.gravity.value),
        (panel.scene.nx, 2.5, model.nx),
        (panel.view.color_by, "<script>", panel.view.color_by.value),
        (panel.view.particle_scale, 1e9, panel.view.particle_scale.value),
        (panel.integrator.dt, -1.0, web_app.runner.simulation.dt),
    ]
    for handle, bad, in_use in cases:
        send(handle, bad)
        if handle is panel.scene.nx:
            press(panel.scene.build_button)
        settle(web_app)
        assert handle.value == in_use, handle.label
    web_app.set_selection(np.array([0]))
    mass = panel.selection.mass.value
    send(panel.selection.mass, -1.0)
    settle(web_app)
    assert panel.selection.mass.value == mass
    assert "refused" in panel.selection.message.content

