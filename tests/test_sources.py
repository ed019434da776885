"""Sources with phase, plane waves from a driven column, and barriers of pinned particles:
symmetry, uniformity and pinning checked against what the physics requires."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from app.cli.arguments import parse_overrides
from sim.model.lattice import ModelError
from sim.scenes import scene_files

STIFFNESS = 35.0


def displacement(simulation: sim.Simulation, component: int) -> np.ndarray:
    """(ny, nx) displacement of one component from rest (m)."""
    model = simulation.model
    shape = (model.ny, model.nx, model.dim)
    return (simulation.positions.reshape(shape)[..., component]
            - model.rest_positions.reshape(shape)[..., component])


def mirrored_sources(phase: float) -> sim.Simulation:
    """Two force sources along y on row 4, four columns either side of the middle column 10
    of a 21-column lattice (mirror-symmetric about column 10), the second with ``phase``."""
    source = dict(row=4, direction="y", amplitude=0.01, frequency=0.8, kind="force", ramp=1.0)
    model = sim.Model.create(21, 9, stiffness=STIFFNESS, rest_length=0.8, linear=True,
                             sources=[dict(source, column=6), dict(source, column=14, phase=phase)])
    return sim.Simulation(model, integrator="verlet", dt=0.01)


@pytest.mark.parametrize("phase, at_rest", [(math.pi, True), (0.0, False)])
def test_sources_in_antiphase_leave_the_mirror_line_at_rest(phase, at_rest):
    # mirror symmetry x -> -x keeps u_y: forces odd under it give u_y odd, zero on the line
    simulation = mirrored_sources(phase)
    largest = 0.0
    for _ in range(40):
        simulation.step(10)
        largest = max(largest, float(np.abs(displacement(simulation, 1)[:, 10]).max()))
    if at_rest:
        assert largest < 1e-12
    else:
        assert largest > 1e-3


def test_a_driven_column_makes_a_plane_wave():
    # u_z of a pre-tensioned membrane (speed sqrt(7) a/s): the front reaches column 10 at 3.8 s;
    # the disturbance from the fixed top and bottom edges spreads from the corners, so rows 16
    # and more from them are still untouched at 10 s; the right wall's echo returns at 26 s
    nx, ny = 40, 64
    source = dict(column=0, row="all", direction="z", amplitude=0.01, frequency=0.3, kind="force",
                  ramp=1.0)
    model = sim.Model.create(nx, ny, dim=3, stiffness=STIFFNESS, rest_length=0.8, linear=True,
                             sources=[source])
    simulation = sim.Simulation(model, integrator="verlet", dt=0.05)
    peak = np.zeros(ny)
    for _ in range(100):  # to 10 s
        simulation.step(2)
        peak = np.maximum(peak, np.abs(displacement(simulation, 2)[:, 10]))
    inner = peak[16:-16]
    assert inner.min() > 1e-3
    assert inner.max() / inner.min() < 1.1


def barrier_scene(boundary: str = "fixed") -> sim.Simulation:
    model = sim.Model.create(
        30, 15, stiffness=STIFFNESS, rest_length=0.8, linear=True,
        sources=[dict(column=2, row="all", direction="x", amplitude=0.02, frequency=0.6,
                      kind="force", ramp=1.0)],
        barriers=[{"column": 12, "openings": [[5, 9]]}],
    )
    return sim.Simulation(model, integrator="verlet", dt=0.02)


def test_a_barriers_pinned_particles_never_move_and_its_opening_passes_the_wave():
    simulation = barrier_scene()
    pinned_peak = 0.0
    open_peak = np.zeros(5)
    for _ in range(60):
        simulation.step(10)
        column = displacement(simulation, 0)[:, 12]
        across = displacement(simulation, 1)[:, 12]
        pinned = np.r_[column[:5], column[10:], across[:5], across[10:]]
        pinned_peak = max(pinned_peak, float(np.abs(pinned).max()))
        open_peak = np.maximum(open_peak, np.abs(column[5:10]))
    assert pinned_peak == 0.0
    assert open_peak.min() > 1e-3


@pytest.mark.parametrize("integrator", [pytest.param("rk4", marks=pytest.mark.slow), "verlet"])
def test_the_energy_balance_closes_with_sources_and_a_barrier(integrator):
    model = barrier_scene().model.replace(damping=0.1)
    simulation = sim.Simulation(model, integrator=integrator, dt=0.01)
    simulation.step(1500)
    energy = simulation.energy()
    assert energy.driven > 1e-3
    tolerance = 1e-6 if integrator == "rk4" else 2e-3
    assert abs(simulation.energy_balance_error()) < tolerance


def test_sources_and_barriers_round_trip_through_a_scene_file(tmp_path):
    scene = sim.scenes.build(
        "grid", nx=12, ny=8,
        sources=[dict(column=1, row="all", frequency=0.5, phase=1.5)],
        barriers=[{"column": 6, "openings": [[2, 3]]}],
    )
    loaded = scene_files.load(scene_files.save(scene, tmp_path / "slit.toml"))
    assert loaded.model.sources == scene.model.sources
    assert loaded.model.barriers == scene.model.barriers


def test_sources_from_the_command_line():
    overrides = parse_overrides(["sources=column=1,row=all,phase=3.14;column=5,row=2"])
    model = sim.scenes.build("grid", nx=10, ny=6, **overrides).model
    assert [source.row for source in model.sources] == ["all", 2]
    assert model.sources[0].phase == pytest.approx(3.14)


@pytest.mark.parametrize("parameters, message", [
    (dict(sources=[dict(column=40)]), "outside"),
    (dict(sources=[dict(phase="half")]), "phase"),
    (dict(sources=[dict(row="some")]), "row"),
    (dict(barriers=[{"column": 3, "row": 2}]), "exactly one"),
    (dict(barriers=[{"column": 3, "openings": [[4, 2]]}]), "ends before"),
    (dict(barriers=[{"column": 3, "openings": [[4, 20]]}]), "past the lattice"),
    (dict(barriers=[{"column": 3}], sources=[dict(column=3, row=1)]), "pinned"),
    (dict(driver=dict(row="all")), "sources"),
])
def test_bad_sources_and_barriers_are_refused_clearly(parameters, message):
    with pytest.raises(ModelError, match=message):
        sim.scenes.build("grid", nx=10, ny=6, **parameters)
