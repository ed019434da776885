"""Kernels prepared before a run needs them: the page says so and keeps answering meanwhile.

A slow compile is stood in for by a rehearsal that waits on an event, so these tests compile
nothing new."""

from __future__ import annotations

import os
import re
import threading

import numpy as np
import pytest

import sim
from app import cli
from app.web.app import WebApp, runner_pacing
from app.web.control import LatticeRunner
from sim.runtime import warming
from tests.helpers import free_port, wait_for
from tests.test_web_safety import press, settle


def test_step_shapes_name_how_a_run_calls_the_stepper():
    assert warming.step_shapes(1, 64) == "one"
    assert warming.step_shapes(2, 64) == "many"
    assert warming.step_shapes(64, 64) == "many"
    assert warming.step_shapes(65, 64) == "both"
    assert warming.step_shapes(130, 64) == "many"


def test_kernel_keys_tell_apart_what_changes_a_kernel_and_not_what_only_changes_numbers():
    grid = sim.Simulation(sim.scenes.build("grid"))
    stiffer = sim.Simulation(sim.scenes.build("grid", stiffness=50.0, dt=0.005))
    assert warming.kernel_key(grid, 2) == warming.kernel_key(stiffer, 2)
    others = [
        sim.scenes.build("grid", gravity=9.81), sim.scenes.build("grid", damping=0.5),
        sim.scenes.build("grid", drag=0.1), sim.scenes.build("ionic"),
        sim.scenes.build("grid", integrator="verlet"), sim.scenes.build("grid", dim=3),
        sim.scenes.build("grid", precision="float32"),
    ]
    keys = {warming.kernel_key(sim.Simulation(scene), 2) for scene in others}
    assert len(keys) == len(others) and warming.kernel_key(grid, 2) not in keys
    assert warming.kernel_key(grid, 1) != warming.kernel_key(grid, 2)


def test_the_page_says_it_is_preparing_and_the_controls_answer_meanwhile(tmp_path):
    asked, release = threading.Event(), threading.Event()

    def slow_compile(simulation, steps):  # stands in for numba compiling the scene's kernels
        asked.set()
        release.wait(60)

    preparer = warming.KernelPreparer(rehearsal=slow_compile)
    app = WebApp(sim.Simulation(sim.scenes.build("grid", nx=11, ny=7)), port=free_port(),
                 scenes_dir=tmp_path / "scenes", recordings_dir=tmp_path / "recordings",
                 preparer=preparer)
    app.start()
    try:
        assert asked.wait(10)
        run = app.panel.run
        assert wait_for(lambda: "Preparing the kernel for this scene" in run.status.content, 10)
        assert app.view.last_positions is not None  # the lattice is drawn meanwhile
        press(run.play_button)
        assert wait_for(lambda: "it runs when ready" in run.status.content, 5)
        assert run.play_button.label == "Pause"
        # the seconds count up (the stand-in compiles nothing, so no "first time" is claimed)
        shown = re.compile(r"Preparing the kernel for this scene: (\d+) s")
        first = int(shown.search(run.status.content).group(1))
        assert wait_for(lambda: int(shown.search(run.status.content).group(1)) > first, 10)
        # every control answers while the compile goes on, and the run waits
        app.control.set_dt(0.005).result(timeout=2)
        app.control.set_gravity(True).result(timeout=2)
        assert app.runner.simulation.dt == 0.005 and app.runner.simulation.model.has_gravity
        press(run.play_button)
        settle(app)
        assert not app.runner.playing and run.play_button.label == "Play"
        assert wait_for(lambda: "paused" in run.status.content, 5)
        assert app.runner.simulation.step_count == 0
    finally:
        app.stop()
        release.set()


def test_a_prepared_runner_compiles_nothing_in_its_own_thread():
    """The rehearsal compiles exactly what the run calls: once it is done, stepping, a single
    step and the frames neither compile nor read a kernel from the cache in the runner's
    thread."""
    runner = LatticeRunner(sim.Simulation(sim.scenes.build("grid", nx=9, ny=6)),
                           steps_per_frame=2, preparer=warming.KernelPreparer())
    frames, recorded = [], []
    runner.subscribe(frames.append, preparing=True)
    runner.subscribe(recorded.append)  # a recorder: only frames of a state that advanced
    runner.start()
    try:
        runner.play()
        assert wait_for(lambda: runner.simulation.step_count > 20, 300)
        runner.pause()
        assert runner.single_step().result(timeout=300) is True
        assert any(frame.preparing is not None for frame in frames)
        assert frames[-1].preparing is None
        assert recorded and all(frame.preparing is None for frame in recorded)
        assert not warming.loaded_in_thread(runner._thread.ident)  # no compile, no cache read
    finally:
        runner.stop()


def test_warm_help_names_what_it_does(capsys):
    with pytest.raises(SystemExit) as stopped:
        cli.main(["warm", "--help"])
    assert stopped.value.code == 0
    text = capsys.readouterr().out
    assert "progress bar" in text and "--toggles" in text and "make run" in text


