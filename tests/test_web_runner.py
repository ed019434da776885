"""The web app's commands and interaction logic, without a browser.

``SimulationControl`` posts commands to a running ``LatticeRunner``; ``WebApp`` turns clicks
(pointer rays) and gizmo drags into those commands.  Servers here bind a free localhost port and
are always stopped.
"""

from __future__ import annotations

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from app.web.control import LatticeRunner, SimulationControl
from tests.helpers import free_port, wait_for


@pytest.fixture
def running():
    simulation = sim.Simulation(sim.scenes.build("grid"))
    runner = LatticeRunner(simulation, max_fps=200)
    runner.start()
    yield runner, SimulationControl(runner)
    runner.stop()


@pytest.fixture
def web_app():
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port())
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None)
    yield app
    app.stop()


def test_gravity_change_reaches_the_simulation(running):
    runner, control = running
    control.set_gravity(True, 3.5).result(timeout=5)
    assert runner.simulation.model.gravity[:2] == (0.0, -3.5)
    control.set_gravity(False).result(timeout=5)
    assert not runner.simulation.model.has_gravity


def test_bad_parameter_is_rejected_and_changes_nothing(running):
    runner, control = running
    with pytest.raises(sim.ModelError):
        control.set_stiffness(-1.0).result(timeout=5)
    assert runner.simulation.model.stiffness == 35.0


def test_drag_command_displaces_exactly_that_particle(running):
    runner, control = running
    before = runner.simulation.peek_positions()
    target = before[17] + np.array([0.3, -0.2])
    control.move_particles([17], target[None, :]).result(timeout=5)
    after = runner.simulation.peek_positions()
    assert np.allclose(after[17], target)
    moved = np.flatnonzero(np.any(after != before, axis=1))
    assert moved.tolist() == [17]


def test_pinned_particle_is_held_while_running_and_released(running):
    runner, control = running
    model = runner.simulation.model
    target = model.rest_positions[40] + np.array([0.0, 0.4])
    control.move_particles([40], target[None, :], owner="client-1", pin=True).result(timeout=5)
    runner.play()
    assert wait_for(lambda: runner.simulation.step_count > 30)
    runner.pause()
    runner.post(lambda s: None).result(timeout=5)
    assert np.allclose(runner.simulation.peek_positions()[40], target)
    control.release("client-1").result(timeout=5)
    assert not runner.pins
    runner.play()
    assert wait_for(lambda: not np.allclose(runner.simulation.peek_positions()[40], target))
    runner.pause()


def test_unstable_dt_pauses_with_a_message_and_a_finite_state(running):
    runner, control = running
    stable = runner.simulation.stable_dt()
    frames = []
    runner.subscribe(frames.append)
    control.set_dt(5 * stable).result(timeout=5)
    runner.play()
    assert wait_for(lambda: any(frame.error for frame in frames))
    assert wait_for(lambda: not runner.playing)
    errored = next(frame for frame in frames if frame.error)
    assert "stability limit" in errored.error
    assert np.isfinite(runner.simulation.peek_positions()).all()


def test_mass_pattern_and_selection_mass(running):
    runner, control = running
    control.set_mass_pattern("ionic", heavy=4.0).result(timeout=5)
    assert set(np.unique(runner.simulation.masses)) == {1.0, 4.0}
    control.set_particle_masses([3, 5], 7.5).result(timeout=5)
    assert runner.simulation.masses[3] == 7.5 and runner.simulation.masses[5] == 7.5


def test_replace_scene_and_snapshot_keep_the_state(running):
    runner, control = running
    control.replace_scene(sim.scenes.build("chain")).result(timeout=10)
    assert runner.simulation.model.nx == 5

    def displace(simulation: sim.Simulation) -> tuple:
        simulation.positions[1] += (0.1, -0.2)
        simulation.velocities[3] = (0.5, 0.25)
        simulation.set_masses(np.array([1.0, 2.0, 3.0, 4.0, 5.0]))
        return simulation.peek_positions(), simulation.state.particle_velocities().copy()

    positions, velocities = runner.post(displace).result(timeout=5)
    scene = control.snapshot().result(timeout=5)
    control.replace_scene(sim.scenes.build("grid")).result(timeout=10)
    control.replace_scene(scene).result(timeout=10)
    loaded = runner.post(lambda s: (s.model, s.peek_positions(), s.velocities.copy())).result(5)
    model, loaded_positions, loaded_velocities = loaded
    assert model.nx == 5 and model.ny == 1
    np.testing.assert_array_equal(model.masses.ravel(), [1.0, 2.0, 3.0, 4.0, 5.0])
    np.testing.assert_allclose(loaded_positions, positions)
    np.testing.assert_allclose(loaded_velocities, velocities)


