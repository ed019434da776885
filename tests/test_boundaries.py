"""Row ends other than walls.  Periodic rows (``boundary="periodic"``): each row is a ring; a
plane wave travels around it at the dispersion relation's phase velocity, the stability limit is
the ring's, and the exact solver and mode energies use the ring's Fourier modes.  Free ends
(``boundary="free"``): a pulse comes back from a free end upright and from a wall inverted, and
the stability limit and modes are those of the free chain."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim

STIFFNESS = 35.0


def ring_with_wave(particles: int, wavenumber_index: int, amplitude: float = 0.01,
                   linear: bool = True) -> tuple[sim.scenes.Scene, float, float]:
    """A ring of ``particles`` carrying the travelling longitudinal wave
    u_i = A cos(q i a - omega t), q a = 2 pi m / N, omega = 2 sqrt(k/m) sin(q a / 2);
    returns (scene, q, omega)."""
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, boundary="periodic", linear=linear)
    q = 2 * math.pi * wavenumber_index / particles
    omega = 2 * math.sqrt(STIFFNESS) * math.sin(q / 2)
    columns = np.arange(particles)
    positions = model.rest_positions.copy()
    velocities = np.zeros_like(positions)
    positions[:, 0] += amplitude * np.cos(q * columns)
    velocities[:, 0] = amplitude * omega * np.sin(q * columns)
    return sim.scenes.Scene(name="ring", model=model, initial_positions=positions,
                            initial_velocities=velocities), q, omega


def wave_phase(simulation: sim.Simulation, q: float) -> float:
    """phi of u_i = A cos(q i - phi), from the Fourier coefficient at q."""
    columns = np.arange(simulation.model.nx)
    displacement = simulation.positions[:, 0] - simulation.rest_positions[:, 0]
    return float(-np.angle(np.sum(displacement * np.exp(-1j * q * columns))))


@pytest.mark.parametrize("wavenumber_index", [1, 3, 10])
def test_a_plane_wave_travels_around_the_ring_at_the_phase_velocity(wavenumber_index):
    scene, q, omega = ring_with_wave(40, wavenumber_index)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.005)
    travelled = 0.0
    previous = wave_phase(simulation, q)
    for _ in range(200):  # follow the phase in steps of less than pi to unwrap it
        simulation.step(20)
        phase = wave_phase(simulation, q)
        travelled += (phase - previous + math.pi) % (2 * math.pi) - math.pi
        previous = phase
    phase_velocity = travelled / q / simulation.time  # spacings per second
    assert phase_velocity == pytest.approx(omega / q, rel=1e-6)
    # and the wave is a normal mode of the ring: its shape is kept
    columns = np.arange(simulation.model.nx)
    displacement = simulation.positions[:, 0] - simulation.rest_positions[:, 0]
    amplitude = 2 * abs(np.sum(displacement * np.exp(-1j * q * columns))) / columns.size
    assert amplitude == pytest.approx(0.01, rel=1e-6)


@pytest.mark.slow  # compiles the nonlinear ring's kernels
def test_the_nonlinear_ring_carries_a_small_wave_at_the_same_speed():
    scene, q, omega = ring_with_wave(30, 2, amplitude=1e-4, linear=False)
    simulation = sim.Simulation(scene, integrator="verlet", dt=0.002)
    quarter_period = int(round(0.5 * math.pi / omega / simulation.dt))
    simulation.step(quarter_period)
    expected = (omega * simulation.time) % (2 * math.pi)
    assert wave_phase(simulation, q) % (2 * math.pi) == pytest.approx(expected, abs=2e-3)


@pytest.mark.slow  # ring kernels at their limit: the ring balance and plane wave run by default
@pytest.mark.parametrize("particles", [8, 9])
def test_the_stability_limit_is_the_rings(particles):
    """Verlet is stable up to dt = 2 / omega_max; on a ring omega_max = 2 sqrt(k/m) sin(pi p/N)
    maximised over whole p: 2 sqrt(k/m) for even N (the zigzag mode), less for odd N."""
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, boundary="periodic", linear=True)
    p = np.arange(particles)
    omega_max = float(np.max(2 * math.sqrt(STIFFNESS) * np.abs(np.sin(math.pi * p / particles))))
    simulation = sim.Simulation(model, integrator="verlet")
    assert simulation.stable_dt() == pytest.approx(2 / omega_max, rel=1e-12)
    fixed = sim.Simulation(sim.Model.create(particles, 1, stiffness=STIFFNESS, linear=True),
                           integrator="verlet")
    if particles % 2 == 0:  # the ring has the zigzag mode, faster than any mode between walls
        assert fixed.stable_dt() > simulation.stable_dt()
    # real runs of the fastest mode: bounded just below the limit, blowing up just above it
    zigzag = np.cos(math.pi * np.round(particles / 2) * 2 * p / particles)
    for factor, blows_up in ((0.98, False), (1.03, True)):
        positions = model.rest_positions.copy()
        positions[:, 0] += 1e-3 * zigzag
        run = sim.Simulation(sim.scenes.Scene(name="ring", model=model, initial_positions=positions),
                             integrator="verlet", dt=factor * 2 / omega_max)
        if blows_up:
            with pytest.raises(sim.BlowUpError):
                run.step(20_000)
        else:
            run.step(20_000)
            assert np.abs(run.positions - model.rest_positions).max() < 1e-2


def test_the_exact_solver_follows_a_periodic_lattice():
    scene = sim.scenes.build("grid", nx=7, ny=4, boundary="periodic", linear=True)
    exact = sim.Simulation(scene, integrator="exact", dt=0.5)
    fine = sim.Simulation(scene, integrator="rk4", dt=0.002)
    exact.step(6)
    fine.step(1500)
    np.testing.assert_allclose(exact.positions, fine.positions, atol=1e-9)


def test_mode_energies_of_a_ring_add_up_and_stay_constant():
    scene = sim.scenes.build("grid", nx=10, ny=3, boundary="periodic", linear=True)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.002)
    simulation.step(185)
    energies = sim.theory.modes.mode_energies(simulation.model, simulation.positions, simulation.velocities)
    total = sum(float(e.sum()) for e in energies)
    energy = simulation.energy()
    assert total == pytest.approx(energy.kinetic + energy.spring, rel=1e-10)
    before = np.concatenate(energies)
    simulation.step(2500)
    after = np.concatenate(sim.theory.modes.mode_energies(simulation.model, simulation.positions,
                                                   simulation.velocities))
    np.testing.assert_allclose(after, before, rtol=0, atol=1e-7 * total)


@pytest.mark.slow  # compiles the threaded kernels of the ring
def test_threads_give_the_same_ring():
    scene = sim.scenes.build("grid", nx=24, ny=37, boundary="periodic")
    runs = []
    for threads in (1, 2):
        simulation = sim.Simulation(scene, integrator="verlet", dt=0.01, threads=threads)
        simulation.step(60)
        runs.append(simulation.positions.copy())
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=1e-12)


def test_sine_modes_are_refused_on_a_ring_with_a_reason():
    model = sim.Model.create(6, 1, boundary="periodic")
    with pytest.raises(sim.ModelError, match="Fourier"):
        sim.theory.modes.excited_state(model, 1, 1, 0, 0.1)


# --- free ends --------------------------------------------------------------------------------


def reflected_pulse_sign(boundary: str) -> float:
    """A longitudinal Gaussian pulse travelling left along a linear chain, reflected at its left
    end: the sign of the reflected pulse relative to the incident one (+1 upright, -1 inverted)."""
    particles = 200
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, linear=True, boundary=boundary)
    columns = np.arange(particles)
    width, centre = 6.0, 100.0
    pulse = 0.01 * np.exp(-0.5 * ((columns - centre) / width) ** 2)
    # a left-going pulse: u(x + c t), so v = c du/dx with c = sqrt(k/m) spacings/s
    slope = np.gradient(pulse)
    positions = model.rest_positions.copy()
    velocities = np.zeros_like(positions)
    positions[:, 0] += pulse
    velocities[:, 0] = math.sqrt(STIFFNESS) * slope
    simulation = sim.Simulation(sim.scenes.Scene(name="pulse", model=model,
                                                 initial_positions=positions,
                                                 initial_velocities=velocities),
                                integrator="rk4", dt=0.02)
    simulation.step(int(round(160 / math.sqrt(STIFFNESS) / simulation.dt)))  # 100 there, 60 back
    displacement = simulation.positions[:, 0] - simulation.rest_positions[:, 0]
    region = slice(40, 100)
    peak = displacement[region][np.argmax(np.abs(displacement[region]))]
    assert abs(peak) > 0.5 * 0.01  # the pulse came back whole
    return float(np.sign(peak))


@pytest.mark.slow  # two long chains' kernels of their own; the free end's physics is in the default run
def test_a_pulse_comes_back_upright_from_a_free_end_and_inverted_from_a_wall():
    assert reflected_pulse_sign("free") == 1.0
    assert reflected_pulse_sign("fixed") == -1.0


@pytest.mark.slow  # free-end kernels at their limit: the free-end balance runs by default
def test_the_stability_limit_of_a_free_chain():
    """Free ends: Neumann second difference, omega_max = 2 sqrt(k/m) sin((N - 1) pi / (2 N))."""
    particles = 6
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, linear=True, boundary="free")
    omega_max = 2 * math.sqrt(STIFFNESS) * math.sin((particles - 1) * math.pi / (2 * particles))
    simulation = sim.Simulation(model, integrator="verlet")
    assert simulation.stable_dt() == pytest.approx(2 / omega_max, rel=1e-12)
    for factor, blows_up in ((0.98, False), (1.03, True)):
        positions = model.rest_positions.copy()
        positions[:, 0] += 1e-3 * np.cos((particles - 1) * math.pi * (np.arange(particles) + 0.5)
                                         / particles)
        run = sim.Simulation(sim.scenes.Scene(name="free", model=model, initial_positions=positions),
                             integrator="verlet", dt=factor * 2 / omega_max)
        if blows_up:
            with pytest.raises(sim.BlowUpError):
                run.step(20_000)
        else:
            run.step(20_000)


@pytest.mark.slow  # free ends' own kernels; their energy balance stays in the default run
def test_the_exact_solver_and_mode_energies_follow_free_ends():
    scene = sim.scenes.build("grid", nx=7, ny=3, boundary="free", linear=True, rest_length=0.9)
    exact = sim.Simulation(scene, integrator="exact", dt=0.5)
    fine = sim.Simulation(scene, integrator="rk4", dt=0.002)
    exact.step(4)
    fine.step(1000)
    np.testing.assert_allclose(exact.positions, fine.positions, atol=1e-9)
    energies = sim.theory.modes.mode_energies(fine.model, fine.positions, fine.velocities)
    energy = fine.energy()
    # the modes are measured from the equilibrium, where the pre-tension has pulled the free
    # ends inward: its spring energy (below the rest lattice's) is the offset
    settled = sim.Simulation(scene, integrator="rk4", dt=0.002)
    settled.positions = (settled.rest_positions
                         + sim.theory.modes.static_offset(scene.model).reshape(2, -1).T)
    assert settled.energy().spring < 0.0
    assert sum(float(e.sum()) for e in energies) == pytest.approx(
        energy.kinetic + energy.spring - settled.energy().spring, rel=1e-10)


@pytest.mark.parametrize("boundary", [pytest.param("periodic", marks=pytest.mark.slow), "free"])
def test_the_energy_balance_closes_on_rings_and_free_ends(boundary):
    scene = sim.scenes.build("grid", nx=9, ny=5, boundary=boundary, rest_length=0.8, damping=0.3,
                             gravity=1.0, driver=dict(column=0, row=2, frequency=0.7))
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.005)
    simulation.step(2000)
    assert abs(simulation.energy_balance_error()) < 1e-6


def free_chain_equilibrium(particles: int, rest_length: float) -> np.ndarray:
    """Static x-displacements (m) of a linearised pre-tensioned chain (spacing 1 m, one row
    between the bottom and top walls) whose ends are free: each end particle is pulled inward
    by the tension T = k (a - L) of its one spring, every particle is held at its site by the
    two wall springs across it (stiffness T / a each), and springs between neighbours resist
    with k.  Solved as K u = f."""
    tension = STIFFNESS * (1.0 - rest_length)
    matrix = 2 * tension * np.eye(particles)
    for i in range(particles - 1):
        matrix[i:i + 2, i:i + 2] += STIFFNESS * np.array([[1.0, -1.0], [-1.0, 1.0]])
    pull = np.zeros(particles)
    pull[0], pull[-1] = tension, -tension
    return np.linalg.solve(matrix, pull)


@pytest.mark.slow  # free ends with tension: kernels of their own
def test_a_free_ended_pre_tensioned_chain_contracts_to_the_equilibrium_of_its_tension():
    """The rest tension of the springs pulls the free ends inward; with drag the chain settles
    where the end tension is balanced (an independent linear solve), and the energy the
    tension released is what the drag took out."""
    particles, rest_length = 12, 0.9
    model = sim.Model.create(particles, 1, stiffness=STIFFNESS, rest_length=rest_length,
                             linear=True, boundary="free", drag=2.0)
    simulation = sim.Simulation(model, integrator="rk4", dt=0.01)
    simulation.step(6000)
    displacement = simulation.positions[:, 0] - simulation.rest_positions[:, 0]
    expected = free_chain_equilibrium(particles, rest_length)
    assert abs(expected[0]) > 0.1
    np.testing.assert_allclose(displacement, expected, atol=1e-6 * abs(expected[0]))
    energy = simulation.energy()
    assert energy.dissipated > 0.05
    assert abs(energy.balance) < 1e-6 * energy.dissipated
