"""Wave packets against the lattice's dispersion relation: a packet launched with one wave vector
travels at the group velocity d omega / d q and its crests at omega / |q|.

The theory here is written out independently of the code under test: for a lattice of nearest
springs each displacement component obeys

    omega^2 = (4 / m) (kx sin^2(qx a / 2) + ky sin^2(qy a / 2))

with kx, ky the stiffness across columns and rows (x motion: kx = k, ky = T / a; y motion the
reverse), so d omega / d qx = a kx sin(qx a) / (m omega), likewise along y, and the phase
speed is omega / |q|.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import sim
from sim.instruments.packet_tracker import PacketTracker
from sim.scenes.packet import PacketSpec, launch_packet, packet_state, polarisation_names, theory
from sim.theory.lattice_waves import WaveError

TOLERANCE = 0.02
"""Measured speeds agree with theory within 2 %."""


def analytic(kx: float, ky: float, m: float, a: float, qx: float, qy: float) -> dict:
    """omega (rad/s), group velocity (m/s, the derivative of omega) and phase speed (m/s)."""
    omega = math.sqrt(4 / m * (kx * math.sin(qx * a / 2) ** 2 + ky * math.sin(qy * a / 2) ** 2))
    # d/dq of sin^2(q a / 2) is (a / 2) sin(q a); d omega = d(omega^2) / (2 omega)
    vx = 4 / m * kx * (a / 2) * math.sin(qx * a) / (2 * omega)
    vy = 4 / m * ky * (a / 2) * math.sin(qy * a) / (2 * omega)
    return {"omega": omega, "group_speed": math.hypot(vx, vy), "velocity": (vx, vy),
            "phase_speed": omega / math.hypot(qx, qy)}


def stiffnesses(model: sim.Model, component: str) -> tuple[float, float]:
    """(kx, ky) (N/m) of one displacement component: k along its springs, T / a across."""
    k, across = model.stiffness, model.stiffness * (model.spacing - model.rest_length) \
        / model.spacing
    return {"x": (k, across), "y": (across, k)}[component]


def measure(scene: sim.scenes.Scene, spec: PacketSpec) -> dict:
    """Launch the packet, run until its edge would reach a wall, sampling eight times a period;
    the tracker's speeds."""
    simulation = sim.Simulation(scene)
    launch_packet(simulation, spec)
    tracker = PacketTracker(simulation.model, spec)
    tracker.add(simulation.time, simulation.state.particle_positions())
    planned = theory(simulation.model, spec)
    assert planned["clear_time"] > 0
    steps = int(planned["clear_time"] / simulation.dt)
    chunk = max(1, int(2 * math.pi / planned["omega"] / 8 / simulation.dt))
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        simulation.step(n)
        done += n
        tracker.add(simulation.time, simulation.state.particle_positions())
    return tracker.speeds()


def check(measured: dict, expected: dict) -> None:
    assert measured["group_speed"] == pytest.approx(expected["group_speed"], rel=TOLERANCE)
    assert measured["phase_speed"] == pytest.approx(expected["phase_speed"], rel=TOLERANCE)
    assert measured["omega"] == pytest.approx(expected["omega"], rel=TOLERANCE)


def chain_case(q: float, nx: int, **settings) -> tuple[dict, dict]:
    scene = sim.scenes.build("grid", nx=nx, ny=1, **settings)
    model = scene.model
    expected = analytic(*stiffnesses(model, "x"), float(model.masses.flat[0]), model.spacing,
                        q, 0.0)
    return measure(scene, PacketSpec(q, 0.0, "x")), expected


def test_a_long_wave_on_the_grids_x_branch_travels_at_the_group_velocity():
    measured, expected = chain_case(0.5, 400)
    check(measured, expected)
    # a long wave: group and phase speed close to a sqrt(k / m), the group one below
    assert measured["group_speed"] < measured["phase_speed"]


def test_a_short_wave_near_the_zone_edge_is_slower_as_theory_says():
    short, short_expected = chain_case(2.5, 120)
    check(short, short_expected)
    long, long_expected = chain_case(1.0, 200)
    assert short["group_speed"] < 0.5 * long["group_speed"]
    ratio = short_expected["group_speed"] / long_expected["group_speed"]
    assert short["group_speed"] / long["group_speed"] == pytest.approx(ratio, rel=TOLERANCE)