def test_steps_per_frame_outside_the_range_is_refused(running):
    runner, control = running
    for bad in (0, -3, 10**9, 2.5, True):
        with pytest.raises(ValueError):
            control.set_steps_per_frame(bad)
    assert runner.steps_per_frame == 1


def test_click_ray_selects_the_particle_under_it(web_app):
    model = web_app.runner.simulation.model
    centre = 3 * model.nx + 5  # 11x7: the middle particle sits at the origin
    assert web_app.click((0.0, 0.0, 20.0), (0.0, 0.0, -1.0)) == centre
    assert web_app.view.selection.tolist() == [centre]
    # slanted ray landing on particle 0 (bottom left)
    x, y = model.rest_positions[0]
    assert web_app.click((x + 1.0, y + 1.0, 10.0), (-0.1, -0.1, -1.0)) == 0
    assert web_app.click((0.0, 0.0, 20.0), (0.0, 0.0, -1.0), add=True) == centre
    assert sorted(web_app.view.selection.tolist()) == [0, centre]
    # a click outside the lattice selects nothing and keeps the selection
    assert web_app.click((50.0, 50.0, 20.0), (0.0, 0.0, -1.0)) is None
    assert sorted(web_app.view.selection.tolist()) == [0, centre]


def test_gizmo_drag_moves_the_selection_and_release_lets_go(web_app):
    model = web_app.runner.simulation.model
    web_app.set_selection(np.array([0]))
    start = model.rest_positions[0].copy()
    owner = 123
    web_app.drag("start", np.array([*start, 0.0]), owner=owner)
    web_app.drag("update", np.array([start[0] + 0.5, start[1] + 0.25, 0.0]), owner=owner)
    web_app.runner.post(lambda s: None).result(timeout=5)
    assert owner in web_app.runner.pins
    assert np.allclose(web_app.runner.simulation.peek_positions()[0], start + [0.5, 0.25])
    web_app.drag("end", np.array([start[0] + 0.5, start[1] + 0.25, 0.0]), owner=owner)
    web_app.runner.post(lambda s: None).result(timeout=5)
    assert not web_app.runner.pins
    assert np.allclose(web_app.runner.simulation.peek_positions()[0], start + [0.5, 0.25])


def test_disconnect_mid_drag_releases_the_pins(web_app):
    web_app.set_selection(np.array([5]))
    start = web_app.runner.simulation.model.rest_positions[5]
    web_app.drag("start", np.array([*start, 0.0]), owner=7)
    web_app.drag("update", np.array([start[0], start[1] + 0.3, 0.0]), owner=7)
    web_app.runner.post(lambda s: None).result(timeout=5)
    assert 7 in web_app.runner.pins

    web_app.client_left(7)
    web_app.runner.post(lambda s: None).result(timeout=5)
    assert not web_app.runner.pins and web_app._drag is None


def test_page_recording_records_the_running_lattice(running, tmp_path):
    from app.web.recording import WebRecordings
    from tests.test_recording import read_chunks, temporal

    runner, control = running
    recordings = WebRecordings(runner, tmp_path)
    recordings.start(control.snapshot().result(timeout=5))
    started_at = runner.simulation.step_count
    runner.play()
    assert wait_for(lambda: runner.simulation.step_count > started_at + 20)
    runner.pause()
    runner.post(lambda s: None).result(timeout=5)  # the last frame has been published
    energy_before_stop = runner.simulation.energy().total
    last_step = runner.simulation.step_count
    path = recordings.stop()
    assert path.exists() and path.suffix == ".rrd"
    totals = temporal(read_chunks(path), "/energy/total", "Scalars:scalars")
    recorded_steps = sorted(totals)
    # live runs are thinned to at most 25 frames per simulated second (dt = 0.01 s: every 4th)
    assert recorded_steps and last_step - recorded_steps[-1] < 4
    assert len([step for step in recorded_steps if step > started_at]) >= 5
    if recorded_steps[-1] == last_step:
        assert totals[last_step][0].as_py() == pytest.approx(energy_before_stop)


def test_speed_accuracy_study_from_the_page(web_app):
    panel = web_app.panel
    panel.study.measure(1e-2)
    assert panel.study.image.visible
    assert panel.study.image.image.shape[2] == 3 and panel.study.image.image.shape[0] > 100
    assert "Recommendation" in panel.study.text.content
    assert " at dt = " in panel.study.text.content  # an integrator and dt that meet 1e-2
