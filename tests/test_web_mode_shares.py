"""The Modes folder follows the FPU chain: the fput scene opens at a speed that shows its first
recurrence within a minute and a half, the folder samples every frame and plots the shares of
modes 1-4 with the return marked; a reset empties the plot; other lattices show no such plot."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from app.web.app import WebApp
from app.web.folders.run import SPEEDS
from tests.helpers import free_port, wait_for


@pytest.fixture
def fput_app():
    app = WebApp(sim.Simulation(sim.scenes.build("fput")), port=free_port())
    app.start()
    yield app
    app.stop()


def assert_plotted_return(view) -> None:
    """The plot of 158 periods: mode 1 starts with the energy, gives it away, and its one
    return, 98.1 % at 153.4 periods, is marked and said."""
    view.update(now=1e9)
    times, first, *_, marks = view.plot.data
    assert first[0] > 0.99 and first.min() < 0.1
    returned = np.flatnonzero(np.isfinite(marks))
    assert returned.size == 1 and times[returned[0]] == pytest.approx(153.4, abs=0.5)
    assert "back (●): 98.1% at 153.4 periods" in view.text.content


def test_the_folder_plots_the_shares_and_marks_the_return(fput_app):
    """Frames of a run stepped here, handed to the folder as the runner hands them."""
    from sim.runtime.runner import Frame

    view, runner = fput_app.panel.spectrum.mode_shares, fput_app.runner
    # the app's own first frame (at t = 0) reaches the folder first: arriving among the frames
    # below, it would read as a reset
    assert wait_for(lambda: view.shares is not None and view.shares.times.size >= 1)
    speed = SPEEDS[fput_app.panel.run.speed.value]
    assert runner.simulation.scene.duration / speed <= 90.0 and speed > 1
    assert runner.max_fps * runner.steps_per_frame * runner.simulation.dt == pytest.approx(speed)
    simulation = sim.Simulation(sim.scenes.build("fput"))
    model = fput_app.runner.simulation.model  # the model the folder knows
    energy = simulation.energy()
    while simulation.time < 158 * 66.02:
        simulation.step(66)
        view._sample(Frame(simulation.step_count, simulation.time, "verlet", simulation.dt,
                           model, simulation.state.particle_positions().copy(), energy,
                           simulation.state.particle_velocities().copy()))
    assert_plotted_return(view)


@pytest.mark.slow
def test_the_fput_chain_plays_fast_and_its_modes_are_plotted(fput_app):
    run, view = fput_app.panel.run, fput_app.panel.spectrum.mode_shares
    runner = fput_app.runner
    speed = SPEEDS[run.speed.value]
    duration = runner.simulation.scene.duration
    assert duration / speed <= 90.0 and speed > 1
    assert runner.max_fps * runner.steps_per_frame * runner.simulation.dt == pytest.approx(speed)
    # 160 periods of mode 1, as the runner would play them, a frame every 66 steps
    runner.steps_per_frame = 66
    runner.max_fps = 1000.0
    runner.play()
    assert wait_for(lambda: runner.simulation.time > 158 * 66.02 or not runner.playing,
                    timeout=120)
    runner.pause()
    assert view.plot.visible
    assert_plotted_return(view)
    fput_app.control.reset().result(timeout=10)
    runner.play()  # the first frames after the reset start the plot again
    assert wait_for(lambda: view.shares.times.size >= 1 and view.shares.times[-1] < 1000)
    runner.pause()
    assert view.plot.data[0].size == 0 or view.plot.data[0].max() < 1000 / 66.02


def test_a_grid_has_no_mode_share_plot(web_app):
    view = web_app.panel.spectrum.mode_shares
    assert view.shares is None and not view.plot.visible


@pytest.mark.parametrize(("preset", "sizes", "particles"),
                         [("single", {}, 1), ("chain", {"nx": 3}, 3)])
def test_a_chain_of_fewer_particles_than_plotted_modes_is_plotted(preset, sizes, particles):
    """One particle between two walls has one mode, three have three: the folder plots those
    (the others left empty) instead of failing."""
    from sim.runtime.runner import Frame

    app = WebApp(sim.Simulation(sim.scenes.build(preset, **sizes)), port=free_port())
    app.start()
    try:
        view = app.panel.spectrum.mode_shares
        assert wait_for(lambda: view.shares is not None and view.shares.times.size >= 1)
        simulation = sim.Simulation(sim.scenes.build(preset, **sizes))
        assert simulation.model.nx == particles
        for _ in range(40):
            simulation.step(20)
            view._sample(Frame(simulation.step_count, simulation.time, "verlet", simulation.dt,
                               app.runner.simulation.model,
                               simulation.state.particle_positions().copy(), simulation.energy(),
                               simulation.state.particle_velocities().copy()))
        view.update(now=1e9)
        times, *modes, marks = view.plot.data
        assert len(modes) == 4 and times.size >= 3
        assert np.allclose(np.sum([m for m in modes if np.isfinite(m).all()], axis=0), 1.0)
        assert sum(np.isfinite(m).all() for m in modes) == particles
        assert "mode 1" in view.text.content
    finally:
        app.stop()