def pretensioned(direction: str) -> tuple[dict, dict]:
    """u_y of the pre-tensioned lattice (interference preset, L = 0.8 a) along x or along y."""
    nx, ny, spec = (150, 150, PacketSpec(1.0, 0.0, "y")) if direction == "x" else \
        (70, 150, PacketSpec(0.0, 1.0, "y"))
    scene = sim.scenes.build("interference", nx=nx, ny=ny)
    model = scene.model
    expected = analytic(*stiffnesses(model, "y"), float(model.masses.flat[0]), model.spacing,
                        spec.qx, spec.qy)
    return measure(scene, spec), expected


@pytest.mark.slow
def test_the_pretensioned_lattice_is_anisotropic_as_theory_says():
    along_x, along_x_expected = pretensioned("x")
    along_y, along_y_expected = pretensioned("y")
    check(along_x, along_x_expected)
    check(along_y, along_y_expected)
    # u_y along x is held by the tension only (T / a = k / 5), along y by the springs' k
    assert along_y["group_speed"] > 2 * along_x["group_speed"]
    ratio = along_y_expected["group_speed"] / along_x_expected["group_speed"]
    assert along_y["group_speed"] / along_x["group_speed"] == pytest.approx(ratio, rel=TOLERANCE)
    # and the packets go straight: no sideways drift
    assert abs(along_x["group_velocity"][1]) < 1e-3 * along_x["group_speed"]
    assert abs(along_y["group_velocity"][0]) < 1e-3 * along_y["group_speed"]


def test_u_y_along_y_of_the_pretensioned_lattice_travels_at_the_group_velocity():
    measured, expected = pretensioned("y")
    check(measured, expected)


def lower_in_plane_branch(k: float, k2: float, m: float, a: float, qx: float, qy: float) -> float:
    """omega (rad/s) of the lower in-plane branch of an unstressed lattice with nearest springs k
    and diagonal ones k2: the smaller eigenvalue of the 2x2 force-constant matrix per mass,
    summed spring by spring (nearest along x and y, diagonals along (1, +-1) / sqrt 2)."""
    cx, cy, sx, sy = (math.cos(qx * a), math.cos(qy * a), math.sin(qx * a), math.sin(qy * a))
    xx = 2 * k * (1 - cx) + 2 * k2 * (1 - cx * cy)
    yy = 2 * k * (1 - cy) + 2 * k2 * (1 - cx * cy)
    xy = 2 * k2 * sx * sy
    return math.sqrt((xx + yy - math.hypot(xx - yy, 2 * xy)) / 2 / m)


@pytest.mark.slow
def test_an_oblique_s_packet_of_the_elastic_solid_travels_at_its_group_velocity():
    scene = sim.scenes.build("elastic-solid", nx=100, ny=100)
    model = scene.model
    k, k2, m, a = model.stiffness, model.diagonal_stiffness, 1.0, model.spacing
    qx, qy, h = 1.0, 0.5, 1e-6
    omega = lower_in_plane_branch(k, k2, m, a, qx, qy)
    vx = (lower_in_plane_branch(k, k2, m, a, qx + h, qy)
          - lower_in_plane_branch(k, k2, m, a, qx - h, qy)) / (2 * h)
    vy = (lower_in_plane_branch(k, k2, m, a, qx, qy + h)
          - lower_in_plane_branch(k, k2, m, a, qx, qy - h)) / (2 * h)
    measured = measure(scene, PacketSpec(qx, qy, "S"))
    check(measured, {"omega": omega, "group_speed": math.hypot(vx, vy),
                     "phase_speed": omega / math.hypot(qx, qy)})
    # it travels along the group velocity, not along q
    angle = math.atan2(*measured["group_velocity"][::-1])
    assert angle == pytest.approx(math.atan2(vy, vx), abs=0.02)
    assert abs(math.atan2(vy, vx) - math.atan2(qy, qx)) > 0.03


