"""The page's plots read well: their ticks differ, keep their signs and units, their ranges fit
the data; a reset empties the energy and probe plots at once."""

from __future__ import annotations

import numpy as np
import pytest

from app.web.widgets import axis_range
from tests.helpers import wait_for
from tests.test_web_safety import press, settle


def tick_labels(low: float, high: float) -> list[str]:
    """Five ticks across a range as the page's plots print them (uPlot: at most three
    decimals)."""
    return [f"{tick:.3f}".rstrip("0").rstrip(".") for tick in np.linspace(low, high, 5)]


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