def test_warm_compiles_what_the_page_then_runs(capsys):
    assert cli.main(["warm", "single"]) == 0
    assert "1 kernel combinations for 1 preset(s)" in capsys.readouterr().out
    simulation = sim.Simulation(sim.scenes.build("single"))
    before = warming.compiles_started()
    simulation.energy()
    simulation.step(runner_pacing(simulation)[0])
    simulation.energy_balance_error()
    assert warming.compiles_started() == before


def test_warm_refuses_an_unknown_preset(capsys):
    assert cli.main(["warm", "no-such-scene"]) == 2
    assert "unknown preset 'no-such-scene'" in capsys.readouterr().err


def test_a_runner_that_moves_on_withdraws_the_preparations_it_no_longer_needs():
    gate, done = threading.Event(), []

    def rehearsal(simulation, steps):
        gate.wait(30)
        done.append(simulation)

    preparer = warming.KernelPreparer(rehearsal=rehearsal)
    assert preparer.prepare("grid", "grid", 2, owner="page") is not None
    assert wait_for(lambda: preparer._current is not None, 10)  # the first one has started
    preparer.prepare("grid+gravity", "grid+gravity", 2, owner="page")
    preparer.prepare("grid+damping", "grid+damping", 2, owner="page")  # gravity is withdrawn
    preparer.prepare("chain", "chain", 2, owner="another page")
    gate.set()
    assert wait_for(lambda: preparer.ready("grid+damping") and preparer.ready("chain"), 10)
    assert sorted(done) == ["chain", "grid", "grid+damping"]
    assert not preparer.ready("grid+gravity")


def test_the_servers_background_warming_runs_at_the_lowest_priority_and_stops(monkeypatch):
    from app.cli.warm import NO_WARM_VARIABLE, start_background, stop_background

    monkeypatch.setenv(NO_WARM_VARIABLE, "1")
    assert start_background("grid") is None  # as in the test suite
    monkeypatch.delenv(NO_WARM_VARIABLE)
    process = start_background("grid")
    try:
        niceness = []
        assert wait_for(lambda: niceness.append(os.getpriority(os.PRIO_PROCESS, process.pid))
                        or niceness[-1] == 19, 10)
    finally:
        stop_background(process)
    assert process.poll() is not None


def test_the_warmed_toggles_include_the_other_spring_law():
    from app.cli.warm import toggles

    labels = [combination.label for combination in toggles("grid")]
    assert labels == ["grid (gravity on)", "grid (damping on)", "grid (gravity on, damping on)",
                      "grid (linear on)"]


def test_warm_uses_a_process_per_core_as_far_as_the_memory_goes(monkeypatch):
    import psutil

    from app.cli import warm

    class Memory:
        available = 100e9

    monkeypatch.setattr(psutil, "virtual_memory", lambda: Memory)
    monkeypatch.setattr(os, "sched_getaffinity", lambda _: {0, 1, 2, 3}, raising=False)
    assert warm.worker_count(10) == 4
    assert warm.worker_count(3) == 3
    Memory.available = 1.5 * warm.WORKER_MEMORY
    assert warm.worker_count(10) == 1


@pytest.mark.slow  # compiles the single preset's toggles in two spawned processes
def test_warm_compiles_side_by_side_and_the_page_then_reads_them(capsys):
    from app.cli import warm

    if warm.worker_count(4) < 2:
        pytest.skip("one core or little memory: warm runs in one process")
    assert cli.main(["warm", "single", "--toggles"]) == 0
    out = capsys.readouterr().out
    assert "on 2 processes" in out or "processes:" in out
    for changes in ({}, {"gravity": 9.81}, {"damping": 0.5}, {"linear": True}):
        simulation = sim.Simulation(sim.scenes.build("single", **changes))
        before = warming.compiles_started()
        simulation.step(runner_pacing(simulation)[0])
        assert warming.compiles_started() == before, changes


@pytest.mark.slow  # spawns two worker processes
def test_warm_says_which_combination_failed_and_goes_on(capsys):
    from app.cli import warm

    class Bar:
        def set_postfix_str(self, text: str) -> None:
            pass

    unique = [warm.Combination("no-such-preset"), warm.Combination("single")]
    results = {label: did for label, _, did in warm._rehearse_all(unique, 2, Bar())}
    assert results["no-such-preset"] is None and results["single"] is not None
    assert "failed    no-such-preset" in capsys.readouterr().err


