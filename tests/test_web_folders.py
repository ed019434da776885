"""The page's folders, without a browser: a failing folder stays contained, and the accuracy
folder's advice comes from the integrator registry.

Values "from a page" are sent the way viser delivers a browser's message (``send`` / ``press``
from ``tests.test_web_safety``).
"""

from __future__ import annotations

from typing import Any

import sim
from app.web.folders.accuracy import explanation, has_time_step_error
from tests.helpers import wait_for
from tests.test_web_safety import press, send, settle


def test_a_failing_folder_is_reported_and_the_rest_of_the_page_goes_on(web_app, monkeypatch):
    def broken(*_: Any) -> None:
        raise RuntimeError("a folder's bug")

    panel = web_app.panel
    monkeypatch.setattr(panel.spectrum, "update", broken)
    monkeypatch.setattr(panel.drive, "show_scene", broken)
    web_app.runner.play()
    assert wait_for(lambda: "spectrum" in panel.failures.content)
    assert "a folder&#x27;s bug" in panel.failures.content and panel.failures.visible
    status = panel.run.status.content
    assert wait_for(lambda: panel.run.status.content != status)  # the other folders follow
    send(panel.scene.preset, "chain")
    press(panel.scene.build_button)
    settle(web_app)
    assert web_app.runner.simulation.scene.name == "chain"
    assert "chain" in panel.scene.info.content and "built chain" in panel.scene.message.content
    assert "drive" in panel.failures.content


def test_the_advice_on_energy_drift_comes_from_the_registry():
    linear = sim.scenes.build("chain", linear=True).model
    describe = sim.integrators.describe
    for name in sim.integrators.names(linear):
        if not has_time_step_error(name):
            continue
        text = explanation(name, 0.05, linear)
        why = describe(name).drift_explanation(0.05)
        assert text.startswith(why)
        remedy = text[len(why):]
        symplectic = [d.label for d in sim.integrators.descriptions() if d.symplectic]
        assert all((label in remedy) != describe(name).symplectic for label in symplectic)
        assert "exact normal-mode solution" in text  # linear springs: the exact solver applies
    nonlinear = sim.scenes.build("chain").model
    assert "exact" not in explanation("euler", 0.05, nonlinear)
    assert "damps" in explanation("rk4", -0.05, nonlinear)
    assert not has_time_step_error("exact") and has_time_step_error("verlet")
