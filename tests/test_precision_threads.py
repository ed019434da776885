"""float32 and multi-threaded runs against the physics, and the integrators as one description.

float32 tolerance: every step rounds each coordinate to float32, a relative error of at most
eps32 = 2**-24 (about 6e-8) of the position's magnitude (the lattice's extent, not the
displacement).  These errors are uncorrelated from step to step, so after N steps they add up
like a random walk to about eps32 * extent * sqrt(N); the tests allow 20 times that on top of
the float64 tolerance.  Energies are summed in float64, so the energy error follows the same
estimate relative to the energy scale.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import sim
from app.cli.arguments import IntegratorChoices
from sim.integrators import registry as integrators
from sim.integrators import steppers
from sim.integrators.registry import IntegratorDescription
from sim.loops import row_sweep as stepping

K = 35.0
EPS32 = float(np.finfo(np.float32).eps) / 2


def float32_tolerance(extent: float, steps: int) -> float:
    """Absolute position tolerance (m) from float32 round-off after ``steps`` steps."""
    return 20 * EPS32 * extent * math.sqrt(steps)


@pytest.mark.slow  # float32 chain kernels of their own; the float32 grid below stays in the default run
@pytest.mark.parametrize("integrator", ["verlet", "rk4"])
@pytest.mark.parametrize("mode", [1, 3, 5])
def test_float32_chain_normal_modes(integrator, mode):
    count, mass, amplitude, dt = 5, 1.0, 0.1, 0.001
    simulation = sim.Simulation(
        sim.scenes.build("chain", linear=True), integrator=integrator, dt=dt, precision="float32"
    )
    assert simulation.state.positions.dtype == np.float32
    j = np.arange(1, count + 1)
    shape = np.sin(mode * math.pi * j / (count + 1))
    rest = simulation.rest_positions.copy()
    simulation.positions[:, 0] = rest[:, 0] + amplitude * shape
    simulation.velocities[...] = 0.0
    omega = 2 * math.sqrt(K / mass) * math.sin(mode * math.pi / (2 * (count + 1)))
    extent = float(np.abs(rest).max())
    simulation.step(2500)
    displacement = simulation.state.particle_positions()[:, 0].astype(float) - rest[:, 0]
    expected = amplitude * shape * math.cos(omega * simulation.time)
    # float64 error of the method itself: Verlet's phase error omega^3 dt^2 t / 24, RK4 negligible
    method = amplitude * omega**3 * dt**2 * simulation.time / 24 if integrator == "verlet" else 0
    np.testing.assert_allclose(
        displacement, expected, atol=float32_tolerance(extent, 2500) + 2 * method
    )


@pytest.mark.parametrize("threads", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_float32_energy_conserved_nonlinear_grid(threads):
    scene = sim.scenes.build("grid").with_displacement(40, (0.05, 0.03))
    reference = sim.Simulation(scene, integrator="verlet", dt=0.01)
    single = sim.Simulation(scene, integrator="verlet", dt=0.01, precision="float32",
                            threads=threads)
    start = reference.energy().total
    steps = 2000
    reference.step(steps)
    single.step(steps)
    extent = float(np.abs(scene.model.rest_positions).max())
    # energy ~ k * stretch * (position error): relative to the spring force scale
    tolerance = K * scene.model.spacing * float32_tolerance(extent, steps) * scene.model.n_springs
    assert abs(single.energy().total - reference.energy().total) < tolerance
    # Verlet's own bounded energy error, of order (omega_max dt)^2
    bound = (reference.stability().omega_max * 0.01) ** 2 / 4
    assert abs(reference.energy().total - start) < bound * start


@pytest.mark.parametrize("precision", ["float64", pytest.param("float32", marks=pytest.mark.slow)])
def test_threads_equal_one_thread_to_round_off(precision):
    scene = sim.scenes.build("interference", nx=96, ny=41)
    runs = []
    for threads in (1, 2, 3):
        simulation = sim.Simulation(scene, integrator="verlet", dt=0.01, precision=precision,
                                    threads=threads)
        simulation.step(200)
        runs.append(simulation.state.positions.astype(float))
    extent = float(np.abs(scene.model.rest_positions).max())
    eps = float(np.finfo(precision).eps)
    for other in runs[1:]:
        np.testing.assert_allclose(other, runs[0], rtol=0, atol=20 * eps * extent * math.sqrt(200))


SCENE_FLAGS = [
    pytest.param({}, id="undamped"),
    pytest.param({"linear": True}, id="linear"),
    pytest.param({"damping": 0.3}, id="dashpots"),
    pytest.param({"drag": 0.2, "gravity": 2.0}, id="drag-gravity"),
    pytest.param({"dim": 3}, id="3d"),
    pytest.param({"mass": "ionic", "damping": 0.3}, id="mass-array"),
]


def _flagged_scene(flags: dict, ny: int):
    scene = sim.scenes.build("interference", nx=48, ny=ny, **flags)
    if flags.get("dim") == 3:
        scene = scene.with_displacement(48 * ny // 2 + 24, (0.0, 0.0, 0.05))
    return scene


def _thread_matrix() -> list:
    """Every (flags, ny); the default run keeps the undamped kernels at ny = 37 (the halo
    wavefronts): each other flag set compiles its own kernels (minutes on a fresh clone), so
    those run with the slow tests."""
    cases = []
    for flags in SCENE_FLAGS:
        for ny in (6, 10, 37):
            fast = flags.id == "undamped" and ny == 37
            cases.append(pytest.param(flags.values[0], ny, id=f"{flags.id}-ny{ny}",
                                      marks=() if fast else pytest.mark.slow))
    return cases


@pytest.mark.parametrize("integrator", [  # the block wavefronts are checked by default in test_physics
    pytest.param("rk4", marks=pytest.mark.slow), "verlet",
    pytest.param("heun", marks=pytest.mark.slow), pytest.param("euler", marks=pytest.mark.slow)])
@pytest.mark.parametrize("flags, ny", _thread_matrix())
def test_every_integrator_on_threads_equals_one_thread(integrator, flags, ny):
    """Row blocks on 2 and 3 threads against the one-thread loop, every flag combination; ny = 10
    gives blocks thinner than 8 rows (RK4 per-stage phases, Heun halo wavefront), ny = 6 the
    per-stage phases of both, ny = 37 their halo wavefronts."""
    scene = _flagged_scene(flags, ny)
    runs = []
    for threads in (1, 2, 3):
        simulation = sim.Simulation(scene, integrator=integrator, dt=0.004, threads=threads)
        simulation.step(60)
        simulation.step(1)  # a call of one step takes Verlet's full-step path
        runs.append(simulation)
    extent = float(np.abs(scene.model.rest_positions).max())
    atol = 20 * float(np.finfo(np.float64).eps) * extent * math.sqrt(61)
    for other in runs[1:]:
        np.testing.assert_allclose(other.state.positions, runs[0].state.positions, rtol=0,
                                   atol=atol)
        np.testing.assert_allclose(other.state.velocities, runs[0].state.velocities, rtol=0,
                                   atol=atol / 0.004)
        assert other.state.dissipated == pytest.approx(runs[0].state.dissipated, rel=1e-12,
                                                       abs=1e-300)


@pytest.mark.slow  # float32 on threads compiles kernels of its own (a minute on a cold cache)
@pytest.mark.parametrize("integrator", ["rk4", "heun", "euler"])
def test_threaded_float32_equals_one_thread(integrator):
    scene = sim.scenes.build("interference", nx=48, ny=37, damping=0.1)
    runs = []
    for threads in (1, 2):
        simulation = sim.Simulation(scene, integrator=integrator, dt=0.004, precision="float32",
                                    threads=threads)
        simulation.step(50)
        runs.append(simulation.state.positions.astype(float))
    extent = float(np.abs(scene.model.rest_positions).max())
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=20 * EPS32 * extent * math.sqrt(50))


@pytest.mark.parametrize("integrator", [pytest.param("rk4", marks=pytest.mark.slow), "verlet"])
def test_threaded_energy_conserved(integrator):
    """Undamped nonlinear grid on 2 threads: the energy stays within the method's own error."""
    scene = sim.scenes.build("grid", ny=24).with_displacement(40, (0.05, 0.03))
    simulation = sim.Simulation(scene, integrator=integrator, dt=0.01, threads=2)
    start = simulation.energy().total
    simulation.step(1500)
    omega_dt = simulation.stability().omega_max * 0.01
    bound = omega_dt**2 / 4 if integrator == "verlet" else omega_dt**4
    assert abs(simulation.energy().total - start) < bound * start