def test_the_packet_state_is_the_plane_wave_under_its_envelope():
    model = sim.scenes.build("grid", nx=200, ny=1).model
    spec = PacketSpec(1.0, 0.0, "x")
    positions, velocities = packet_state(model, spec, amplitude=0.01)
    displacement = (positions - model.rest_positions)[:, 0]
    x = model.rest_positions[:, 0]
    peak = int(np.argmax(np.abs(displacement)))
    assert abs(displacement[peak]) == pytest.approx(0.01, rel=0.01)
    # crests one wavelength apart: the field's strongest Fourier component is at q
    k = 2 * np.pi * np.fft.rfftfreq(model.nx, model.spacing)
    assert k[np.argmax(np.abs(np.fft.rfft(displacement)))] == pytest.approx(1.0, abs=0.04)
    # the velocities: u_t = A E omega sin(...) so u^2 + (u_t / omega)^2 = (A E)^2, smooth and
    # peaking at A; the crests move towards +x (u_t = -c u_x, c > 0)
    omega = analytic(model.stiffness, 0.0, 1.0, model.spacing, 1.0, 0.0)["omega"]
    envelope = np.hypot(displacement, velocities[:, 0] / omega)
    assert envelope.max() == pytest.approx(0.01, rel=0.01)
    assert np.abs(np.diff(envelope)).max() < 0.01 * 0.1
    assert float(velocities[:, 0] @ np.gradient(displacement, x)) < 0


def test_polarisation_names_follow_the_lattice():
    assert polarisation_names(sim.scenes.build("grid").model) == ("x", "y")
    assert polarisation_names(sim.scenes.build("membrane").model) == ("x", "y", "z")
    solid = sim.scenes.build("elastic-solid", nx=20, ny=20).model
    assert polarisation_names(solid) == ("S", "P")


@pytest.mark.parametrize("spec, words", [
    (PacketSpec(4.0, 0.0, "x"), "first zone"),
    (PacketSpec(0.0, 0.0, "x"), "zero"),
    (PacketSpec(math.nan, 0.0, "x"), "finite"),
    (PacketSpec(1.0, 0.0, "S"), "one of x, y"),
    (PacketSpec(1.0, 0.0, "y"), "carries no wave"),
])
def test_a_refused_packet_says_why(spec, words):
    model = sim.scenes.build("grid", nx=40, ny=20).model
    with pytest.raises(WaveError, match=words):
        theory(model, spec)


def test_unequal_masses_without_a_repeating_cell_are_refused():
    model = sim.scenes.build("grid", nx=12, ny=8).model
    masses = 1.0 + np.random.default_rng(0).random((8, 12))
    with pytest.raises(ValueError, match="equal masses or the ionic checkerboard"):
        packet_state(model.replace(mass=masses), PacketSpec(1.0, 0.0, "x"))


def diatomic(q: float, k: float, heavy: float, light: float, optical: bool) -> float:
    """omega (rad/s) of the diatomic chain's branch at q (rad/m, a = 1): omega^2 =
    k (1/M + 1/m) -+ k sqrt((1/M + 1/m)^2 - 4 sin^2(q a) / (M m))."""
    mean = 1 / heavy + 1 / light
    root = math.sqrt(mean**2 - 4 * math.sin(q) ** 2 / (heavy * light))
    return math.sqrt(k * (mean + (root if optical else -root)))


@pytest.mark.parametrize("branch, tolerance", [("x acoustic", 0.005), ("x optical", 0.015)])
def test_packets_of_the_ionic_chain_travel_at_its_branches_group_velocity(branch, tolerance):
    """The checkerboard chain (4 kg and 1 kg alternating): a Bloch packet of each branch keeps
    the branch's frequency and travels at its group velocity, from the diatomic chain's textbook
    dispersion (the centroid lags by the envelope's spread of wave vectors: more on the optical
    branch, whose group velocity bends more)."""
    scene = sim.scenes.build("ionic", nx=800, ny=1)
    heavy, light = 4.0, 1.0
    assert sorted(set(scene.model.masses.ravel())) == [light, heavy]
    q = 0.3 * math.pi
    optical = branch.endswith("optical")
    omega = diatomic(q, 35.0, heavy, light, optical)
    h = 1e-5
    group = (diatomic(q + h, 35.0, heavy, light, optical)
             - diatomic(q - h, 35.0, heavy, light, optical)) / (2 * h)
    measured = measure(scene, PacketSpec(q, 0.0, branch))
    assert measured["omega"] == pytest.approx(omega, rel=1e-3)
    assert measured["group_speed"] == pytest.approx(abs(group), rel=tolerance)  # along vg
    assert measured["samples"] > 100


