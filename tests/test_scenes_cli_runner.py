"""Scene files, the headless command line and the runner's command handling."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import sim
from app import cli
from app.cli.arguments import parse_overrides
from sim.runtime.runner import Runner


def test_scene_file_round_trip_keeps_masses_displacements_and_velocities(tmp_path):
    scene = sim.scenes.build("ionic", nx=6, ny=4, damping=0.3, gravity=(0.0, -1.0), linear=True)
    rng = np.random.default_rng(2)
    velocities = 0.1 * rng.standard_normal(scene.initial_velocities.shape)
    scene = sim.Scene(
        name="mine", model=scene.model, description="a test", integrator="verlet", dt=0.02,
        initial_positions=scene.initial_positions, initial_velocities=velocities,
    )
    path = sim.scenes.scene_files.save(scene, tmp_path / "mine.toml")
    loaded = sim.scenes.scene_files.load(path)
    assert loaded.name == "mine" and loaded.integrator == "verlet" and loaded.dt == 0.02
    np.testing.assert_array_equal(loaded.model.masses, scene.model.masses)
    np.testing.assert_array_equal(loaded.initial_positions, scene.initial_positions)
    np.testing.assert_array_equal(loaded.initial_velocities, velocities)
    for key, value in scene.model.parameters().items():
        assert getattr(loaded.model, key) == value, key


def test_a_hand_written_scene_file_loads(tmp_path):
    path = tmp_path / "hand.toml"
    path.write_text(
        'name = "by hand"\nintegrator = "rk4"\ndt = 0.01\n[model]\nnx = 3\nny = 1\n'
        "stiffness = 10.0\nmass = 2.0\n[initial]\ndisplacements = [[1, 0.2, 0.0]]\n"
    )
    scene = sim.scenes.scene_files.load(path)
    simulation = sim.Simulation(scene)
    assert simulation.positions[1, 0] == pytest.approx(scene.model.rest_positions[1, 0] + 0.2)
    simulation.step(10)
    assert np.isfinite(simulation.positions).all()


@pytest.mark.parametrize(
    "text, message",
    [
        ("[model\nnx = 3", "not valid TOML"),
        ("name = 'x'", "no \\[model\\] table"),
        ("[model]\nnx = 3\nmass = -1.0", "mass must be positive"),
        ("[model]\nnx = 3\nwobble = 2", "unknown \\[model\\] key"),
        ("[model]\nnx = 3\nmass = 'arrays:masses'\n[arrays]\nfile = 'missing.npz'", "array file"),
        ("dt = -1\n[model]\nnx = 2", "dt"),
        ("[model]\nnx = 'five'", "nx must be a whole number"),
        ("[model]\nnx = 2\ngravity = 'down'", "gravity must be"),
        ("format = 99\n[model]\nnx = 2", "format"),
        ("[model]\nnx = 2\n[initial]\ndisplacements = [['a', 0.1, 0.0]]", "bad.toml"),
    ],
)
def test_bad_scene_files_get_clear_errors(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(sim.SceneError, match=message):
        sim.scenes.scene_files.load(path)


def test_missing_or_binary_scene_file_is_a_clear_error(tmp_path):
    with pytest.raises(sim.SceneError, match="cannot read scene file"):
        sim.scenes.scene_files.load(tmp_path / "nowhere.toml")
    binary = tmp_path / "binary.toml"
    binary.write_bytes(bytes(range(256)))
    with pytest.raises(sim.SceneError, match="not a text"):
        sim.scenes.scene_files.load(binary)


# --- command line ------------------------------------------------------------------------------


def test_run_prints_an_energy_summary_as_json(capsys):
    status = cli.main(["run", "chain", "--integrator", "verlet", "--dt", "0.01", "--steps", "300",
                       "--json", "--quiet"])
    assert status == 0
    output = capsys.readouterr().out
    summary = json.loads(output[output.index("{"):])
    assert summary["steps"] == 300 and summary["integrator"] == "verlet"
    start, end = summary["energy_start"]["total"], summary["energy_end"]["total"]
    assert end == pytest.approx(start, rel=0.02)  # Verlet conserves energy well at this step


def test_run_reports_a_blow_up_and_exits_nonzero(capsys):
    status = cli.main(["run", "grid", "--integrator", "rk4", "--dt", "0.5", "--steps", "2000",
                       "--quiet"])
    assert status == 3
    assert "blew up" in capsys.readouterr().err


def test_bad_overrides_exit_with_a_clear_message(capsys):
    assert cli.main(["run", "grid", "--set", "mass=-2", "--quiet"]) == 2
    assert "mass must be positive" in capsys.readouterr().err
    assert cli.main(["run", "nosuchscene", "--quiet"]) == 2


def test_scenes_lists_every_preset(capsys):
    assert cli.main(["scenes"]) == 0
    output = capsys.readouterr().out
    for name in sim.scenes.names():
        assert name in output


def test_override_values_are_parsed():
    assert parse_overrides(["nx=40", "gravity=0,-9.81", "linear=true", "damping=0.5"]) == {
        "nx": 40, "gravity": (0.0, -9.81), "linear": True, "damping": 0.5,
    }


# --- runner -------------------------------------------------------------------------------------


def test_runner_publishes_frames_and_applies_commands_between_steps():
    runner = Runner(sim.Simulation(sim.scenes.build("grid")))
    frames = []
    runner.subscribe(frames.append, strains=True)
    # a change of a value, not of a term: the same compiled kernel runs on
    runner.post(lambda simulation: simulation.set_parameters(stiffness=40.0))
    runner.advance(10, every=5)
    assert [frame.step for frame in frames] == [5, 10]
    assert frames[-1].model.stiffness == 40.0
    assert frames[-1].strains.shape == (runner.simulation.model.n_springs,)
    assert frames[-1].velocities is None  # nobody asked for them


def test_runner_thread_pauses_on_blow_up_and_keeps_a_finite_state():
    simulation = sim.Simulation(sim.scenes.build("grid"), integrator="rk4", dt=0.5)
    runner = Runner(simulation, steps_per_frame=50, max_fps=1000)
    errors = []
    runner.subscribe(lambda frame: frame.error and errors.append(frame.error))
    runner.start()
    try:
        runner.play()
        for _ in range(200):
            if errors:
                break
            import time

            time.sleep(0.02)
    finally:
        runner.stop()
    assert errors and "blew up" in errors[0]
    assert not runner.playing
    assert np.isfinite(simulation.positions).all()
    assert math.isfinite(simulation.energy().total)


def test_a_failing_command_reports_its_error_without_stopping_anything():
    runner = Runner(sim.Simulation(sim.scenes.build("single")))
    future = runner.post(lambda simulation: simulation.set_parameters(stiffness=-1))
    with pytest.raises(sim.ModelError):
        future.result(timeout=1)
    runner.advance(3)
    assert runner.simulation.step_count == 3


def test_serve_refuses_a_bad_host_or_port_instead_of_hanging(capsys):
    assert cli.main(["serve", "grid", "--host", "256.1.1.1"]) == 2
    assert "not an address of this machine" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["serve", "grid", "--port", "99999"])
    assert exit_info.value.code == 2
    assert "between 0 and 65535" in capsys.readouterr().err