@pytest.mark.slow  # damped threaded kernels of their own; threads equal one thread in the default run
def test_threaded_damped_energy_balance():
    """Kinetic + potential + dissipated stays the initial energy with the blocks on 2 threads."""
    scene = sim.scenes.build("grid", ny=24, damping=0.5).with_displacement(40, (0.05, 0.03))
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.01, threads=2)
    start = simulation.energy().total
    simulation.step(500)
    assert simulation.state.dissipated > 0.1 * start
    balance = simulation.energy().total + simulation.state.dissipated
    assert balance == pytest.approx(start, rel=1e-4)


@pytest.mark.parametrize("integrator", [pytest.param("rk4", marks=pytest.mark.slow),
                                        pytest.param("verlet", marks=pytest.mark.slow)])
def test_threaded_stability_limit_unchanged(integrator):
    """Just below the analysed limit a threaded run stays bounded; just above it grows, as on one
    thread."""
    scene = sim.scenes.build("grid", linear=True, ny=24).with_displacement(40, (0.01, 0.01))
    limit = sim.Simulation(scene, integrator=integrator).stable_dt(integrator)
    for factor, stable in ((0.98, True), (1.05, False)):
        energies = []
        for threads in (1, 2):
            simulation = sim.Simulation(scene, integrator=integrator, dt=factor * limit,
                                        threads=threads)
            start = simulation.energy().total
            try:
                simulation.step(3000)
                energies.append(simulation.energy().total / start)
            except sim.BlowUpError:
                energies.append(math.inf)
        assert (energies[1] < 2.0) is stable
        assert (energies[0] < 2.0) is stable


