"""The page's Dispersion folder without a browser: it follows the scene, the integrator and the
time step, draws the integrator's numerical dispersion of the current dt, describes the chosen
wave and refuses bad values in red."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.theory.bands import verlet_omega
from tests.helpers import wait_for
from tests.test_web_safety import press, send, settle


def labels(folder) -> list[str]:
    """The labels of the plotted lines; none while the folder swaps in a new plot (it replaces
    the plot from the runner's thread when the integrator or the time step changes)."""
    plot = folder.plot
    return [] if plot is None else [series["label"] for series in plot.series]


def plotted(folder, label: str) -> np.ndarray:
    """The values of the plotted line ``label``."""
    labels = [series["label"] for series in folder.plot.series]
    return np.asarray(folder.plot.data[labels.index(label)])


def test_the_folder_follows_the_integrator_and_the_time_step(web_app):
    panel = web_app.panel
    folder = panel.dispersion
    assert folder.plot is not None and "x by rk4" in [s["label"] for s in folder.plot.series]
    send(panel.integrator.method, "verlet")
    settle(web_app)
    web_app.runner.play()
    assert wait_for(lambda: "y by verlet" in labels(folder))
    send(panel.integrator.dt, 0.2)
    settle(web_app)
    assert wait_for(lambda: "dt = 0.2 s" in folder.summary.content)
    web_app.runner.pause()
    bands = plotted(folder, "x")
    numerical = plotted(folder, "x by verlet")
    expected = verlet_omega(bands, 0.2)
    stable = bands * 0.2 < 2.0
    assert np.allclose(numerical[stable], expected[stable], rtol=1e-9)
    # the grid's highest waves (11.8 rad/s) grow at dt = 0.2 s: their line leaves the plot
    top = folder.plot.scales["y"]["range"][1]
    assert (~stable).any() and np.all(numerical[~stable] > top)
    assert "grow" in folder.summary.content


def test_the_chosen_wave_is_described_and_bad_values_are_refused(web_app):
    folder = web_app.panel.dispersion
    send(folder.branch, "x")
    send(folder.position, 0.1)  # on Gamma-X: q along x, a tenth of the path's 2 + sqrt 2
    q = 0.1 * (2 + math.sqrt(2)) * math.pi
    assert f"|q| = {q:.4g} rad/m" in folder.point_text.content
    omega = 2 * math.sqrt(35.0) * math.sin(q / 2)
    assert f"ω = {omega:.4g} rad/s" in folder.point_text.content
    marker = plotted(folder, "chosen wave")
    assert np.nanmax(marker) == omega or abs(np.nanmax(marker) - omega) < 0.05 * omega
    send(folder.position, float("nan"))
    assert "refused" in folder.message.content and "c0392b" in folder.message.content
    send(folder.branch, "<b>P</b>")
    assert "refused" in folder.message.content and "<b>P</b>" not in folder.message.content
    assert folder.branch.value == "x"


def test_a_new_scene_redraws_the_bands(web_app):
    panel = web_app.panel
    send(panel.scene.preset, "ionic")
    press(panel.scene.build_button)
    settle(web_app)
    folder = panel.dispersion
    assert wait_for(lambda: "ionic lattice" in folder.summary.content)
    assert list(folder.branch.options) == ["x acoustic", "x optical", "y acoustic", "y optical"]
    assert "ionic lattice" in folder.summary.content
    optical = plotted(folder, "x optical")
    assert np.min(optical) == np.min(optical)  # finite
    assert math.isclose(float(np.min(optical)), math.sqrt(2 * 35.0 / 1.0), rel_tol=1e-3)


def test_the_modes_folder_draws_the_density_of_states(web_app):
    spectrum = web_app.panel.spectrum
    web_app.runner.play()
    assert wait_for(lambda: spectrum.density_plot is not None)
    web_app.runner.pause()
    centres, density = (np.asarray(column) for column in spectrum.density_plot.data)
    model = web_app.runner.simulation.model
    width = centres[1] - centres[0]
    assert float(density.sum() * width) == pytest.approx(model.n_particles * model.dim)
    assert f"{model.n_particles * model.dim:,} exact normal-mode" in spectrum.density_text.content


def test_launch_puts_the_chosen_packet_in_the_lattice_and_refuses_what_it_cannot(web_app):
    from sim.scenes.packet import PacketSpec, packet_state

    folder = web_app.panel.dispersion
    send(folder.branch, "y")
    send(folder.position, 0.0)
    press(folder.launch_button)
    assert "refused" in folder.message.content and "Γ" in folder.message.content
    send(folder.position, 0.6)  # on X-M
    press(folder.launch_button)
    settle(web_app)
    assert "launched a packet on branch y" in folder.message.content
    model = web_app.runner.simulation.model
    _, qx, qy = folder.structure.point(0.6)
    expected, _ = packet_state(model, PacketSpec(qx, qy, "y"), None)
    assert np.allclose(web_app.runner.simulation.positions, expected)
    assert "press Play" in folder.message.content
    web_app.runner.play()  # the words follow the run
    assert wait_for(lambda: "it moves as the run plays" in folder.message.content)
    web_app.runner.pause()
    assert not folder.launch_button.disabled and not folder.launch_reason.visible
    panel = web_app.panel
    send(panel.scene.preset, "ionic")
    press(panel.scene.build_button)
    settle(web_app)
    assert wait_for(lambda: "ionic lattice" in folder.summary.content)
    assert not folder.launch_button.disabled  # a Bloch packet of the checkerboard's branch
    send(folder.branch, "x optical")
    send(folder.position, 0.3)
    press(folder.launch_button)
    settle(web_app)
    assert "launched a packet on branch x optical" in folder.message.content
    model = web_app.runner.simulation.model
    _, qx, qy = folder.structure.point(0.3)
    expected, _ = packet_state(model, PacketSpec(qx, qy, "x optical"), None)
    assert np.allclose(web_app.runner.simulation.positions, expected)
    masses = 1.0 + np.random.default_rng(0).random(model.n_particles)  # no repeating cell
    web_app.runner.post(lambda simulation: simulation.set_masses(masses)).result(timeout=30)
    settle(web_app)
    assert wait_for(lambda: folder.launch_button.disabled)  # a button that cannot act says why
    assert folder.launch_reason.visible and "ionic checkerboard" in folder.launch_reason.content


class StandInTracker:
    """A tracker that reports fixed speeds (m/s) once it has seen frames: the folder's display
    of measured speeds is tested apart from the measurement."""

    def __init__(self, model, spec) -> None:
        self.frames = 0

    def add(self, time: float, positions) -> None:
        self.frames += 1

    def speeds(self) -> dict[str, float]:
        if self.frames < 3:
            raise ValueError("too few frames")
        return {"group_speed": 3.25, "phase_speed": 4.5}


def test_measured_speeds_are_shown_and_a_reset_takes_them_away(web_app, monkeypatch):
    import sys
    import types

    module = types.ModuleType("sim.instruments.packet_tracker")
    module.PacketTracker = StandInTracker
    monkeypatch.setitem(sys.modules, "sim.instruments.packet_tracker", module)
    folder = web_app.panel.dispersion
    send(folder.branch, "x")
    send(folder.position, 0.1)
    press(folder.launch_button)
    settle(web_app)
    web_app.runner.play()
    assert wait_for(lambda: "measured group speed 3.25 m/s" in folder.point_text.content)
    web_app.runner.pause()
    assert "phase speed 4.5 m/s" in folder.point_text.content
    measured = plotted(folder, "measured")
    size = 0.1 * (2 + math.sqrt(2)) * math.pi  # |q| on Gamma-X (a = 1 m)
    chosen = int(np.flatnonzero(np.isfinite(plotted(folder, "chosen wave")))[0])
    assert measured[chosen] == pytest.approx(4.5 * size, rel=1e-9)
    press(web_app.panel.run.reset_button)
    settle(web_app)
    assert wait_for(lambda: "measured" not in folder.point_text.content)
    assert wait_for(lambda: not np.isfinite(plotted(folder, "measured")).any())


@pytest.fixture
def wide_grid(tmp_path):
    import sim
    from app.web.app import WebApp
    from tests.helpers import free_port

    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=80, ny=40), integrator="verlet",
                                dt=0.02),
                 port=free_port(), scenes_dir=tmp_path / "scenes",
                 recordings_dir=tmp_path / "recordings")
    app.start()
    assert wait_for(lambda: app.view.last_positions is not None, timeout=120)
    yield app
    app.stop()


