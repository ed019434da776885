"""Every blow-up is caught: from a start at rest (0 J, a lattice that only sags under gravity),
an unstable step stops the run with one line naming the integrator, dt, time and stability
limit, and the CLI exits 3; a run whose energy grows a thousandfold is not a result."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sim
from app.study.stability import whole_run_trial
from sim.runtime.blowup import BlowUpRule
from sim.scenes import run_limits

ROOT = Path(__file__).resolve().parents[1]


def _cli(*arguments: str) -> subprocess.CompletedProcess:
    environment = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run(
        [sys.executable, "-m", "app.cli", *arguments], capture_output=True, text=True,
        cwd=ROOT, env=environment, timeout=300,
    )


def test_catenary_just_past_the_verlet_limit_exits_3_with_the_reason() -> None:
    limit = sim.Simulation(sim.scenes.build("catenary"), integrator="verlet").stable_dt()
    dt = 1.01 * limit
    result = _cli("run", "catenary", "--integrator", "verlet", "--dt", repr(dt), "--quiet")
    assert result.returncode == 3, result.stdout + result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("stopped: ")
    message = lines[0]
    assert "Verlet" in message and f"dt = {dt:.6g} s" in message
    assert "t = " in message and f"stability limit is dt = {limit:.6g} s" in message


@pytest.mark.parametrize("dt", [0.060, 0.061])
def test_catenary_just_below_its_sagging_limit_exits_3_and_names_the_small_amplitude_limit(
        dt: float) -> None:
    """The sagging catenary's Verlet limit (0.06195 s, measured) is below the small-amplitude
    theory's (0.0904 s): at 0.97 and 0.98 of it a high mode grows until the dashpots pour its
    energy away as fast as it comes, the motion stays small and the dissipated energy climbs
    far past what gravity released."""
    limit = sim.Simulation(sim.scenes.build("catenary"), integrator="verlet").stable_dt()
    assert dt < limit
    result = _cli("run", "catenary", "--integrator", "verlet", "--dt", repr(dt), "--quiet")
    assert result.returncode == 3, result.stdout + result.stderr
    message = result.stderr.strip()
    assert "the energy ran away" in message, message
    assert f"small-amplitude stability limit is dt = {limit:.6g} s, above this dt" in message
    measured = run_limits.MEASURED[("catenary", "verlet")]
    assert f"catenary preset's own run was measured to run to its end up to dt = {measured:.4g} s" \
        in message


def test_a_thousandfold_energy_gain_is_a_blow_up_and_json_stays_one_document() -> None:
    result = _cli("run", "grid", "--integrator", "heun", "--dt", "0.05", "--quiet", "--json")
    assert result.returncode == 3
    summary = json.loads(result.stdout)  # nothing but the document on stdout
    assert "blew up" in summary["blew_up"]
    start, end = summary["energy_start"]["total"], summary["energy_end"]["total"]
    assert end < 1000 * start  # stopped well before the energy was off by a factor of 1000


def test_the_exact_supply_of_a_sagging_damped_lattice_is_never_exceeded() -> None:
    """From rest under gravity with dashpots, the energy of motion plus the dissipated energy
    equals the gravitational energy released (energy balance), so a stable run never trips the
    rule; the same run with the gravity's release ignored would have."""
    scene = sim.scenes.build("catenary", nx=6, ny=4)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.01)
    start = simulation.energy()
    assert start.kinetic == 0.0 and start.spring == 0.0
    rule = BlowUpRule.starting_from(scene.model, start)
    simulation.step(500)
    energy = simulation.energy()
    spent = energy.kinetic + energy.spring + energy.dissipated
    released = start.gravity - energy.gravity
    assert spent == pytest.approx(released, rel=1e-6)
    assert rule.problem(scene.model, simulation.state, energy) is None
    assert spent > 100 * rule.floor


def test_a_particle_far_beyond_the_lattice_is_a_blow_up() -> None:
    simulation = sim.Simulation(sim.scenes.build("chain"), integrator="verlet", dt=0.01)
    simulation.step(10)
    rule = BlowUpRule.starting_from(simulation.model, simulation.energy())
    state = simulation.state.copy()
    assert rule.problem(simulation.model, state, simulation.energy()) is None
    state.positions[1, 0, 2] += 20 * 6 * simulation.model.spacing  # 20 chain lengths away
    assert "from its rest position" in rule.problem(simulation.model, state, simulation.energy())
    state.velocities[0, 0, 0] = np.nan
    assert "NaN" in rule.problem(simulation.model, state, simulation.energy())


def test_a_recording_from_a_zero_joule_start_ends_with_the_blow_up(tmp_path: Path) -> None:
    from app.recording import Recorder
    from sim.runtime.runner import Runner
    from tests.test_recording import read_chunks, temporal, texts

    scene = sim.scenes.build("catenary")
    limit = sim.Simulation(scene, integrator="verlet").stable_dt()
    simulation = sim.Simulation(scene, integrator="verlet", dt=1.01 * limit)
    runner = Runner(simulation)
    path = tmp_path / "catenary.rrd"
    with pytest.raises(sim.BlowUpError):
        with Recorder(path, scene) as recorder:
            recorder.attach(runner)
            runner.advance(400, every=5)
    chunks = read_chunks(path)
    errors = [entry for entry in texts(chunks, "/log") if entry[2] == "ERROR"]
    assert len(errors) == 1 and "blew up" in errors[0][1] and "stability limit" in errors[0][1]
    assert max(temporal(chunks, "/energy/total", "Scalars:scalars")) <= errors[0][0]
    assert max(entry[0] for entry in texts(chunks, "/log")) == errors[0][0]


