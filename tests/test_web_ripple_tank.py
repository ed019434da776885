"""The page's ripple-tank folders (Sources, Barrier, Screen, Tape and stopwatch), without a browser.

Values "from a page" are sent the way viser delivers a browser's message (``send`` / ``press``
from ``tests.test_web_safety``); values the server assigns itself must post nothing.  The scenes
are small versions of the presets (a 60x41 membrane with thin walls), so nothing here runs long.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import sim
from app.web.folders.measure import Stopwatch
from sim.runtime.runner import Frame
from tests.test_web_safety import press, send, settle


def small_double_slit() -> sim.Scene:
    return sim.scenes.build("double-slit", nx=60, ny=41, sponge_width=6,
                            barriers=[{"column": 30, "openings": [[15, 17], [23, 25]]}])


def small_two_sources() -> sim.Scene:
    point = dict(direction="z", amplitude=0.02, frequency=0.33, kind="force", ramp=3.0)
    return sim.scenes.build("two-sources", nx=40, ny=40, sponge_width=6,
                            sources=[dict(point, column=20, row=16),
                                     dict(point, column=20, row=24, phase=0.5)])


class Spy:
    """Replaces the commands the ripple-tank folders post by recorders."""

    def __init__(self, control: Any) -> None:
        self.calls: list[str] = []
        for name in ("set_sources", "set_barriers", "set_parameters", "drive"):
            setattr(control, name, lambda *_, name=name, **__: self.calls.append(name))


def test_the_folders_show_the_scene_in_use_and_refreshing_posts_nothing(web_app):
    panel = web_app.panel
    for name in ("sources", "barrier", "screen", "measure"):  # the 11x7 grid has no sources
        assert not getattr(panel, name).folder.visible
    web_app.replace_scene(small_double_slit(), source="test")
    model = web_app.runner.simulation.model
    for name in ("sources", "barrier", "screen", "measure"):
        assert getattr(panel, name).folder.visible
    assert (panel.barrier.slits.value, panel.barrier.width.value,
            panel.barrier.separation.value) == ("two", 3, 8)
    assert panel.sources.frequency.value == model.sources[0].frequency
    assert "every row (a plane wave)" in panel.sources.where.content
    assert not panel.sources.difference.visible  # one source
    spy = Spy(web_app.control)
    panel.barrier.width.value = 7
    panel.barrier.slits.value = "one"
    panel.sources.frequency.value = 0.2
    panel.sources.phase.value = 1.0
    panel.screen.column.value = 40
    panel.show_scene(web_app.runner.simulation)
    settle(web_app)
    assert spy.calls == []
    assert web_app.runner.simulation.model is model
    assert panel.barrier.width.value == 3  # shown again as it runs


def test_barrier_sliders_rebuild_the_barrier_and_bad_values_change_nothing(web_app):
    web_app.replace_scene(small_double_slit(), source="test")
    barrier = web_app.panel.barrier
    send(barrier.width, 5)
    assert web_app.runner.simulation.model.barriers[0].openings == ((14, 18), (22, 26))
    send(barrier.separation, 12)
    assert web_app.runner.simulation.model.barriers[0].openings == ((12, 16), (24, 28))
    send(barrier.slits, "one")
    assert web_app.runner.simulation.model.barriers[0].openings == ((18, 22),)
    assert not barrier.separation.visible
    model = web_app.runner.simulation.model
    for handle, value in ((barrier.width, float("nan")), (barrier.width, 2.5),
                          (barrier.width, 0), (barrier.width, 1e9), (barrier.width, -3),
                          (barrier.slits, "three"), (barrier.width, 45)):
        send(handle, value)
        assert "refused" in barrier.message.content, (handle.label, value)
        assert web_app.runner.simulation.model is model
        assert barrier.width.value == 5 and barrier.slits.value == "one"  # the value in use
    send(barrier.slits, "two")  # two slits 5 wide, twice their width apart
    assert web_app.runner.simulation.model.barriers[0].openings == ((13, 17), (23, 27))
    send(barrier.separation, 4)  # slits 5 wide, 4 apart: they would overlap
    assert "need a separation above 5" in barrier.message.content
    assert web_app.runner.simulation.model.barriers[0].openings == ((13, 17), (23, 27))
    assert barrier.separation.value == 10


def test_sources_phase_difference_moves_adds_and_removes_sources(web_app):
    web_app.replace_scene(small_two_sources(), source="test")
    folder = web_app.panel.sources
    assert folder.difference.visible
    assert folder.difference.value == pytest.approx(0.5)
    send(folder.difference, 0.0)
    screen = web_app.panel.screen
    centre = web_app.runner.simulation.model.origin[1] + 20.0  # between rows 16 and 24
    in_phase = sorted(f.y - centre for f in screen._theory_of(
        web_app.runner.simulation.model, 34, 0.33, "z")[0])
    assert min(abs(y) for y in in_phase) < 1e-9  # a bright bisector
    send(folder.difference, math.pi)
    first, second = web_app.runner.simulation.model.sources
    assert math.remainder(second.phase - first.phase - math.pi, 2 * math.pi) == \
        pytest.approx(0.0, abs=1e-12)
    antiphase = sorted(f.y - centre for f in screen._theory_of(
        web_app.runner.simulation.model, 34, 0.33, "z")[0])
    assert min(abs(y) for y in antiphase) > 2.0  # a dark bisector, bright lines either side
    assert antiphase == pytest.approx([-y for y in reversed(antiphase)], abs=1e-9)
    model = web_app.runner.simulation.model
    for value in (float("nan"), 10.0, "1", True):
        send(folder.difference, value)
        assert "refused" in folder.message.content
        assert web_app.runner.simulation.model is model
    send(folder.chosen, "2")
    send(folder.frequency, 0.25)
    assert web_app.runner.simulation.model.sources[1].frequency == 0.25
    assert web_app.runner.simulation.model.sources[0].frequency == 0.33
    send(folder.frequency, 1e6)  # above half the step rate
    assert "refused" in folder.message.content
    assert folder.frequency.value == 0.25
    web_app.set_selection(np.array([10 * 40 + 12]))  # column 12, row 10
    press(folder.move_button)
    moved = web_app.runner.simulation.model.sources[1]
    assert (moved.column, moved.row) == (12, 10)
    web_app.set_selection(np.array([30 * 40 + 25]))
    press(folder.add_button)
    sources = web_app.runner.simulation.model.sources
    assert len(sources) == 3 and (sources[2].column, sources[2].row) == (25, 30)
    assert folder.chosen.value == "3"
    press(folder.remove_button)
    assert len(web_app.runner.simulation.model.sources) == 2


def test_the_screen_averages_the_frames_and_draws_the_slit_theory(web_app):
    web_app.replace_scene(small_double_slit(), source="test")
    folder = web_app.panel.folders.pop("screen")  # fed by hand below, not by the frame pump
    model = web_app.runner.simulation.model
    column = folder.screen.column
    setup = sim.scenes.ripple_tank.SlitSetup.of(model)
    theory = setup.theory(model, column)
    assert [f.y for f in folder._theory[0]] == [f.y for f in theory]
    # frames with u_z = g(y) sin(omega t): the screen shows <u^2> = g^2 / 2
    omega = 2 * math.pi * setup.frequency
    y = model.rest_positions[folder.screen.rows, 1]
    g = 0.01 * np.cos(0.2 * y)
    energy = web_app.runner.simulation.energy()
    for step in range(0, 401):
        t = step * (1.0 / setup.frequency) / 100
        positions = np.array(model.rest_positions)
        positions[folder.screen.rows, 2] = g * math.sin(omega * t)
        folder.update(Frame(step, t, "verlet", 0.01, model, positions, energy), now=0.0)
    assert folder.screen.whole_periods == 4
    assert np.allclose(folder.screen.intensity, 0.5 * g * g, rtol=0.02, atol=1e-9)
    # the table is the screen's intensity as the picture shows it (nan where no wave arrived)
    lines = folder.csv().splitlines()
    assert lines[0] == "y (m),time-averaged <u²> (m²)"
    table = np.loadtxt(lines[1:], delimiter=",")
    counted, _ = folder.counted_rows(folder._last_time, folder.screen)
    shown = np.where(counted, folder.screen.intensity, np.nan)
    assert np.allclose(table[:, 0], y)
    np.testing.assert_allclose(table[:, 1], shown, rtol=1e-8, equal_nan=True)


def test_the_tape_measures_spacings_and_metres_and_the_stopwatch_counts_simulated_time(web_app):
    folder = web_app.panel.measure
    assert not folder.folder.visible and not folder.tape_line.visible  # a grid: no tape on it
    web_app.replace_scene(small_double_slit(), source="test")
    assert folder.folder.visible and folder.tape_line.visible
    send(folder.end_a, (10, 5))
    send(folder.end_b, (13, 9))
    assert "5 spacings = 5 m" in folder.tape.content
    send(folder.end_b, (100, 9))  # outside the 60-column lattice
    assert "refused" in folder.message.content
    assert tuple(folder.end_b.value) == (13, 9)  # every page shows the end in use again
    watch = Stopwatch()
    watch.observe(1.0, 10.0)  # not running: nothing counted
    watch.start()
    for simulated, wall in ((2.0, 11.0), (2.5, 12.0), (4.0, 14.0)):
        watch.observe(simulated, wall)
    watch.stop()
    watch.observe(9.0, 20.0)
    assert (watch.simulated, watch.wall) == (2.0, 3.0)
    assert "0.67 s simulated per s" in watch.describe()


def test_the_folders_follow_sources_and_barriers_changed_elsewhere(web_app):
    web_app.replace_scene(small_double_slit(), source="test")
    source = web_app.runner.simulation.model.sources[0]
    changed = sim.model.forcing.Driver.create({**source.as_table(), "frequency": 0.21})
    web_app.runner.post(lambda simulation: simulation.set_parameters(
        sources=[changed], barriers=[{"column": 30, "openings": [[18, 22]]}])).result(timeout=30)
    model = web_app.runner.simulation.model
    frame = Frame(0, 0.0, "verlet", 0.01, model, np.array(model.rest_positions),
                  web_app.runner.simulation.energy())
    web_app.panel.sources.update(frame, 0.0)
    web_app.panel.barrier.update(frame, 0.0)
    assert web_app.panel.sources.frequency.value == 0.21
    assert (web_app.panel.barrier.slits.value, web_app.panel.barrier.width.value) == ("one", 5)
