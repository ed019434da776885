"""The page's plots read well: their ticks differ, keep their signs and units, their ranges fit
the data and their axes are wide enough for their labels; a reset empties the energy, error and
probe plots at once; a refused number is said in the page; a reset takes the run's status notes
away."""

from __future__ import annotations

import numpy as np
import pytest
import viser

from app.web.widgets import RATIO_UNITS, PlotAxis, axis_range, axis_size
from sim.runtime.runner import Frame
from tests.helpers import wait_for
from tests.test_web_safety import press, send, settle


def tick_labels(low: float, high: float) -> list[str]:
    """Five ticks across a range as the page's plots print them (uPlot: at most three
    decimals)."""
    return [f"{tick:.3f}".rstrip("0").rstrip(".") for tick in np.linspace(low, high, 5)]


@pytest.mark.parametrize("errors, shown", [
    (-1.1e-4 - 1e-5 * np.arange(100) / 100, "ppm"),  # -0.011 % to -0.012 %: negative, in ppm
    (2.12e-3 + 1e-6 * np.sin(np.arange(100)), "ppm"),  # a nearly flat 0.212 %
    (np.linspace(0.0, 0.36, 50), "%"),  # 0 to 36 %
    (np.array([0.0, 3e-9]), "ppb"),
])
def test_an_error_plot_takes_the_unit_that_keeps_its_ticks_distinct_and_signed(errors, shown):
    factor, unit, (low, high) = axis_range(errors, "", RATIO_UNITS)
    assert unit == shown
    scaled = errors / factor
    assert low <= scaled.min() and scaled.max() <= high
    labels = tick_labels(low, high)
    assert len(set(labels)) == len(labels), labels
    if errors.max() < 0:
        assert all(text.startswith("-") for text in labels[:-1]), labels


def test_the_value_axis_is_wide_enough_for_its_longest_label_and_moves_seldom():
    # "-2115.5" and "-0.012" need more than uPlot's 50 px at about 7 px a character
    assert axis_size(-2120.0, -2110.0) >= 7 * len("-2,117.5")
    assert axis_size(0.0, 1.0) >= 50
    axis = PlotAxis("energy", "J", "t (s)")
    factor, layout = axis.layout(np.array([1.0, 2.0]))
    assert axis.layout(np.array([1.2, 1.9]), layout)[1] == layout  # still fits: kept
    assert axis.layout(np.array([1.0, 9.0]), layout)[1] != layout  # leaves it: a new range
    assert axis.layout(np.array([1.0, 1.001]), layout)[1] != layout  # far too wide: narrower


@pytest.mark.parametrize("values, unit, shown", [
    (0.598 + 1e-7 * np.sin(np.arange(600)), "J", "mJ"),  # the total energy: nearly flat
    (3e-5 * np.sin(np.arange(600) / 10), "m", "µm"),  # a probe's displacement
    (-2.5e-3 - 1e-4 * np.arange(600) / 600, "J", "mJ"),  # negative only
    (np.array([0.0, 4e-9]), "m", "nm"),
])
def test_ticks_differ_keep_their_sign_and_the_range_fits(values, unit, shown):
    factor, label, (low, high) = axis_range(values, unit)
    assert label == shown
    scaled = values / factor
    assert low <= scaled.min() and scaled.max() <= high
    assert 1.0 <= np.abs(scaled).max() < 1000.0
    labels = tick_labels(low, high)
    assert len(set(labels)) == len(labels), labels
    if values.max() < 0:
        assert all(text.startswith("-") for text in labels[:-1]), labels
    # the range is about the data's size, not the scale of something else
    assert high - low <= 2.2 * max(scaled.max() - scaled.min(), 0.01 * np.abs(scaled).max()) + 1


def test_a_reset_empties_the_probe_and_energy_plots_at_once(web_app):
    probes = web_app.panel.probes
    web_app.set_selection(np.array([3]))
    press(probes.probe_button)
    web_app.runner.play()
    assert wait_for(lambda: probes.time_plot.handle.data[0].size > 8, timeout=60)
    assert wait_for(lambda: web_app.panel.energy.plot.data[0].size > 8, timeout=60)
    web_app.runner.pause()
    settle(web_app)
    press(web_app.panel.run.reset_button)
    assert wait_for(lambda: probes.time_plot.handle.data[0].size == 0, timeout=10)
    assert probes.spectrum_plot.handle.data[0].size == 0  # cleared with (just before) the time plot
    assert wait_for(lambda: web_app.panel.energy.plot.data[0].size <= 1, timeout=10)


def test_a_reset_empties_the_error_plot_and_takes_the_run_notes_away(web_app):
    accuracy, run = web_app.panel.accuracy, web_app.panel.run
    web_app.runner.play()
    assert wait_for(lambda: accuracy.plot.data[0].size > 8, timeout=60)
    web_app.runner.pause()
    settle(web_app)
    duration = web_app.runner.simulation.scene.duration
    model = web_app.runner.simulation.model
    energy = web_app.runner.simulation.energy()
    positions = np.array(model.rest_positions)
    run.update(Frame(10, duration, "rk4", 0.01, model, positions, energy, playing=True), now=0.0)
    assert run.end_html.visible and "duration" in run.end_html.content
    press(run.reset_button)
    assert wait_for(lambda: accuracy.plot.data[0].size == 0, timeout=10)
    assert wait_for(lambda: not run.end_html.visible, timeout=10)


def test_a_refused_number_is_said_in_red_and_no_number_box_has_limits_the_page_would_drop(
        web_app):
    integrator = web_app.panel.integrator
    send(integrator.dt, 50.0)
    settle(web_app)
    assert web_app.runner.simulation.dt == 0.01
    assert "#c0392b" in integrator.message.content and "dt" in integrator.message.content
    # a box with a browser min/max would have its value dropped by the gate before any folder
    # could say why: every number box leaves its limits to the folder's own check
    boxes = [handle for handle in web_app.server.gui._gui_input_handle_from_uuid.values()
             if isinstance(handle, viser.GuiNumberHandle)]
    assert len(boxes) >= 8
    assert all(box._impl.props.min is None and box._impl.props.max is None for box in boxes), [
        box.label for box in boxes if box._impl.props.min is not None
        or box._impl.props.max is not None]


def test_the_accuracy_folders_words_use_the_plots_unit():
    from app.web.folders.accuracy import error_words
    from app.web.widgets import History

    history = History(10)
    for time, error in ((0.0, 0.0), (1.0, 3e-5), (2.0, 1.2e-5)):
        history.add(time, (error,))
    assert error_words(1.2e-5, history) == "+12 ppm"
    history.add(3.0, (0.02,))
    assert error_words(0.02, history) == "+2.000%"
