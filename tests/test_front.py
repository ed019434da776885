"""When the sources' wave has reached a column (``sim.theory.front``), against the chain's analytic
group velocity: omega = 2 sqrt(k/m) sin(q a / 2), so d omega / dq = a sqrt(k/m) cos(q a / 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import sim
from sim.theory import lattice_waves
from sim.theory.front import arrival_times


def group_speed_along_x(model: sim.Model, frequency: float) -> float:
    wave = lattice_waves.polarisation(model, "z")
    k, m, a = wave.across_columns, wave.mass, wave.spacing
    q = 2.0 / a * math.asin(2 * math.pi * frequency / (2 * math.sqrt(k / m)))
    return a * math.sqrt(k / m) * math.cos(q * a / 2)


def test_a_plane_wave_reaches_every_row_of_a_column_after_its_distance_over_the_group_speed():
    model = sim.scenes.build("double-slit", nx=60, ny=41, sponge_width=6, barriers=[]).model
    source = model.sources[0]
    speed = group_speed_along_x(model, source.frequency)
    times = arrival_times(model, 50)
    expected = source.start + source.ramp + (50 - source.column) * model.spacing / speed
    assert times.shape == (model.ny,)
    assert times == pytest.approx(np.full(model.ny, expected), rel=1e-3)
    # slower than the long-wave speed a sqrt(k / m): the lattice is dispersive
    assert speed < lattice_waves.polarisation(model, "z").long_wave_speeds()[0]


def test_through_slits_the_rows_off_the_axis_are_reached_later_by_the_longer_path():
    model = sim.scenes.build("double-slit", nx=60, ny=41, sponge_width=6,
                             barriers=[{"column": 30, "openings": [[18, 22]]}]).model
    source = model.sources[0]
    speed = group_speed_along_x(model, source.frequency)
    times = arrival_times(model, 50)
    # the row of the slit's centre: straight along x all the way
    straight = source.start + source.ramp + (50 - source.column) * model.spacing / speed
    assert times[20] == pytest.approx(straight, rel=1e-3)
    assert np.all(times >= times[20] - 1e-9)
    assert times[0] > times[10] > times[20]  # farther rows later
    assert times[0] == pytest.approx(times[40], rel=1e-9)  # symmetric about the slit


def test_no_source_no_arrival():
    assert arrival_times(sim.scenes.build("grid", nx=5, ny=4).model, 2) is None