def test_stability_limit_does_not_depend_on_precision_or_threads():
    scene = sim.scenes.build("grid")
    base = sim.Simulation(scene, integrator="verlet")
    other = sim.Simulation(scene, integrator="verlet", precision="float32", threads=2)
    for name in ("verlet", "rk4", "euler"):
        assert other.stable_dt(name) == base.stable_dt(name)
    omega = base.stability("verlet").omega_max
    assert base.stable_dt("verlet") == pytest.approx(2.0 / omega)
    assert base.stable_dt("rk4") == pytest.approx(2 * math.sqrt(2) / omega)


def test_float32_kernels_compute_in_float32():
    scene = sim.scenes.build("grid")
    simulation = sim.Simulation(scene, integrator="rk4", precision="float32")
    simulation.step(3)
    signatures = [str(signature) for signature in stepping.runge_kutta_steps.signatures]
    assert any("float32" in signature and "float64, 3d" not in signature
               for signature in signatures), signatures
    assert simulation.state.velocities.dtype == np.float32
    assert isinstance(simulation.energy().total, float)


def test_precision_from_scene_files_and_cli(tmp_path):
    scene = sim.scenes.build("chain", precision="float32")
    path = tmp_path / "chain.toml"
    sim.scenes.scene_files.save(scene, path)
    assert sim.scenes.scene_files.load_file(str(path)).precision == "float32"
    assert sim.Simulation(sim.scenes.scene_files.load_file(str(path))).precision == "float32"
    with pytest.raises(sim.SceneError):
        sim.scenes.build("chain", precision="float16")
    result = subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "chain", "--steps", "10", "--precision",
         "float32", "--threads", "2", "--quiet"], capture_output=True, text=True,
    )
    assert result.returncode == 0, result.stderr


