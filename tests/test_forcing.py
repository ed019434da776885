"""The driver and the absorbing walls against physics: the driven damped oscillator's amplitude,
resonance of a chain's normal mode, the evanescent response inside the ionic band gap, the
sponge's reflection, and the energy balance with the driver's work."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.model.lattice import ModelError

STIFFNESS = 35.0


def steady_amplitude(simulation: sim.Simulation, omega: float, periods: int,
                     component: int = 0) -> np.ndarray:
    """Amplitude at angular frequency ``omega`` of every particle's displacement along
    ``component`` over ``periods`` drive periods (least-squares fit of a cos + b sin + c)."""
    times, displacements = [], []
    steps_per_period = int(round(2 * math.pi / omega / simulation.dt))
    for _ in range(periods * steps_per_period):
        simulation.step(1)
        times.append(simulation.time)
        displacements.append(simulation.positions[:, component] - simulation.rest_positions[:, component])
    t = np.array(times)
    basis = np.stack([np.cos(omega * t), np.sin(omega * t), np.ones_like(t)], axis=1)
    coefficients, *_ = np.linalg.lstsq(basis, np.array(displacements), rcond=None)
    return np.hypot(coefficients[0], coefficients[1])


# --- the driver -------------------------------------------------------------------------------


@pytest.mark.parametrize("ratio", [0.5, 0.95, 1.0, 1.6])
@pytest.mark.parametrize("integrator", [  # Runge-Kutta with a driver: by default below
    pytest.param("rk4", marks=pytest.mark.slow), "verlet"])
def test_driven_damped_oscillator_settles_to_the_analytic_amplitude(ratio, integrator):
    """One particle between two springs along x (omega_0^2 = 2k/m), drag gamma m, driven by
    F0 sin(omega t): amplitude F0 / (m sqrt((omega_0^2 - omega^2)^2 + (gamma omega)^2))."""
    mass, drag, amplitude = 2.0, 0.8, 0.01
    omega_0 = math.sqrt(2 * STIFFNESS / mass)
    omega = ratio * omega_0
    model = sim.Model.create(1, 1, stiffness=STIFFNESS, mass=mass, drag=drag, linear=True,
                             driver=dict(frequency=omega / (2 * math.pi), amplitude=amplitude,
                                         ramp=2.0))
    simulation = sim.Simulation(model, integrator=integrator, dt=0.004)
    gamma = drag / mass
    simulation.step(int(12 / gamma / simulation.dt))  # transients decay as exp(-gamma t / 2)
    measured = steady_amplitude(simulation, omega, periods=4)[0]
    force = amplitude * STIFFNESS
    expected = force / (mass * math.sqrt((omega_0**2 - omega**2) ** 2 + (gamma * omega) ** 2))
    assert measured == pytest.approx(expected, rel=0.01)


def chain_modes(particles: int) -> tuple[np.ndarray, np.ndarray]:
    """Angular frequencies (rad/s) and shapes (columns) of a fixed-fixed chain, k/m = 35."""
    n = np.arange(1, particles + 1)
    omegas = 2 * math.sqrt(STIFFNESS) * np.sin(n * math.pi / (2 * (particles + 1)))
    positions = np.arange(1, particles + 1)
    shapes = np.sqrt(2 / (particles + 1)) * np.sin(np.outer(positions, n) * math.pi / (particles + 1))
    return omegas, shapes


@pytest.mark.parametrize("mode", [1, 2, 3])
def test_driving_a_chain_at_a_mode_frequency_excites_that_mode(mode):
    particles = 8
    omegas, shapes = chain_modes(particles)
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, drag=0.05, linear=True,
                             driver=dict(column=0, frequency=omegas[mode - 1] / (2 * math.pi),
                                         amplitude=0.002, ramp=5.0))
    simulation = sim.Simulation(model, integrator="rk4", dt=0.01)
    simulation.step(6000)
    displacement = simulation.positions[:, 0] - simulation.rest_positions[:, 0]
    velocity = simulation.velocities[:, 0]
    modal_energy = 0.5 * (shapes.T @ velocity) ** 2 + 0.5 * (omegas * (shapes.T @ displacement)) ** 2
    assert modal_energy[mode - 1] >= 0.95 * modal_energy.sum()


def ionic_gap_decay_per_cell(omega: float, light: float, heavy: float) -> float:
    """Amplitude ratio per unit cell (two particles) of the evanescent wave of the diatomic chain
    at an angular frequency inside its gap: with s = 1/m + 1/M the dispersion relation
    omega^2 = k s -+ k sqrt(s^2 - 4 sin^2(q a) / (m M)) at q a = pi/2 + i kappa a gives
    cosh^2(kappa a) = m M (s^2 - (omega^2 / k - s)^2) / 4, and the ratio is exp(-2 kappa a)."""
    s = 1 / light + 1 / heavy
    cosh_squared = light * heavy * (s**2 - (omega**2 / STIFFNESS - s) ** 2) / 4
    return math.exp(-2 * math.acosh(math.sqrt(cosh_squared)))


@pytest.mark.slow  # a driven chain of unequal masses compiles kernels of its own
def test_driving_the_ionic_chain_inside_the_gap_gives_an_evanescent_response():
    light, heavy = 1.0, 4.0
    acoustic_top, optical_bottom = math.sqrt(2 * STIFFNESS / heavy), math.sqrt(2 * STIFFNESS / light)
    omega = 0.5 * (acoustic_top + optical_bottom)
    particles = 60
    masses = np.where(np.arange(particles) % 2 == 0, heavy, light)[None, :]
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, mass=masses, linear=True,
                             boundary="absorbing", sponge_width=20, sponge_sides="right",
                             driver=dict(column=0, frequency=omega / (2 * math.pi),
                                         amplitude=0.01, ramp=20.0))
    simulation = sim.Simulation(model, integrator="rk4", dt=0.01)
    simulation.step(4000)
    amplitude = steady_amplitude(simulation, omega, periods=6)
    heavy_amplitudes = amplitude[0:10:2]  # the first five cells
    measured = np.exp(np.polyfit(np.arange(heavy_amplitudes.size), np.log(heavy_amplitudes), 1)[0])
    assert measured == pytest.approx(ionic_gap_decay_per_cell(omega, light, heavy), rel=0.03)
    # and outside the gap, in the acoustic band, the wave travels: no decay along the chain
    assert amplitude[30] < 1e-3 * amplitude[0]


@pytest.mark.parametrize("integrator, kind", [
    ("verlet", "force"), ("verlet", "displacement"),
    pytest.param("rk4", "displacement", marks=pytest.mark.slow),  # kernels of their own
    pytest.param("rk4", "force", marks=pytest.mark.slow),  # its own kernels: a minute cold
])
def test_the_energy_balance_closes_with_the_driver_work(integrator, kind):
    model = sim.Model.create(6, 5, stiffness=STIFFNESS, rest_length=0.8, damping=0.2, drag=0.05,
                             gravity=2.0, driver=dict(column=2, row=1, direction="y", kind=kind,
                                                      amplitude=0.05, frequency=1.1, ramp=1.0))
    simulation = sim.Simulation(model, integrator=integrator, dt=0.002)
    simulation.step(3000)
    energy = simulation.energy()
    assert energy.driven > 0.05 and energy.dissipated > 0.01
    tolerance = 1e-6 if integrator == "rk4" else 2e-3
    assert abs(simulation.energy_balance_error()) < tolerance


def test_a_displacement_driver_follows_its_prescription():
    model = sim.Model.create(5, 1, stiffness=STIFFNESS,
                             driver=dict(column=2, kind="displacement", direction="x",
                                         amplitude=0.1, frequency=0.5, ramp=0.0))
    simulation = sim.Simulation(model, integrator="verlet", dt=0.01)
    for _ in range(137):
        simulation.step(1)
    # the position is set at the start of each step; one step later it has moved on freely
    simulation.step(0)
    expected = 0.1 * math.sin(2 * math.pi * 0.5 * 1.37)
    displacement = simulation.positions[2, 0] - simulation.rest_positions[2, 0]
    assert displacement == pytest.approx(expected, abs=2e-3)


def prescribed_chain_exact(particles: int, driven: int, amplitude: float, frequency: float,
                           damping: float, time: float) -> np.ndarray:
    """x-displacements (m) at ``time`` of a linear chain of unit masses between walls with
    dashpots ``damping`` beside its springs, particle ``driven`` moved as
    A sin(omega t) from rest at t = 0 and the others starting at rest: the free particles obey
    u'' = k L u + c L u' + (k b u_d + c b u_d') with L the chain's second difference and b its
    coupling to the driven particle, solved exactly (eigenvectors for the transient, a complex
    amplitude for the steady state)."""
    omega = 2 * math.pi * frequency
    free = [i for i in range(particles) if i != driven]
    n = len(free)
    second = -2 * np.eye(particles) + np.eye(particles, k=1) + np.eye(particles, k=-1)
    coupling = second[free, driven]
    system = np.zeros((2 * n, 2 * n))
    system[:n, n:] = np.eye(n)
    system[n:, :n] = STIFFNESS * second[np.ix_(free, free)]
    system[n:, n:] = damping * second[np.ix_(free, free)]
    sine, cosine = np.zeros(2 * n), np.zeros(2 * n)
    sine[n:] = STIFFNESS * coupling * amplitude
    cosine[n:] = damping * coupling * amplitude * omega
    steady = np.linalg.solve(1j * omega * np.eye(2 * n) - system, cosine - 1j * sine)
    values, vectors = np.linalg.eig(system)
    transient = vectors @ (np.exp(values * time) * np.linalg.solve(vectors, -steady.real))
    state = transient.real + (steady * np.exp(1j * omega * time)).real
    displacement = np.full(particles, amplitude * math.sin(omega * time))
    displacement[free] = state[:n]
    return displacement


@pytest.mark.parametrize(("integrator", "steps", "order"), [
    pytest.param("verlet", 400, 1.8, marks=pytest.mark.slow), ("rk4", 100, 3.5)])
def test_a_displacement_driver_with_dashpots_converges_at_the_integrators_order(integrator, steps,
                                                                                order):
    """The neighbours of a prescribed particle feel a position and velocity consistent with its
    prescribed motion inside the step, so halving dt divides the error by 2^order."""
    particles, driven, amplitude, frequency, damping, duration = 6, 2, 0.05, 0.7, 0.6, 2.0
    expected = prescribed_chain_exact(particles, driven, amplitude, frequency, damping, duration)
    errors = []
    for count in (steps, 2 * steps):
        model = sim.Model.create(particles, 1, stiffness=STIFFNESS, damping=damping, linear=True,
                                 driver=dict(column=driven, kind="displacement", direction="x",
                                             amplitude=amplitude, frequency=frequency, ramp=0.0))
        simulation = sim.Simulation(model, integrator=integrator, dt=duration / count)
        simulation.step(count)
        displacement = simulation.positions[:, 0] - simulation.rest_positions[:, 0]
        errors.append(np.abs(displacement - expected).max())
    assert errors[1] < 1e-4 * amplitude
    assert math.log2(errors[0] / errors[1]) > order


# --- the absorbing layer ---------------------------------------------------------------------


def reflected_fraction(wavelength: float, boundary: str,
                       width: int = sim.model.boundaries.DEFAULT_LAYER_WIDTH) -> float:
    """A Gaussian wave packet of ``wavelength`` (in spacings) starts at rest in the middle of a
    long linear chain and splits into two halves that run into the walls; the fraction of the
    energy back in the interior when the reflections would have returned to the middle."""
    distance = 300
    particles = 2 * (distance + width)
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, linear=True, boundary=boundary,
                             sponge_width=width)
    x = np.arange(particles) - (particles - 1) / 2
    displacement = 0.01 * np.exp(-0.5 * (x / wavelength) ** 2) * np.cos(2 * math.pi * x / wavelength)
    positions = model.rest_positions.copy()
    positions[:, 0] += displacement
    scene = sim.scenes.Scene(name="packet", model=model, initial_positions=positions)
    q = 2 * math.pi / wavelength
    group_velocity = math.sqrt(STIFFNESS) * math.cos(q / 2)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.05)
    start = simulation.energy().total
    simulation.step(int(2 * distance / group_velocity / simulation.dt))
    inside = slice(width, particles - width)
    u = simulation.positions[:, 0] - model.rest_positions[:, 0]
    kinetic = 0.5 * np.sum(simulation.velocities[inside, 0] ** 2)
    spring = 0.5 * STIFFNESS * np.sum(np.diff(u[inside]) ** 2)
    return (kinetic + spring) / start


@pytest.mark.parametrize("wavelength", [10, 20, 30])
def test_the_sponge_reflects_at_most_one_percent_of_waves_ten_spacings_and_longer(wavelength):
    assert reflected_fraction(wavelength, "absorbing") <= 0.01
    assert reflected_fraction(wavelength, "fixed") > 0.9  # the same measurement sees a wall


@pytest.mark.slow  # the layer's kernels on another scene; its reflection stays in the default run
def test_the_sponge_takes_out_what_it_absorbs_and_the_balance_closes():
    scene = sim.scenes.build("interference-open", nx=140, ny=100)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.01)
    simulation.step(4000)
    energy = simulation.energy()
    assert energy.dissipated > 0.5 * (energy.total + energy.dissipated)
    assert abs(simulation.energy_balance_error()) < 1e-4


@pytest.mark.slow  # the layer's kernels on another scene; its reflection stays in the default run
def test_the_sponge_does_not_lower_the_stable_step():
    """The layer's drag is integrated exactly, so Verlet just below the undamped limit stays
    bounded with it."""
    scene = sim.scenes.build("grid", nx=100, ny=4, boundary="absorbing", sponge_width=20,
                             linear=True)
    simulation = sim.Simulation(scene, integrator="verlet")
    simulation.dt = 0.98 * simulation.stable_dt()
    simulation.step(3000)
    assert np.isfinite(simulation.energy().total)


# --- what a scene without them runs, and bad input --------------------------------------------


def test_scenes_without_driver_or_sponge_step_in_one_compiled_call(monkeypatch):
    simulation = sim.Simulation(sim.scenes.build("grid"), integrator="verlet")
    calls = []
    advance = simulation._integrator.advance
    monkeypatch.setattr(simulation._integrator, "advance",
                        lambda state, n, dt: (calls.append(n), advance(state, n, dt)))
    simulation.step(64)
    assert calls == [64]


@pytest.mark.parametrize("parameters, message", [
    (dict(driver=dict(column=12)), "outside"),
    (dict(driver=dict(frequency=float("nan"))), "finite"),
    (dict(driver=dict(frequency=0)), "positive"),
    (dict(driver=dict(amplitude=-1)), ">= 0"),
    (dict(driver=dict(kind="push")), "kind"),
    (dict(driver=dict(direction=(0, 0, 0))), "zero vector"),
    (dict(driver=dict(direction="z")), "out of the plane"),
    (dict(driver="column=1,frequency"), "key=value"),
    (dict(boundary="open"), "boundary"),
    (dict(boundary="absorbing", nx=8, ny=6), "lower sponge_width"),
    (dict(boundary="absorbing", sponge_width=2, sponge_sides="left,front"), "sponge side"),
    (dict(boundary="absorbing", sponge_width=0), "sponge_width"),
])
def test_bad_driver_and_boundary_values_are_refused_clearly(parameters, message):
    with pytest.raises(ModelError, match=message):
        sim.scenes.build("grid", **parameters)


def test_the_exact_solver_refuses_a_driven_scene():
    with pytest.raises(ValueError, match="driver"):
        sim.Simulation(sim.scenes.build("resonance", linear=True), integrator="exact")


def instrumented_grid(**changes) -> sim.scenes.Scene:
    """The nonlinear pre-tensioned grid with a force driver and absorbing walls, undamped: the
    scene the fused leapfrog loops run."""
    parameters = dict(nx=40, ny=24, boundary="absorbing", sponge_width=6,
                      driver=dict(column=20, row=12, direction="y", amplitude=0.05,
                                  frequency=0.8, ramp=1.0))
    return sim.scenes.build("grid", **{**parameters, **changes})


@pytest.mark.slow  # kernels of their own (leapfrog with both)
def test_a_driver_and_a_sponge_run_inside_the_fused_steps(monkeypatch):
    simulation = sim.Simulation(instrumented_grid(), integrator="verlet")
    calls = []
    advance = simulation._integrator.advance
    monkeypatch.setattr(simulation._integrator, "advance",
                        lambda state, n, dt: (calls.append(n), advance(state, n, dt)))
    simulation.step(64)
    assert calls == [64]


@pytest.mark.parametrize("kind", ["force", "displacement"])
def test_the_balance_closes_with_the_instruments_inside_verlets_steps(kind):
    """Work fed in and energy taken out are counted inside the fused loops: what the driver
    put in is what the lattice holds plus what the layer took out, to Verlet's accuracy."""
    scene = instrumented_grid(driver=dict(column=20, row=12, direction="y", amplitude=0.05,
                                          frequency=0.8, ramp=1.0, kind=kind))
    simulation = sim.Simulation(scene, integrator="verlet", dt=0.01)
    start = simulation.energy().balance
    simulation.step(3000)
    energy = simulation.energy()
    exchanged = abs(energy.driven) + energy.dissipated
    assert abs(energy.driven) > 0.01 and energy.dissipated > 1.0
    assert abs(energy.balance - start) < 2e-3 * exchanged


