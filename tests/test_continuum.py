"""The continuum limit against physics: a body discretised at several N converges to the wave
equation; its fundamental, the order of convergence, the exact Fourier series against
d'Alembert's solution, and every run against the lattice's normal modes computed here."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from app.cli import main
from app.study import continuum as study
from sim.model.lattice import ModelError
from sim.runtime.simulation import Simulation
from sim.scenes.bodies import Body, Shape
from sim.scenes.continuum import ContinuumSolution


def _prony_omega(series: np.ndarray, dt: float) -> float:
    """omega of a pure cosine sampled every dt: u(t+dt) + u(t-dt) = 2 cos(omega dt) u(t)."""
    middle = series[1:-1]
    ratio = float(((series[2:] + series[:-2]) * middle).sum() / (2.0 * (middle * middle).sum()))
    return math.acos(ratio) / dt


@pytest.mark.parametrize("particles", [64, 512])
def test_string_fundamental_approaches_c_over_2_l0_with_the_discrete_correction(particles):
    body = Body(kind="string", length=0.8, density=0.02, tension=50.0, shape=Shape("sine"))
    continuum = body.speed / (2 * body.length)
    # predicted by the dispersion relation: f = (c / (pi a)) sin(pi a / (2 L0))
    a = body.spacing(particles)
    predicted = continuum * (1 - (math.pi * a / body.length) ** 2 / 24)
    dt = body.crossing_time / 2000
    simulation = Simulation(body.scene(particles, "rk4", dt))
    middle = particles // 2
    series = []
    for _ in range(6000):
        series.append(body.field(simulation.model, simulation.peek_positions())[0, middle])
        simulation.step(1)
    measured = _prony_omega(np.array(series), dt) / (2 * math.pi)
    correction = continuum - predicted
    assert abs(measured - predicted) < 0.01 * correction  # the correction itself is resolved
    assert abs(measured - continuum) < 1e-4 * continuum  # and it is small: the limit is c / 2 L0
    assert measured < continuum


def test_the_same_body_at_every_n_has_the_same_density_and_modulus():
    string = Body(kind="string", length=2.0, density=0.05, tension=80.0)
    membrane = Body(kind="membrane", length=2.0, density=0.05, tension=80.0)
    for n in (4, 17, 100):
        model = string.model(n)
        a = model.spacing
        assert a == pytest.approx(2.0 / (n + 1))
        assert model.masses.flat[0] / a == pytest.approx(0.05)  # lambda = m / a
        assert model.stiffness * a == pytest.approx(80.0)  # K = k a
        assert model.tension == pytest.approx(0.0)  # unstressed: the row moves along its springs
        model = membrane.model(min(n, 20))
        a = model.spacing
        assert model.masses.flat[0] / a**2 == pytest.approx(0.05)  # sigma = m / a^2
        assert model.tension / a == pytest.approx(80.0)  # membrane tension S = T / a


def _dalembert(shape: Shape, s: np.ndarray, t: float, speed: float, length: float) -> np.ndarray:
    """(f(s - ct) + f(s + ct)) / 2 with f extended odd about both ends (period 2 L0)."""

    def extended(x):
        x = np.mod(x, 2 * length)
        inside = x <= length
        return np.where(inside, shape.values(np.where(inside, x, 0) / length),
                        -shape.values(np.where(inside, 0, 2 * length - x) / length))

    return 0.5 * (extended(s - speed * t) + extended(s + speed * t))


@pytest.mark.parametrize("kind", ["gaussian", "pluck"])
def test_the_fourier_series_is_converged_and_equals_dalembert(kind):
    body = Body(kind="string", shape=Shape(kind, centre=0.37))
    solution = ContinuumSolution(body, 200)
    assert solution.converged
    s = body.coordinates(200)
    for t in (0.0, 0.13 * body.crossing_time, 0.71 * body.crossing_time):
        expected = _dalembert(body.shape, s, t, body.speed, body.length)
        assert np.abs(solution.at(t)[0] - expected).max() < 1e-6 * body.shape.amplitude


def test_the_membrane_series_follows_a_single_mode_exactly():
    body = Body(kind="membrane", shape=Shape("sine", mode=2))
    solution = ContinuumSolution(body, 12)
    x = body.coordinates(12) / body.length
    omega = body.speed * math.pi * math.sqrt(8) / body.length
    t = 0.3 * body.crossing_time
    expected = 0.01 * np.outer(np.sin(2 * math.pi * x), np.sin(2 * math.pi * x)) * math.cos(omega * t)
    assert np.abs(solution.at(t) - expected).max() < 1e-12


def _modal_solution(body: Body, particles: int, times) -> list[np.ndarray]:
    """The string lattice's exact solution from its dense eigenvectors (numpy, not sim)."""
    model = body.model(particles)
    k, m = model.stiffness, model.masses.flat[0]
    matrix = (2 * np.eye(particles) - np.eye(particles, k=1) - np.eye(particles, k=-1)) * k / m
    values, vectors = np.linalg.eigh(matrix)
    start = vectors.T @ body.initial_field(particles)[0]
    return [(vectors @ (start * np.cos(np.sqrt(values) * t)))[None, :] for t in times]