def test_the_step_loop_can_be_compiled_apart_from_verlets_first_force_pass(monkeypatch):
    """``assume_forces_of`` lets a second child compile Verlet's step loop while the first
    compiles its force pass (``warming.rehearse_loop``): the next advance starts with the loop."""
    from sim.integrators import steppers

    simulation = sim.Simulation(sim.scenes.build("grid"), integrator="verlet")
    stepper = simulation._integrator
    calls = []
    original = steppers.stepping.accelerations
    monkeypatch.setattr(steppers.stepping, "accelerations",
                        lambda *arguments: calls.append(1) or original(*arguments))
    stepper.advance(simulation.state, 3, simulation.dt)
    before = len(calls)
    simulation.state.revision += 1  # a change from outside: the forces are computed first
    stepper.advance(simulation.state, 3, simulation.dt)
    first_pass = len(calls) - before
    assert stepper.assume_forces_of(simulation.state)
    simulation.state.revision += 1  # a particle placed before the loop (a driver) changes none
    stepper.invalidate()
    before = len(calls)
    stepper.advance(simulation.state, 3, simulation.dt)
    assert first_pass >= 1 and len(calls) - before == first_pass - 1
    simulation.state.revision += 1  # only the next advance: then the forces are computed again
    before = len(calls)
    stepper.advance(simulation.state, 3, simulation.dt)
    assert len(calls) - before == first_pass
    rk4 = sim.Simulation(sim.scenes.build("grid"), integrator="rk4")
    assert not rk4._integrator.assume_forces_of(rk4.state)
    assert not rk4._integrator.first_forces(rk4.state)
    warming.rehearse_loop(sim.scenes.build("grid"), "verlet", 0.01, "float64", 1, 65)


@pytest.mark.parametrize("integrator, name", [("verlet", "grid"), ("verlet", "catenary"),
                                               ("verlet", "bandgap"), ("yoshida4", "grid")])
def test_the_first_force_pass_alone_leaves_the_run_as_it_was(integrator, name):
    """``first_forces`` (the other child's half of a rehearsal) computes the forces the next
    advance starts from: a run after it is the run without it, bit for bit (damped, driven and
    with an absorbing layer too)."""
    scene = sim.scenes.build(name)
    plain = sim.Simulation(scene, integrator=integrator)
    prepared = sim.Simulation(scene, integrator=integrator)
    assert prepared._integrator.first_forces(prepared.state)
    plain.step(70)
    prepared.step(70)
    assert np.array_equal(plain.state.positions, prepared.state.positions)
    assert np.array_equal(plain.state.velocities, prepared.state.velocities)


def test_a_stopped_server_leaves_no_compiling_child_behind(tmp_path):
    """A server stopped while a child process compiles its kernels ends that child too (on
    Linux), instead of leaving it compiling at full speed on the teacher's laptop."""
    import signal
    import subprocess
    import sys

    import psutil

    if not sys.platform.startswith("linux"):
        pytest.skip("the child ends with its parent on Linux")
    cache = str(tmp_path / "numba")
    env = {**os.environ, "OSCILLATORS_NO_WARM": "1", "NUMBA_CACHE_DIR": cache}

    def compiling() -> list:
        found = []
        for process in psutil.process_iter(["cmdline"]):
            try:
                if "sim.runtime.warming" in " ".join(process.info["cmdline"] or ()) and \
                        process.environ().get("NUMBA_CACHE_DIR") == cache:
                    found.append(process)
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                pass
        return found

    server = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "double-slit", "--port",
                               str(free_port())], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    try:
        for line in server.stdout:  # serving, its own scene's kernels being prepared
            if "serving on" in line:
                break
        assert wait_for(lambda: any(sum(process.cpu_times()[:2]) > 1.0  # compiling by now
                                    for process in compiling()), timeout=60)
    finally:
        server.send_signal(signal.SIGTERM)
        server.wait(30)
    assert wait_for(lambda: not compiling(), timeout=5), compiling()


@pytest.mark.parametrize("fails", ["none", "beside", "main"])
def test_the_two_compiling_children_wait_for_each_other_and_for_no_dead_one(tmp_path, fails):
    """The first child goes on once the other has done its first part (the absorbing layer's
    action) and steps once the other has ended; either side ending early, however it ends,
    releases the other (no child waits for ever)."""
    from sim.runtime.children import call_in_child
    from tests import child_calls

    log = tmp_path / "order.txt"

    def call() -> None:
        call_in_child(child_calls.main_side, str(log), fails == "main",
                      beside=[(child_calls.beside_side, (str(log), fails == "beside"))],
                      beside_done="loop_done", beside_ready="layer_ready", timeout=60)

    if fails == "main":
        with pytest.raises(RuntimeError, match="exited with 5"):
            call()
    else:
        call()
    order = log.read_text().splitlines()
    expected = {"none": ["beside: first part", "main: after the other's first part",
                         "beside: the rest", "main: after the other ended"],
                "beside": ["main: after the other's first part", "main: after the other ended"],
                "main": ["beside: first part", "beside: the rest"]}[fails]
    assert order == expected


def test_a_child_whose_starter_is_gone_ends_at_once():
    """A compiling child asks to end with the process that started it; if that process is not
    its parent any more when it asks (it ended in between), the child ends at once."""
    import subprocess
    import sys

    from sim.runtime.children import PARENT_VARIABLE, ROOT

    if not sys.platform.startswith("linux"):
        pytest.skip("the child ends with its parent on Linux")
    code = "from sim.runtime.children import end_with_parent; end_with_parent(); print('went on')"

    def child(parent: int) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              cwd=ROOT, env={**os.environ, PARENT_VARIABLE: str(parent)},
                              timeout=60)

    gone = child(2**22 + 1)  # above Linux's largest process id: no process's
    assert gone.returncode == 1 and gone.stdout == ""
    alive = child(os.getpid())
    assert alive.returncode == 0 and alive.stdout.strip() == "went on"