def test_the_layer_inside_verlets_steps_acts_as_between_single_steps():
    """The fused leapfrog lets the layer act before each sweep, at the positions the sweep kicks
    with, and counts its take on the half-step velocities half a step on.  Stepped one step at a
    time, the layer acts between whole velocity-Verlet steps instead (another loop): the same
    splitting, so the same motion and the same energy taken out and fed in, to rounding."""
    runs = []
    for steps, calls in ((400, 1), (1, 400)):
        simulation = sim.Simulation(instrumented_grid(), integrator="verlet", dt=0.01)
        for _ in range(calls):
            simulation.step(steps)
        runs.append((simulation.positions - simulation.rest_positions, simulation.energy()))
    (fused, fused_energy), (single, single_energy) = runs
    moved = np.abs(single).max()
    assert moved > 1e-3 and single_energy.dissipated > 1e-3
    assert np.abs(fused - single).max() < 1e-9 * moved
    assert fused_energy.dissipated == pytest.approx(single_energy.dissipated, rel=1e-9)
    assert fused_energy.driven == pytest.approx(single_energy.driven, rel=1e-9)


@pytest.mark.slow  # the threaded loops with a driver and a layer: kernels of their own
def test_threads_run_the_instruments_like_one_thread():
    """On 4 threads the grid's 24 rows are blocks of 6, fewer than a band's 7 rows."""
    runs = []
    for threads in (1, 2, 4):
        simulation = sim.Simulation(instrumented_grid(), integrator="verlet", dt=0.01,
                                    threads=threads)
        simulation.step(500)
        runs.append((simulation.positions.copy(), simulation.energy()))
    for positions, energy in runs[1:]:
        np.testing.assert_allclose(positions, runs[0][0], rtol=0, atol=1e-12)
        assert energy.driven == pytest.approx(runs[0][1].driven, rel=1e-9)
        assert energy.dissipated == pytest.approx(runs[0][1].dissipated, rel=1e-9)


