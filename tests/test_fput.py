"""The FPUT lesson against an independent computation: the fput preset's first mode gives its
energy away and gets 98 % of it back near 153 of its periods, as a plain numpy velocity-Verlet
code of the FPU equations (written here) finds, and as Fermi, Pasta, Ulam and Tsingou saw."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import sim
from app.cli import main
from sim.instruments.mode_shares import ModeShares

N, ALPHA, DT = 32, 0.25, 0.05
SINES = np.sqrt(2 / (N + 1)) * np.sin(np.outer(np.arange(1, N + 1), np.arange(1, N + 1))
                                      * np.pi / (N + 1))
OMEGA = 2 * np.sin(np.arange(1, N + 1) * np.pi / (2 * (N + 1)))
PERIOD = 2 * np.pi / OMEGA[0]


def _numpy_fput(periods: float) -> tuple[np.ndarray, np.ndarray]:
    """(times in periods of mode 1, mode 1's share), sampled every 66 steps, of the FPU chain
    u_n'' = F(u_(n+1) - u_n) - F(u_n - u_(n-1)), F(s) = s + alpha s^2, u_0 = u_(N+1) = 0."""

    def acceleration(u):
        s = np.diff(np.concatenate([[0.0], u, [0.0]]))
        force = s + ALPHA * s * s
        return force[1:] - force[:-1]

    u = np.sin(np.arange(1, N + 1) * np.pi / (N + 1))
    v = np.zeros(N)
    a = acceleration(u)
    times, shares = [], []
    for step in range(1, math.ceil(periods * PERIOD / DT) + 1):
        v += 0.5 * DT * a
        u += DT * v
        a = acceleration(u)
        v += 0.5 * DT * a
        if step % 66 == 0:
            q, p = SINES @ u, SINES @ v
            energy = 0.5 * (p * p + OMEGA**2 * q * q)
            times.append(step * DT / PERIOD)
            shares.append(energy[0] / energy.sum())
    return np.array(times), np.array(shares)


def test_the_first_mode_comes_back_as_the_numpy_fpu_chain_says():
    simulation = sim.Simulation(sim.scenes.build("fput"))
    modes = ModeShares(simulation.model)
    assert modes.period == pytest.approx(PERIOD, rel=1e-12)  # 66.02 s
    while simulation.time < 160 * PERIOD:
        modes.add(simulation.time, simulation.state.particle_positions(),
                  simulation.state.particle_velocities())
        simulation.step(66)
    times, shares = _numpy_fput(160)
    window = (times > 120) & (times < 160)
    peak = np.argmax(shares[window])
    first = modes.recurrences()[0]
    assert first.periods == pytest.approx(times[window][peak], abs=0.1)
    assert first.share == pytest.approx(shares[window][peak], abs=2e-3)
    assert first.periods == pytest.approx(153.4, abs=0.5) and first.share > 0.975
    low_time, low_share = modes.lowest_share()
    assert low_share == pytest.approx(shares[times < 140].min(), abs=2e-3)
    assert 95 < low_time < 115 and low_share < 0.1
    assert abs(simulation.energy_balance_error()) < 1e-4


def test_run_reports_the_mode_energies_and_the_recurrence(capsys):
    assert main(["run", "fput", "--json", "--quiet"]) == 0
    report = json.loads(capsys.readouterr().out)["modes"]
    assert report["modes"] == list(range(1, 9))
    energies = np.array(report["mode_energies"])
    assert energies.shape == (len(report["times"]), 8)
    assert energies[0, 0] / report["harmonic_energy"][0] > 0.999  # all of it in mode 1
    assert report["first_recurrence"]["periods"] == pytest.approx(153.4, abs=0.5)
    assert main(["run", "grid", "--modes", "4", "--steps", "1", "--quiet"]) == 2
    assert "one-row chain" in capsys.readouterr().err