def test_a_launched_packet_s_measured_speeds_agree_with_the_bands(wide_grid):
    """An x packet along x, lambda = 4.9 a, on an 80x40 grid: its centroid moves at the group
    velocity and its carrier turns at Verlet's numerical frequency of omega(q)."""
    folder = wide_grid.panel.dispersion
    send(folder.branch, "x")
    send(folder.position, 0.12)
    press(folder.launch_button)
    settle(wide_grid)
    wide_grid.runner.play()
    assert wait_for(lambda: folder._tracker is not None and folder._tracker.times.size > 3
                    and folder._tracker.times[-1] - folder._tracker.times[0] > 3.0, timeout=120)
    wide_grid.runner.pause()
    measured = folder._tracker.speeds()
    _, qx, qy = folder.structure.point(0.12)
    theory = folder.structure.wave("x", qx, qy)
    assert measured["group_speed"] == pytest.approx(theory["group_speed"], rel=0.01)
    verlet = float(verlet_omega(theory["omega"], 0.02)) / theory["q"]
    # measured 5.52063 m/s: Verlet's 5.52072, not the lattice's 5.51607
    assert measured["phase_speed"] == pytest.approx(verlet, rel=1e-4)
    assert abs(measured["phase_speed"] - theory["phase_speed"]) > 5e-4 * theory["phase_speed"]
    assert wait_for(lambda: "measured group speed" in folder.point_text.content, timeout=10)