@pytest.mark.slow  # float32 3-D kernels of their own: 40 s cold
def test_a_driven_out_of_plane_lattice_runs_in_float32_as_in_float64():
    """The drive reads a float32 state's velocities too (the ripple tanks' sources in float32):
    the same run in both precisions, to float32's resolution."""
    scene = sim.scenes.build("grid", nx=10, ny=8, dim=3, linear=True, dt=0.01,
                             driver=dict(column=4, row=3, direction="z", amplitude=0.05,
                                         frequency=0.5, kind="force"))
    runs = {"rest": np.asarray(sim.Simulation(scene).state.positions, dtype=float)}
    for precision in ("float64", "float32"):
        simulation = sim.Simulation(scene, integrator="verlet", precision=precision)
        simulation.step(200)
        runs[precision] = np.asarray(simulation.state.positions, dtype=float)
    moved = np.abs(runs["float64"] - runs["rest"]).max()
    assert moved > 1e-3  # the drive moved the lattice
    assert np.abs(runs["float32"] - runs["float64"]).max() < 1e-3 * moved


@pytest.mark.parametrize("integrator", ["rk4", pytest.param("verlet", marks=pytest.mark.slow)])
def test_a_kick_inside_the_sponge_is_absorbed_not_amplified(integrator):
    """A particle inside the layer of a chain at rest is given a small velocity: the layer must
    take that energy out, not turn it into a drift of the chain (a layer that cannot hold a
    static stress drifts as a piston and feeds the lattice)."""
    model = sim.Model.create(30, 1, stiffness=STIFFNESS, linear=True, boundary="absorbing")
    velocities = np.zeros_like(model.rest_positions)
    velocities[1, 0] = 1e-3
    scene = sim.scenes.Scene(name="kick", model=model, initial_positions=model.rest_positions.copy(),
                             initial_velocities=velocities)
    simulation = sim.Simulation(scene, integrator=integrator, dt=0.02)
    given = simulation.energy().total
    simulation.step(15000)  # 300 s: fifty crossings of the chain
    energy = simulation.energy()
    assert energy.kinetic + energy.potential < 0.1 * given
    assert energy.dissipated > 0.9 * given
    assert abs(simulation.energy_balance_error()) < 1e-2
