"""Sweeps on Dask: the same independent runs give the same results serially, on a local cluster
and on a cluster started with dask's own command line (a scheduler and two worker processes on
127.0.0.1); a run whose worker dies is run again, and a run that keeps failing is reported by
name, never dropped."""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from app.study import accuracy, executor, stability
from sim.scenes import building as scenes

ROOT = Path(__file__).resolve().parents[1]
DASK = Path(sys.executable).with_name("dask")


def stability_sweep(runner) -> list:
    study = stability.stability_study(stability.default_cases(["grid-linear", "strong-drag"]),
                                      integrators=["verlet", "rk4"], steps=100, precision=0.05,
                                      executor=runner)
    return study.limits


def accuracy_sweep(runner) -> list:
    study = accuracy.accuracy_study(scenes.build("chain"), integrators=["verlet", "rk4"],
                                    dts=[0.02, 0.01], until=1.0, refine=False,
                                    precisions=("float64",), executor=runner)
    return study.runs


def assert_same_limits(limits, expected) -> None:
    assert [(limit.case, limit.integrator) for limit in limits] == \
        [(limit.case, limit.integrator) for limit in expected]
    for got, want in zip(limits, expected, strict=True):
        assert got.measured == pytest.approx(want.measured, rel=1e-9, abs=1e-12)
        assert got.trials == want.trials


def assert_same_runs(runs, expected) -> None:
    assert [(run.integrator, run.dt, run.steps) for run in runs] == \
        [(run.integrator, run.dt, run.steps) for run in expected]
    for got, want in zip(runs, expected, strict=True):
        assert got.error == pytest.approx(want.error, rel=1e-9, abs=1e-15)


@pytest.fixture(scope="module")
def serial_results():
    return stability_sweep(executor.serial()), accuracy_sweep(executor.serial())


def test_a_local_cluster_gives_the_serial_runs(serial_results):
    labels: list[str] = []
    with executor.executor_for(workers=2) as runner:
        assert runner.workers == 2
        limits = stability.stability_study(
            stability.default_cases(["grid-linear", "strong-drag"]), integrators=["verlet", "rk4"],
            steps=100, precision=0.05, executor=runner, progress=labels.append).limits
        runs = accuracy_sweep(runner)
    assert_same_limits(limits, serial_results[0])
    assert_same_runs(runs, serial_results[1])
    assert sorted(labels) == sorted(f"{case}: {name}" for case in ("grid-linear", "strong-drag")
                                    for name in ("verlet", "rk4"))


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@contextlib.contextmanager
def dask_cluster(workers: int = 2):
    """``dask scheduler`` and ``dask worker`` processes on 127.0.0.1 on free ports; yields the
    scheduler's address and stops them all."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    environment = {**os.environ, "PYTHONPATH": str(ROOT)}
    started = [subprocess.Popen(
        [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(port),
         "--dashboard-address", ":0", "--no-show"],
        env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        for _ in range(workers):
            started.append(subprocess.Popen(
                [str(DASK), "worker", address, "--nthreads", "1", "--host", "127.0.0.1",
                 "--dashboard-address", ":0", "--no-dashboard"],
                env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        yield address
    finally:
        for process in reversed(started):
            process.terminate()
        for process in reversed(started):
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()


@pytest.mark.slow
def test_a_cluster_started_with_dasks_command_line_gives_the_serial_runs(serial_results):
    with dask_cluster(2) as address:
        deadline = time.monotonic() + 60
        while True:  # the scheduler takes a moment to listen
            try:
                runner = executor.cluster(address, timeout=5)
                break
            except executor.ExecutorError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.5)
        try:
            runner.client.wait_for_workers(2, timeout=60)
            assert runner.workers == 2
            assert_same_limits(stability_sweep(runner), serial_results[0])
            assert_same_runs(accuracy_sweep(runner), serial_results[1])
        finally:
            runner.close()


def die_once(flag: str) -> int:
    """Kill the worker process the first time (a crash, not an exception); then return 7."""
    marker = Path(flag)
    if not marker.exists():
        marker.write_text("died")
        os._exit(1)
    return 7


def always_fails(item: int) -> int:
    if item == 2:
        raise RuntimeError("this run always fails")
    return item * item


@pytest.mark.slow
def test_a_dead_workers_run_is_retried_and_a_lost_run_is_reported(tmp_path):
    with executor.executor_for(workers=2) as runner:
        assert runner.map(die_once, [str(tmp_path / "flag")], ["fragile"]) == [7]
        assert (tmp_path / "flag").exists()
        with pytest.raises(executor.LostRunsError) as lost:
            runner.map(always_fails, [1, 2, 3], ["one", "two", "three"])
    assert list(lost.value.lost) == ["two"]
    assert "this run always fails" in lost.value.lost["two"]
    assert lost.value.results == [1, None, 9]
    with pytest.raises(RuntimeError, match="always fails"):
        executor.serial().map(always_fails, [1, 2])  # in this process: the run's own error


def test_bad_cluster_options_are_refused_in_one_line():
    with pytest.raises(executor.ExecutorError, match="tcp://HOST:PORT"):
        executor.cluster("localhost")
    with pytest.raises(executor.ExecutorError, match="whole number"):
        executor.local_cluster(0)
    result = subprocess.run(
        [sys.executable, "-m", "app.cli", "stability", "--cases", "grid-linear",
         "--scheduler", "nowhere"], capture_output=True, text=True, cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "tcp://HOST:PORT" in result.stderr