def test_every_run_agrees_with_the_lattice_modes_far_below_the_continuum_error():
    body = Body(kind="string", shape=Shape("gaussian"))
    times = [f * body.crossing_time for f in study.TIMES]
    for particles in (4, 16, 64, 256):
        run = study.run_particles(body, particles)
        exact = _modal_solution(body, particles, times)
        continuum = ContinuumSolution(body, particles)
        fields = study.lattice_run(body, particles, run.integrator, run.dt, times)
        norm = np.linalg.norm(body.initial_field(particles))
        lattice_vs_run = max(np.linalg.norm(f - e) for f, e in zip(fields, exact, strict=True))
        lattice_vs_continuum = max(np.linalg.norm(e - continuum.at(t))
                                   for e, t in zip(exact, times, strict=True))
        assert lattice_vs_run <= 0.1 * lattice_vs_continuum
        assert run.time_error == pytest.approx(lattice_vs_run / norm, rel=1e-6)
        assert run.discretisation_error == pytest.approx(lattice_vs_continuum / norm, rel=1e-6)


def test_halving_the_chosen_step_leaves_the_continuum_error_unchanged():
    body = Body(kind="string", shape=Shape("gaussian"))
    run = study.run_particles(body, 128)
    times = [f * body.crossing_time for f in study.TIMES]
    halved = study.lattice_run(body, 128, run.integrator, run.dt / 2, times)
    reference = ContinuumSolution(body, 128)
    norm = np.linalg.norm(body.initial_field(128))
    error = max(np.linalg.norm(h - reference.at(t)) for h, t in zip(halved, times, strict=True))
    assert error / norm == pytest.approx(run.error, rel=0.02)


def test_a_smooth_shape_converges_as_a_squared():
    result = study.continuum_study(Body(kind="string", shape=Shape("gaussian")),
                                   [32, 64, 128, 256, 512])
    assert result.order == pytest.approx(2.0, abs=0.2)
    assert result.expected_order == 2.0


def test_a_pluck_converges_more_slowly_and_says_why():
    result = study.continuum_study(Body(kind="string", shape=Shape("pluck", centre=0.3)),
                                   [32, 64, 128, 256])
    assert result.order == pytest.approx(1.0, abs=0.25)
    assert "kink" in result.why


@pytest.mark.slow
def test_a_smooth_membrane_converges_as_a_squared():
    result = study.continuum_study(Body(kind="membrane", shape=Shape("gaussian")), [32, 64, 128])
    assert result.order == pytest.approx(2.0, abs=0.2)


def test_cli_json_and_picture(tmp_path, capsys):
    picture = tmp_path / "string.png"
    code = main(["continuum", "string", "--particles", "8,16,32", "--shape", "sine", "--json",
                 "--quiet", "--plot", str(picture)])
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    assert [run["particles"] for run in data["runs"]] == [8, 16, 32]
    assert all(run["error"] > 0 for run in data["runs"])
    assert data["order"] == pytest.approx(2.0, abs=0.1)
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*"))  # no temporary file left beside it


@pytest.mark.parametrize("arguments, words", [
    (["--width", "0.5"], "width"),
    (["--particles", "4,0"], "at least 1"),
    (["membrane", "--particles", "5000"], "at most"),
    (["--particles", "20000", "--courant", "0.00001"], "limit"),
])
def test_cli_bad_input_is_one_line(arguments, words, capsys):
    try:
        code = main(["continuum", *arguments, "--quiet"])
    except SystemExit as exit_:  # argparse refuses a bad value itself
        code = exit_.code
    assert code == 2
    error = capsys.readouterr().err.strip()
    assert words in error and "\n" not in error


def test_bad_body_parameters_raise_clear_errors():
    with pytest.raises(ModelError, match="tension"):
        Body(kind="string", tension=-1.0)
    with pytest.raises(ModelError, match="centre"):
        Shape("pluck", centre=1.0)
