"""A subscriber that raises is detached and reported; the runner and the others go on.

Also: ``oscillators serve`` on every interface warns what the network can do, and stops cleanly
on SIGTERM.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import sim
from sim.runtime.runner import Runner
from tests.helpers import free_port, wait_for


def test_a_raising_subscriber_is_detached_and_the_others_keep_their_frames():
    runner = Runner(sim.Simulation(sim.scenes.build("chain")))
    received: list[int] = []
    errors: list[BaseException] = []
    calls = []

    def broken(frame: sim.runtime.runner.Frame) -> None:
        calls.append(frame.step)
        raise RuntimeError("plot exploded")

    runner.subscribe(broken, on_error=errors.append)
    runner.subscribe(lambda frame: received.append(frame.step))
    runner.advance(10, every=2)
    assert calls == [2]  # called once, then detached
    assert [str(error) for error in errors] == ["plot exploded"]
    assert received == [2, 4, 6, 8, 10]
    assert len(runner.subscriber_errors) == 1 and "plot exploded" in runner.subscriber_errors[0]


def test_a_failing_error_handler_does_not_stop_the_background_loop():
    runner = Runner(sim.Simulation(sim.scenes.build("grid")), max_fps=500)

    def broken(frame: sim.runtime.runner.Frame) -> None:
        raise OSError("disk full")

    def broken_handler(error: BaseException) -> None:
        raise ValueError("and the handler too")

    runner.subscribe(broken, on_error=broken_handler)
    runner.start()
    try:
        runner.play()
        assert wait_for(lambda: runner.simulation.step_count > 50)
        assert runner.playing and runner.error is None
    finally:
        runner.stop()


def test_before_step_hook_runs_before_every_step_and_after_the_last():
    runner = Runner(sim.Simulation(sim.scenes.build("chain")))
    seen: list[int] = []
    runner.before_step = lambda simulation: seen.append(simulation.step_count)
    assert runner.guarded_step(3)
    assert seen == [0, 1, 2, 3]
    assert runner.steps_taken == 3
    runner.before_step = None
    assert runner.guarded_step(4) and seen == [0, 1, 2, 3] and runner.steps_taken == 7


def test_serve_on_every_interface_warns_and_stops_on_sigterm():
    command = [sys.executable, "-m", "app.cli", "serve", "single", "--host", "0.0.0.0",
               "--port", str(free_port())]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.monotonic() + 60
        line = ""
        while time.monotonic() < deadline:
            line = process.stderr.readline()
            if "warning" in line or not line:
                break
        assert "anyone who can reach this machine" in line
        assert "change the simulation" in line and "recordings" in line
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=30) == 0
    finally:
        if process.poll() is None:
            process.kill()