# --- the one description of the integrators ---------------------------------------------------


class SymplecticEuler(steppers.Integrator):
    """The docs/api.md example: kick with a(x), then drift with the new velocity."""

    name = "symplectic-euler"

    def advance(self, state, n, dt):
        for _ in range(n):
            stepping.accelerations(*self._common(state), self.work[0])
            state.velocities += self._dt(dt) * self.work[0]
            state.positions += self._dt(dt) * state.velocities
        state.advance_clock(n, dt)


def test_every_integrator_table_comes_from_the_one_description():
    from app.study import accuracy

    registered = [d.name for d in integrators.descriptions()]
    general = [d.name for d in integrators.descriptions() if d.applies_to is None]
    assert list(sim.INTEGRATORS) == general
    assert list(IntegratorChoices()) == registered
    for table, field in ((sim.ORDERS, "order"), (integrators.LABELS, "label"),
                         (integrators.FORCE_EVALUATIONS, "force_evaluations"),
                         (integrators.STABILITY_FACTORS, "stability_factor")):
        assert list(table) == registered
        assert all(table[name] == getattr(integrators.describe(name), field) for name in table)
    assert accuracy.ORDERS is integrators.ORDERS
    assert accuracy.FORCE_EVALUATIONS is integrators.FORCE_EVALUATIONS


def test_a_fifth_integrator_is_one_registration():
    description = IntegratorDescription(
        name="symplectic-euler", label="symplectic Euler", short_label="symplectic Euler",
        order=1, force_evaluations=1, stability_factor=2.0, stepper=SymplecticEuler,
        amplification=None, symplectic=True,
    )
    integrators.register(description)
    try:
        assert "symplectic-euler" in sim.INTEGRATORS
        assert "symplectic-euler" in IntegratorChoices()
        assert sim.ORDERS["symplectic-euler"] == 1
        simulation = sim.Simulation(sim.scenes.build("single"), integrator="symplectic-euler",
                                    dt=0.01)
        omega = simulation.stability().omega_max
        assert simulation.stable_dt() == pytest.approx(2.0 / omega)
        simulation.positions[0] += (1e-3, 0.0)
        start = simulation.energy().total
        simulation.step(1000)
        assert abs(simulation.energy().total - start) < 0.05 * start  # symplectic: bounded
    finally:
        integrators.unregister("symplectic-euler")
    assert "symplectic-euler" not in sim.INTEGRATORS


def test_a_runge_kutta_table_knows_its_order_and_stability_limit():
    """Order conditions and the stability polynomial against the textbook values: orders 4, 2,
    3, 2; R(z) the Taylor polynomial of e^z to the order (s stages, order s); the largest stable
    omega dt on the imaginary axis 2 sqrt 2 for RK4 (|R(iy)|^2 = 1 - y^6/72 + y^8/576) and
    sqrt 3 for a third-order method (1 - y^4/12 + y^6/36), none for second order (1 + y^4/4)."""
    from sim.integrators.butcher import CLASSIC_RK4, HEUN, MIDPOINT, RALSTON3

    expected = {CLASSIC_RK4: (4, 2 * math.sqrt(2)), HEUN: (2, None), RALSTON3: (3, math.sqrt(3)),
                MIDPOINT: (2, None)}
    for table, (order, factor) in expected.items():
        assert table.order == order, table.label
        taylor = [1 / math.factorial(k) for k in range(order + 1)]
        np.testing.assert_allclose(table.stability_polynomial, taylor, rtol=1e-15)
        if factor is None:
            assert table.stability_factor is None
        else:
            assert table.stability_factor == pytest.approx(factor, rel=1e-12)
    ralston = integrators.describe("ralston3")
    assert (ralston.order, ralston.force_evaluations, ralston.stability_factor) == (
        3, 3, RALSTON3.stability_factor)
    # the amplification matrix on the damped oscillator is R(dt M), M = [[0, 1], [-w^2, -beta]]
    omega_squared, beta, dt = np.array([4.0, 9.0]), np.array([0.5, 0.0]), 0.1
    matrices = ralston.amplification(omega_squared, beta, dt)
    for g, w2, b in zip(matrices, omega_squared, beta, strict=True):
        step = dt * np.array([[0.0, 1.0], [-w2, -b]])
        expected_matrix = np.eye(2) + step + step @ step / 2 + step @ step @ step / 6
        np.testing.assert_allclose(g, expected_matrix, rtol=1e-14)