def test_run_packet_json_reports_the_speeds(capsys):
    from app.cli import main

    assert main(["run", "grid", "--set", "nx=120", "--set", "ny=1", "--packet", "2.5,0",
                 "--json", "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    for key in ("group_speed", "group_speed_theory", "phase_speed", "phase_speed_theory",
                "omega", "omega_theory"):
        assert isinstance(summary[key], float), key
    expected = analytic(35.0, 0.0, 1.0, 1.0, 2.5, 0.0)
    assert summary["group_speed"] == pytest.approx(expected["group_speed"], rel=TOLERANCE)
    assert summary["phase_speed"] == pytest.approx(expected["phase_speed"], rel=TOLERANCE)
    assert summary["packet"]["polarisation"] == "x"
    assert summary["time"] == pytest.approx(summary["packet"]["clear_time"], abs=0.02)


@pytest.mark.parametrize("packet, words", [("4,0", "first zone"), ("1", "QX,QY"),
                                           ("1,1", "chain"), ("1,0,q", "one of x, y")])
def test_run_refuses_a_bad_packet_with_one_line(packet, words, capsys):
    from app.cli import main

    assert main(["run", "grid", "--set", "ny=1", f"--packet={packet}", "--quiet"]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: --packet") and words in error and "Traceback" not in error


def test_launch_packet_sets_the_state_and_keeps_the_clock():
    simulation = sim.Simulation(sim.scenes.build("grid", nx=120, ny=1))
    simulation.step(7)
    spec = PacketSpec(2.5, 0.0, "x")
    launch_packet(simulation, spec)
    positions, velocities = packet_state(simulation.model, spec)
    np.testing.assert_array_equal(simulation.state.particle_positions(), positions)
    np.testing.assert_array_equal(simulation.state.particle_velocities(), velocities)
    assert simulation.time == pytest.approx(7 * simulation.dt)
    assert simulation.state.dissipated == 0.0


def test_the_tracker_starts_again_after_a_reset_and_reads_sparse_samples():
    scene = sim.scenes.build("grid", nx=120, ny=1)
    spec = PacketSpec(2.5, 0.0, "x")
    simulation = sim.Simulation(scene)
    launch_packet(simulation, spec)
    tracker = PacketTracker(simulation.model, spec)
    tracker.add(5.0, simulation.state.particle_positions())
    tracker.add(6.0, simulation.state.particle_positions())
    tracker.add(0.0, simulation.state.particle_positions())  # an earlier time: a reset
    assert tracker.times.tolist() == [0.0]
    # one sample every 0.9 of a period: the phase is unwrapped about the theory's omega
    expected = analytic(35.0, 0.0, 1.0, 1.0, 2.5, 0.0)
    steps = max(1, int(0.9 * 2 * math.pi / expected["omega"] / simulation.dt))
    while simulation.time < 20.0:
        simulation.step(steps)
        tracker.add(simulation.time, simulation.state.particle_positions())
    measured = tracker.speeds()
    assert measured["unwrapped_about_theory"]
    assert measured["omega"] == pytest.approx(expected["omega"], rel=1e-3)
    assert measured["group_speed"] == pytest.approx(expected["group_speed"], rel=TOLERANCE)


def test_the_speeds_can_be_read_while_another_thread_adds_frames() -> None:
    """The page reads a tracker's speeds in its own thread while the simulation's thread adds
    frames: every read sees whole samples (no arrays of different lengths)."""
    import threading

    scene = sim.scenes.build("grid", nx=200, ny=1)
    spec = PacketSpec(0.5, 0.0, "x")
    positions, _ = packet_state(scene.model, spec)
    tracker = PacketTracker(scene.model, spec)
    done = threading.Event()

    def feed() -> None:
        for k in range(4000):
            tracker.add(0.001 * k, positions)
        done.set()

    feeder = threading.Thread(target=feed)
    feeder.start()
    reads = 0
    while not done.is_set() or reads < 10:
        result = tracker.speeds()
        assert result["samples"] >= 0
        reads += 1
    feeder.join()
    assert tracker.speeds()["samples"] > 3
@pytest.mark.slow
@pytest.mark.parametrize("q", [1.5, 2.5])
def test_short_waves_between_absorbing_walls_travel_at_the_group_velocity(q):
    """A packet starts clear of the absorbing layer, so the layer neither reflects nor drifts
    into the measurement: the speeds are those of theory, as between fixed walls."""
    measured, expected = chain_case(q, 200, boundary="absorbing")
    check(measured, expected)
