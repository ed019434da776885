"""The page's Drive folder and walls control, without a browser.

Values "from a page" are sent the way viser delivers a browser's message (``send`` / ``press``
from ``tests.test_web_safety``); values the server assigns itself must post nothing.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from app.web.control import DRIVE_RAMP, LatticeRunner, SimulationControl
from app.web.folders.drive import mode_frequencies
from sim.instruments.probes import mode_table
from sim.model.forcing import Driver
from sim.theory.modes import ModalBasis
from tests.helpers import wait_for
from tests.test_web_safety import press, send, settle


def driven_work(app: WebApp) -> float:
    """The driver's work (J) of the running simulation, read between steps (the first driven
    steps compile the driven loops: on a cold cache that takes a while)."""
    return app.runner.post(lambda simulation: simulation.energy().driven).result(timeout=180)


class CommandSpy:
    """Replaces the control's model-changing commands by recorders (what a refresh must not
    call)."""

    NAMES = ("drive", "stop_driving", "set_boundary", "set_parameters", "set_stiffness",
             "set_damping", "set_gravity", "set_mass_pattern", "set_dt", "set_integrator")

    def __init__(self, control: SimulationControl) -> None:
        self.calls: list[str] = []
        for name in self.NAMES:
            setattr(control, name, self._recorder(name))

    def _recorder(self, name: str) -> Any:
        def record(*_: Any, **__: Any) -> None:
            self.calls.append(name)

        return record


def test_driving_the_selected_particle_sets_the_driver_and_its_work_grows(web_app):
    drive = web_app.panel.drive
    model = web_app.runner.simulation.model
    particle = 3 * model.nx + 2
    web_app.set_selection(np.array([particle]))
    assert "column 2, row 3" in drive.target.content
    send(drive.frequency, 0.8)
    send(drive.amplitude, 0.05)
    send(drive.kind, "force")
    send(drive.direction, "y")
    press(drive.drive_button)
    assert "driving particle (2, 3)" in drive.message.content, drive.message.content
    driver = web_app.runner.simulation.model.driver
    assert driver == Driver(column=2, row=3, direction=(0.0, 1.0, 0.0), amplitude=0.05,
                            frequency=0.8, kind="force", start=0.0, ramp=DRIVE_RAMP)
    web_app.runner.steps_per_frame = 25
    web_app.runner.play()
    assert wait_for(lambda: driven_work(web_app) > 0.0, timeout=180)
    first = driven_work(web_app)
    assert wait_for(lambda: driven_work(web_app) > first, timeout=10)
    assert wait_for(lambda: "work done by the driver so far" in drive.state.content)
    web_app.runner.pause()
    # the energy plot carries the driver's work as a sixth series
    assert wait_for(lambda: web_app.panel.energy.shows_driver)
    assert [series["label"] for series in web_app.panel.energy.plot.series][-1] == "driver's work"


def test_stop_driving_clears_the_driver_and_keeps_its_work(web_app):
    drive = web_app.panel.drive
    web_app.set_selection(np.array([5]))
    send(drive.amplitude, 0.1)
    press(drive.drive_button)
    assert web_app.runner.simulation.model.driver is not None
    web_app.runner.steps_per_frame = 25
    web_app.runner.play()
    assert wait_for(lambda: driven_work(web_app) != 0.0, timeout=180)
    web_app.runner.pause()
    press(drive.stop_button)
    assert web_app.runner.simulation.model.driver is None
    assert "stopped driving" in drive.message.content
    assert "not driven" in drive.state.content
    work = driven_work(web_app)
    assert work != 0.0  # the energy account keeps what the driver did
    assert wait_for(lambda: web_app.panel.energy.shows_driver)


def test_a_driven_preset_is_shown_and_refreshing_posts_no_commands(web_app):
    panel = web_app.panel
    drive = panel.drive
    spy = CommandSpy(web_app.control)
    scene = sim.scenes.build("resonance")
    web_app.replace_scene(scene, source="test")
    model = web_app.runner.simulation.model
    driver = scene.model.driver
    assert model.driver == driver
    assert drive.frequency.value == driver.frequency
    assert drive.amplitude.value == driver.amplitude
    assert (drive.kind.value, drive.direction.value) == ("force", "x")
    assert "Driven (force A k) at particle (0, 0)" in drive.state.content
    assert "Lowest normal modes along x" in drive.modes.content
    assert f"{driver.frequency:.4g}" in drive.modes.content  # the third mode is listed
    # the server assigning the folder's (and the walls') values changes nothing
    drive.frequency.value = 1.3
    drive.amplitude.value = 0.2
    drive.kind.value = "displacement"
    drive.direction.value = "y"
    panel.scene.walls.boundary.value = "absorbing"
    panel.scene.walls.sponge_width.value = 2
    drive.show_scene(web_app.runner.simulation)
    panel.show_scene(web_app.runner.simulation)
    settle(web_app)
    assert spy.calls == []
    assert web_app.runner.simulation.model is model


BAD_DRIVE_VALUES = [
    ("frequency", float("nan")), ("frequency", float("inf")), ("frequency", 0.0),
    ("frequency", -1.0), ("frequency", 1e9), ("frequency", True), ("amplitude", float("nan")),
    ("amplitude", -0.01), ("amplitude", float("inf")), ("amplitude", 1e6),
    ("kind", "laser"), ("direction", "z"), ("direction", "<b>x</b>"),
]


def test_bad_drive_values_from_the_page_are_refused_and_change_nothing(web_app):
    drive = web_app.panel.drive
    model = web_app.runner.simulation.model
    web_app.set_selection(np.array([3]))
    good = {name: getattr(drive, name).value for name in ("frequency", "amplitude", "kind",
                                                          "direction")}
    for widget, bad in BAD_DRIVE_VALUES:
        send(getattr(drive, widget), bad)
        press(drive.drive_button)
        message = drive.message.content
        assert "could not drive" in message and widget in message, (widget, bad, message)
        assert "<b>" not in message
        assert web_app.runner.simulation.model is model
        send(getattr(drive, widget), good[widget])
    press(drive.drive_button)  # the good values drive
    assert web_app.runner.simulation.model.driver is not None


def test_a_drive_without_a_particle_inside_the_lattice_is_refused(web_app):
    drive = web_app.panel.drive
    model = web_app.runner.simulation.model
    press(drive.drive_button)  # nothing selected, nothing driven
    assert "select the particle" in drive.message.content
    web_app.view.set_selection(np.array([model.n_particles + 5]))  # e.g. a stale selection
    press(drive.drive_button)
    assert f"at most {model.n_particles - 1}, got {model.n_particles + 5}" in drive.message.content
    assert web_app.runner.simulation.model is model


def test_absorbing_walls_on_a_too_small_lattice_are_refused_and_keep_the_scene(web_app):
    panel = web_app.panel
    model = web_app.runner.simulation.model
    send(panel.scene.walls.boundary, "absorbing")
    send(panel.scene.walls.sponge_width, 30)
    press(panel.scene.walls.boundary_button)
    assert "could not change the walls" in panel.scene.message.content
    assert "sponge_width" in panel.scene.message.content  # the model's own explanation
    assert web_app.runner.simulation.model is model
    assert panel.scene.walls.boundary.value == "fixed"  # shows what runs
    for widget, bad in ((panel.scene.walls.sponge_width, float("nan")), (panel.scene.walls.sponge_width, 0),
                        (panel.scene.walls.sponge_width, 2.5), (panel.scene.walls.boundary, "open")):
        send(widget, bad)
        press(panel.scene.walls.boundary_button)
        assert "could not change the walls" in panel.scene.message.content
        assert web_app.runner.simulation.model is model
    send(panel.scene.walls.boundary, "absorbing")
    send(panel.scene.walls.sponge_width, 2)
    press(panel.scene.walls.boundary_button)
    changed = web_app.runner.simulation.model
    assert (changed.boundary, changed.sponge_width) == ("absorbing", 2)
    assert changed.sponge_sides == ("left", "right", "bottom", "top")
    assert "walls now absorbing" in panel.scene.message.content
    assert "absorbing" in panel.scene.info.content
    send(panel.scene.walls.boundary, "fixed")
    press(panel.scene.walls.boundary_button)
    assert web_app.runner.simulation.model.boundary == "fixed"


def test_a_scene_with_periodic_rows_opens_and_shows_its_walls(web_app):
    panel = web_app.panel
    web_app.replace_scene(sim.scenes.build("chain", boundary="periodic"), source="test")
    assert panel.scene.walls.boundary.value == "periodic" and "periodic" in panel.scene.walls.boundary.options
    assert "periodic rows" in panel.spectrum.frequency.content
    assert panel.spectrum.excite_button.disabled
    lowest, _ = mode_frequencies(web_app.runner.simulation.model, 0)
    assert f"{lowest[0]:.4g}" in panel.drive.modes.content  # the ring's lowest wave
    send(panel.scene.walls.boundary, "fixed")
    press(panel.scene.walls.boundary_button)
    assert web_app.runner.simulation.model.boundary == "fixed"
    assert panel.scene.walls.boundary.options == ("fixed", "absorbing", "periodic", "free")


def test_the_exact_solver_refuses_a_driver_and_keeps_the_model():
    simulation = sim.Simulation(sim.scenes.build("chain", linear=True), integrator="exact")
    runner = LatticeRunner(simulation)
    runner.start()
    try:
        control = SimulationControl(runner)
        model = simulation.model
        with pytest.raises(sim.IntegratorError, match="another integrator"):
            control.drive(0, 0, "x", 0.05, 1.0, "force").result(timeout=10)
        with pytest.raises(sim.IntegratorError):
            control.set_boundary("absorbing", 1).result(timeout=10)
        assert runner.simulation.model is model and runner.simulation.integrator == "exact"
    finally:
        runner.stop()


def test_reset_starts_a_drive_from_the_page_again_at_time_zero():
    runner = LatticeRunner(sim.Simulation(sim.scenes.build("chain")))
    runner.start()
    try:
        control = SimulationControl(runner)
        runner.post(lambda simulation: simulation.step(50)).result(timeout=10)
        driver = control.drive(1, 0, "y", 0.05, 1.0, "displacement").result(timeout=10)
        assert driver.start == pytest.approx(0.5)
        control.reset().result(timeout=10)
        assert runner.simulation.model.driver.start == 0.0
        assert runner.simulation.time == 0.0
    finally:
        runner.stop()


def test_mode_frequencies_are_the_lattice_normal_modes():
    tensioned = sim.Model.create(7, 5, stiffness=35.0, rest_length=0.8)
    for polarisation in (0, 1):
        name = "xy"[polarisation]
        expected = sorted({round(mode.frequency, 9) for mode in mode_table(tensioned)
                           if mode.polarisation == name})
        lowest, highest = mode_frequencies(tensioned, polarisation, count=4)
        np.testing.assert_allclose(lowest, expected[:4], rtol=1e-9)
        assert highest == pytest.approx(expected[-1])
    ring = sim.Model.create(9, 3, stiffness=35.0, rest_length=0.9, boundary="periodic")
    for polarisation in (0, 1):
        lowest, highest = mode_frequencies(ring, polarisation, count=4)
        omega_squared = np.sort(ModalBasis.of(ring).omega_squared[polarisation])
        frequencies = np.sqrt(omega_squared[omega_squared > 1e-9]) / (2 * math.pi)
        distinct = [f for k, f in enumerate(frequencies)
                    if k == 0 or not math.isclose(f, frequencies[k - 1], rel_tol=1e-6)]
        np.testing.assert_allclose(lowest, distinct[:4], rtol=1e-9)
        assert highest == pytest.approx(frequencies[-1])
    ionic = sim.scenes.build("bandgap", nx=40).model
    lowest, highest = mode_frequencies(ionic, 0, count=3)
    omega = np.sqrt(np.sort(ModalBasis.of(ionic).omega_squared[0]))
    np.testing.assert_allclose(lowest, omega[:3] / (2 * math.pi))
    assert highest == pytest.approx(omega[-1] / (2 * math.pi))


@pytest.mark.parametrize("walls", ["periodic", "free"])
def test_periodic_and_free_walls_from_the_page_change_the_running_lattice(web_app, walls):
    panel = web_app.panel
    panel.scene.walls.boundary.value = walls
    web_app.control.set_boundary(walls, 3).result(timeout=30)
    model = web_app.runner.simulation.model
    assert model.boundary == walls
    web_app.control.set_boundary("fixed", 3).result(timeout=30)
    assert web_app.runner.simulation.model.boundary == "fixed"
