"""One function, every face: `choose`, `accuracy`, `scenes --measure` and the page's Accuracy
folder (*Choose for me*, then *Apply*) give the same verified setting for the same scene and
tolerance, and the page then runs exactly that setting and shows its dt.

The scene is the `chain` preset (5 particles, full springs: the reference is RK4 converged), so
every face takes seconds."""

from __future__ import annotations

import json
import re

import pytest

import sim
from app.cli import main
from app.study.choose import choose
from app.web.app import WebApp
from tests.helpers import free_port, wait_for
from tests.test_web_safety import press, send, settle

SCENE = "chain"
TOLERANCE = 0.01


@pytest.fixture(scope="module")
def answer() -> tuple[str, float]:
    choice = choose(sim.scenes.build(SCENE), TOLERANCE)
    assert choice.answer is not None and choice.answer.error <= TOLERANCE
    return choice.answer.integrator, choice.answer.dt


def test_choose_accuracy_and_scenes_give_the_same_answer(answer, capsys) -> None:
    assert main(["choose", SCENE, "--tolerance", str(TOLERANCE), "--json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["integrator"], data["dt"]) == answer
    assert main(["accuracy", SCENE, "--tolerance", str(TOLERANCE), "--dts", "0.02", "0.01",
                 "--until", "1", "--precisions", "float64", "--json", "--quiet"]) == 0
    recommendation = json.loads(capsys.readouterr().out)["recommendation"]
    assert (recommendation["integrator"], recommendation["dt"]) == answer
    assert main(["scenes", SCENE, "--measure", "--tolerance", str(TOLERANCE)]) == 0
    found = re.search(r"choose: --integrator ([\w-]+) --dt (\S+)", capsys.readouterr().out)
    assert found is not None and found[1] == answer[0]
    assert float(found[2]) == pytest.approx(answer[1], rel=1e-6)  # six figures, not 17
    assert len(found[2].replace(".", "").lstrip("0")) <= 6


def test_the_page_applies_exactly_the_verified_setting_and_shows_its_dt(answer, tmp_path) -> None:
    app = WebApp(sim.Simulation(sim.scenes.build(SCENE)), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings")
    app.start()
    try:
        accuracy = app.panel.accuracy
        send(accuracy.tolerance, 100 * TOLERANCE)  # %
        press(accuracy.choose_button)
        assert "verified" in accuracy.message.content, accuracy.message.content
        assert app.runner.simulation.dt == sim.scenes.build(SCENE).dt  # nothing applied yet
        press(accuracy.apply_button)
        settle(app)
        simulation = app.runner.simulation
        assert (simulation.integrator, simulation.dt) == answer
        app.runner.play()
        assert wait_for(lambda: app.panel.integrator.dt.value == answer[1])
        assert app.panel.integrator.method.value == answer[0]
    finally:
        app.stop()