@pytest.mark.parametrize("a, b, c, message", [
    (((0, 0, 0), (0.5, 0, 0), (-1, 2, 0)), (1 / 6, 2 / 3, 1 / 6), (0, 0.5, 1), "not low-storage"),
    (((0.5, 0), (0.5, 0)), (0.5, 0.5), (0.5, 0.5), "implicit"),
    (((0, 0), (1, 0)), (0.5, 0.6), (0, 1), "sum to 1"),
    (((0, 0), (1, 0)), (0.5, 0.5), (0, 0.5), "sum of row 2"),
    (((0,),), (1,), (0,), "at least 2 stages"),
    (((0, 0), ("1/x", 0)), (0.5, 0.5), (0, 1), "number"),
])
def test_a_table_the_loops_cannot_run_is_refused_clearly(a, b, c, message):
    from sim.integrators.butcher import ButcherTable, ButcherTableError

    with pytest.raises(ButcherTableError, match=message):
        ButcherTable(label="test table", a=a, b=b, c=c)


def test_non_kernel_integrators_only_where_they_apply():
    nonlinear = sim.scenes.build("grid").model
    for description in integrators.descriptions():
        if description.applies_to is not None:
            assert description.name not in sim.INTEGRATORS
        if not description.kernel:
            assert description.name not in integrators.names(kernel_only=True)
    assert set(integrators.names(nonlinear)) <= set(integrators.ALL_INTEGRATORS)


def bench_report(*options: str) -> dict:
    """``oscillators bench --scene grid --seconds 0.05 OPTIONS --json`` in a fresh process, its
    JSON report (the command must succeed)."""
    result = subprocess.run(
        [sys.executable, "-m", "app.cli", "bench", "--scene", "grid", "--seconds", "0.05",
         *options, "--json"], capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


@pytest.mark.slow  # compiles every kernel variant in a fresh process
def test_bench_reports_host_vector_width_and_threads():
    report = bench_report("--threads", "2")
    assert report["host"]["vector_width_bits"] in (128, 256, 512)
    assert report["threads"] == [1, 2]
    configurations = {(r["integrator"], r["precision"], r["threads"]) for r in report["configurations"]}
    assert ("verlet", "float32", 2) in configurations and ("rk4", "float64", 1) in configurations
    gains = report["specialisation"]["rk4"]["gain"]
    assert set(gains) == {"zero_gravity", "zero_drag", "zero_dashpot", "inverse_mass_array",
                          "three_dimensional", "damped_gravity_compiled_out"}
    assert all(0.3 < gain < 30 for gain in gains.values())  # ratios of measured rates


@pytest.mark.slow  # compiles the instruments' kernels of the grid in a fresh process
def test_bench_runs_only_the_parts_asked_for():
    report = bench_report("--only", "instruments")
    assert not {"integrators", "configurations", "specialisation"} & set(report)
    costs = report["instruments"]["cost"]
    assert set(costs) == {"periodic", "driven", "absorbing"}
    assert all(0.3 < cost < 30 for cost in costs.values())  # ratios of measured rates
