"""The two float64 1/sqrt variants compute the same forces, and the per-host choice answers for
each loop family (``sim.loops.host_tuning``)."""

from __future__ import annotations

import numpy as np
import pytest

import sim
from sim.forces.springs import spring_force
from sim.loops import host_tuning


def test_the_estimate_and_the_division_give_the_same_forces():
    """The spring law every loop uses, on random stretched, compressed and tilted springs."""
    model = sim.scenes.build("grid", nx=9, ny=6).model.replace(rest_length=0.6)
    generator = np.random.default_rng(5)
    a = model.spacing
    zero = np.float64(0.0)
    forces = {None: [], True: []}
    for _ in range(200):
        first = tuple(np.float64(v) for v in (*generator.normal(0.0, 0.3 * a, 3), 0.0, 0.0, 0.0))
        offset = generator.normal(0.0, 0.3 * a, 3) + (a, 0.0, 0.0)
        second = tuple(np.float64(v) for v in (*(np.array(first[:3]) + offset), zero, zero, zero))
        for estimate in forces:
            parameters = model.kernel_parameters.as_type(np.float64, estimate)
            forces[estimate].append(spring_force(first, second, 0, None, parameters, None)[:3])
    divided, estimated = np.array(forces[None]), np.array(forces[True])
    scale = np.abs(divided).max()
    assert scale > 0
    np.testing.assert_allclose(estimated, divided, rtol=0, atol=1e-13 * scale)


def test_the_choice_is_forced_by_the_environment_and_loops_are_named(monkeypatch):
    host_tuning.inverse_sqrt_estimate.cache_clear()
    try:
        monkeypatch.setenv("OSCILLATORS_INVERSE_SQRT", "estimate")
        assert all(host_tuning.inverse_sqrt_estimate(loop) is True for loop in host_tuning.LOOPS)
        host_tuning.inverse_sqrt_estimate.cache_clear()
        monkeypatch.setenv("OSCILLATORS_INVERSE_SQRT", "divide")
        assert all(host_tuning.inverse_sqrt_estimate(loop) is None for loop in host_tuning.LOOPS)
        with pytest.raises(ValueError, match="leapfrog"):
            host_tuning.inverse_sqrt_estimate("spiral")
    finally:
        host_tuning.inverse_sqrt_estimate.cache_clear()


@pytest.mark.slow  # compiles both variants of both loop families
def test_the_measurement_answers_for_every_loop(monkeypatch, tmp_path):
    host_tuning.inverse_sqrt_estimate.cache_clear()
    try:
        monkeypatch.delenv("OSCILLATORS_INVERSE_SQRT", raising=False)
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
        answers = {loop: host_tuning.inverse_sqrt_estimate(loop) for loop in host_tuning.LOOPS}
        assert all(answer in (True, None) for answer in answers.values())
        assert (tmp_path / "coupled-oscillators" / "host_tuning.json").exists()
        assert "leapfrog" in host_tuning.describe()
    finally:
        host_tuning.inverse_sqrt_estimate.cache_clear()
