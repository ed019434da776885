"""Plane waves, rays, fringes and the intensity screen against independent physics: the long-wave
speeds a sqrt(k/m), a pulse spreading through the simulated lattice, textbook two-slit geometry and
the mean square of a sine."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.instruments.screen import IntensityScreen
from sim.model.lattice import Model
from sim.theory import lattice_waves, slits

K, A, L = 35.0, 1.0, 0.8  # the paper's stiffness, spacing and pre-tensioned rest length


def pulse_radius(simulation: sim.Simulation, component: int, axis: int) -> float:
    """Distance (m) from the centre, along ``axis`` through it, of the outgoing pulse's crest (the
    largest displacement of the initial bump's sign; a 2-D pulse trails a trough behind it)."""
    model = simulation.model
    u = (simulation.positions - simulation.rest_positions)[:, component].reshape(model.ny, model.nx)
    centre_row, centre_column = model.ny // 2, model.nx // 2
    line = u[centre_row, centre_column:] if axis == 0 else u[centre_row:, centre_column]
    return float(np.argmax(line[3:]) + 3) * model.spacing


@pytest.mark.parametrize(("dim", "component", "size"), [(2, 1, (101, 181)), (3, 2, (101, 101))])
def test_a_point_pulse_spreads_at_the_long_wave_speeds(dim, component, size):
    """In-plane u_y travels at a sqrt(T/a/m) = sqrt(7) along x and sqrt(k/m) = sqrt(35) along y
    (an ellipse); out-of-plane u_z at sqrt(7) both ways (a circle)."""
    model_args = dict(nx=size[0], ny=size[1], dim=dim, spacing=A, stiffness=K, rest_length=L, mass=1.0)
    scene = sim.scenes.build("grid", **model_args)
    simulation = sim.Simulation(scene, integrator="verlet", dt=0.02)
    model = simulation.model
    rest = simulation.rest_positions
    radius_squared = rest[:, 0] ** 2 + rest[:, 1] ** 2
    positions = rest.copy()
    positions[:, component] += 1e-3 * np.exp(-radius_squared / (2 * 2.0 ** 2))
    simulation.positions[:] = positions
    simulation.velocities[:] = 0.0
    duration = 12.0
    simulation.step(int(round(duration / simulation.dt)))
    wave = lattice_waves.polarisation(model, "xyz"[component])
    speed_x, speed_y = wave.long_wave_speeds()
    tension_stiffness = K * (A - L) / A
    expected_x = math.sqrt(tension_stiffness) if component != 0 else math.sqrt(K)
    expected_y = math.sqrt(K) if component == 1 else math.sqrt(tension_stiffness)
    assert speed_x == pytest.approx(expected_x)
    assert speed_y == pytest.approx(expected_y)
    along_x = pulse_radius(simulation, component, 0)
    along_y = pulse_radius(simulation, component, 1)
    assert along_x == pytest.approx(speed_x * duration, rel=0.05)
    assert along_y == pytest.approx(speed_y * duration, rel=0.05)


def test_dispersion_and_rays_agree_with_closed_forms():
    model = Model.create(nx=8, ny=8, dim=3, spacing=A, stiffness=K, rest_length=L)
    wave = lattice_waves.polarisation(model, "z")
    tension = K * (A - L) / A
    # a 1-D lattice's wavenumber along x: omega = 2 sqrt(T/m) sin(q a / 2)
    omega = 1.3
    assert wave.wavenumber(omega, 0.0) == pytest.approx(2 / A * math.asin(omega / (2 * math.sqrt(tension))))
    # along the diagonal both components carry sin^2(q a / (2 sqrt 2))
    q = 2 * math.sqrt(2) / A * math.asin(omega / (2 * math.sqrt(2 * tension)))
    assert wave.wavenumber(omega, math.pi / 4) == pytest.approx(q)
    # by symmetry the ray along the diagonal has its wave vector along the diagonal too
    qx, qy = wave.ray(omega, math.pi / 4)
    assert qx == pytest.approx(qy, rel=1e-6)
    with pytest.raises(lattice_waves.WaveError, match="above the highest frequency"):
        wave.wavenumber(2.01 * math.sqrt(tension), 0.0)
    # long waves in the anisotropic in-plane lattice: phase = omega * travel time on the ellipse
    in_plane = lattice_waves.polarisation(model, "y")
    cx, cy = in_plane.long_wave_speeds()
    omega = 0.02
    for dx, dy in ((100.0, 0.0), (0.0, 100.0), (60.0, 80.0), (-30.0, 90.0)):
        expected = omega * math.hypot(dx / cx, dy / cy)
        assert in_plane.phase(omega, dx, dy) == pytest.approx(expected, rel=1e-3)


def test_two_slit_fringes_follow_the_path_difference_of_long_waves():
    model = Model.create(nx=8, ny=8, dim=3, spacing=A, stiffness=K, rest_length=L)
    wave = lattice_waves.polarisation(model, "z")
    omega = 0.05  # long waves: lambda about 330 spacings, the lattice is a continuum here
    wavelength = wave.wavelength(omega)
    separation, distance = 2.5 * wavelength, 40 * wavelength
    far = slits.two_slit_maxima_far_field(wave, omega, separation, distance, half_height=1e9)
    for fringe in far:
        theta = math.asin(fringe.order * wavelength / separation)
        assert fringe.y == pytest.approx(distance * math.tan(theta), rel=1e-4)
    assert sorted(f.order for f in far) == [-2, -1, 0, 1, 2]
    rays = slits.two_slit_maxima_ray_phase(wave, omega, (-separation / 2, separation / 2),
                                           distance, half_height=distance, samples=300)
    assert sorted(f.order for f in rays) == [-1, 0, 1]  # up to 45 degrees: 2.5 sin 45 < 2
    for fringe in rays:
        path = (math.hypot(distance, fringe.y + separation / 2)
                - math.hypot(distance, fringe.y - separation / 2))
        assert path == pytest.approx(fringe.order * wavelength, abs=0.01 * wavelength)


def test_the_screen_averages_whole_periods_of_a_sine():
    model = Model.create(nx=5, ny=4, dim=2, spacing=A, stiffness=K)
    period = 0.7
    screen = IntensityScreen(model, column=2, component="y", period=period, periods=3)
    amplitudes = np.array([0.1, 0.2, 0.3, 0.4])
    dt = period / 97.3  # not a whole fraction of the period
    positions = model.rest_positions.copy()
    for n in range(2000):
        t = n * dt
        positions[screen.rows, 1] = model.rest_positions[screen.rows, 1] + amplitudes * math.sin(
            2 * math.pi * t / period + 0.4)
        screen.observe(t, positions)
        if n == 50:
            assert screen.intensity is None
    assert screen.whole_periods == 3
    assert screen.intensity == pytest.approx(amplitudes**2 / 2, rel=2e-2)


def test_ray_phases_of_many_points_match_the_phase_found_ray_by_ray():
    model = Model.create(nx=8, ny=8, dim=2, spacing=A, stiffness=K, rest_length=L)
    wave = lattice_waves.polarisation(model, "y")  # anisotropic: q leans off the ray
    omega = 0.6 * wave.highest_omega(0.0)
    dx = np.array([50.0, 30.0, -20.0, 0.0, 45.0])
    dy = np.array([0.0, 40.0, 35.0, -60.0, -45.0])
    together = slits.ray_phases(wave, omega, dx, dy)
    one_by_one = [wave.phase(omega, float(x), float(y)) for x, y in zip(dx, dy, strict=True)]
    assert together == pytest.approx(one_by_one, rel=1e-6)