@pytest.mark.slow  # a long free-row run on its own kernels (a minute on a cold cache)
def test_a_pre_stretched_free_row_releases_exactly_its_stretch_energy_and_is_not_a_blow_up() -> None:
    """A chain of springs pre-stretched to a = 2 L with free ends contracts when let go: its
    spring energy falls below the rest lattice's, at most by what the row's nx - 1 springs store
    there, 1/2 k (a - L)^2 each (all of it only if every one were back at its rest length L), and
    the energy balance K + spring + dissipated stays at its start.  Counted from that lowest
    value, the rule's supply is exactly what the run spends."""
    scene = sim.scenes.build("chain", boundary="free", rest_length=0.5)
    model = scene.model
    release = 0.5 * model.stiffness * (model.spacing - model.rest_length) ** 2 * (model.nx - 1)
    simulation = sim.Simulation(scene, integrator="rk4", dt=0.002)
    start = simulation.energy()
    rule = BlowUpRule.starting_from(model, start)
    assert rule.release == pytest.approx(release, rel=1e-12)
    lowest = 0.0
    for _ in range(40):
        simulation.step(250)
        energy = simulation.energy()
        lowest = min(lowest, energy.spring)
        spent = energy.kinetic + energy.spring + rule.release + energy.dissipated
        assert spent == pytest.approx(rule.supply(energy), rel=1e-6)
        assert rule.problem(model, simulation.state, energy) is None
    assert -release <= lowest < -0.2 * release  # it did contract, never below the bound


@pytest.mark.slow  # every driven preset one step at a time over its run
def test_a_driven_lattice_from_rest_stepped_one_step_at_a_time_is_not_a_blow_up() -> None:
    """From 0 J the driver's work is the whole supply; seen after every single step (the page's
    slowest pace) the motion never outruns the work counted for it by more than the factor of
    about 2 of one step's bookkeeping, inside the rule's factor of 10."""
    for name in ("resonance", "bandgap"):
        scene = sim.scenes.build(name)
        for integrator in ("verlet", "rk4", "heun"):
            simulation = sim.Simulation(scene, integrator=integrator, dt=scene.dt)
            rule = BlowUpRule.starting_from(scene.model, simulation.energy())
            assert rule.floor < 1e-2  # the round-off floor only: no allowance for the driver
            for _ in range(200):
                simulation.step(1)  # raises BlowUpError if the rule trips
            energy = simulation.energy()
            spent = energy.kinetic + energy.spring + energy.dissipated
            assert 0 < spent <= 3 * rule.supply(energy)


@pytest.mark.parametrize("dim, precision", [(2, np.float64), (3, np.float32)])
def test_the_largest_displacement_is_the_farthest_coordinate_from_rest(dim, precision):
    from sim.runtime.blowup import largest_displacement

    model = sim.scenes.build("grid", nx=7, ny=5, dim=dim).model
    rest = model.rest_positions.T.reshape(dim, model.ny, model.nx)
    state = sim.Simulation(model, precision=np.dtype(precision).name).state
    generator = np.random.default_rng(3)
    state.positions[...] = rest + generator.normal(0.0, 0.1, rest.shape)
    state.positions[dim - 1, 3, 4] = rest[dim - 1, 3, 4] - 2.5  # the farthest, below its rest
    expected = np.abs(state.positions.astype(np.float64) - rest).max()
    assert expected == pytest.approx(2.5, rel=1e-6)
    assert largest_displacement(model, state) == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize(("preset", "integrator"), sorted(run_limits.MEASURED))
def test_each_measured_run_limit_is_where_the_preset_s_own_run_starts_to_stop(
        preset: str, integrator: str) -> None:
    """The table's limit is an edge of the preset's own run: a little below it the run goes to
    its end, a little above it stops (the blow-up rule), and it is below the small-amplitude
    theory's limit (else it would not be listed)."""
    scene = sim.scenes.build(preset)
    measured = run_limits.MEASURED[(preset, integrator)]
    assert measured < 0.98 * sim.Simulation(scene).stable_dt(integrator)
    assert whole_run_trial(scene, integrator, 0.98 * measured).stable
    assert not whole_run_trial(scene, integrator, 1.05 * measured).stable


def test_the_measured_run_limit_is_said_only_for_the_preset_as_built() -> None:
    limit = sim.Simulation(sim.scenes.build("catenary"), integrator="verlet").stability()
    assert limit.run_dt == run_limits.MEASURED[("catenary", "verlet")]
    assert "catenary preset's own run was measured" in limit.reason
    changed = sim.Simulation(sim.scenes.build("catenary", stiffness=36.0), integrator="verlet")
    assert changed.stability().run_dt is None
    assert "measured" not in changed.stability().reason
