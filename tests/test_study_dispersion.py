"""Continuum limit: wave speed and dispersion measured from simulated chains against theory."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.study import dispersion

STIFFNESS = 35.0
MASS = 1.0


@pytest.fixture(scope="module")
def study():
    return dispersion.dispersion_study(particles=150, stiffness=STIFFNESS, mass=MASS, heavy=4.0,
                                       duration=100.0)


def test_long_wavelength_pulse_travels_at_a_sqrt_k_over_m():
    speed = dispersion.measure_wave_speed(800, STIFFNESS, MASS, width=10.0)
    assert abs(speed / math.sqrt(STIFFNESS / MASS) - 1) < 0.01


def test_pulse_speed_scales_with_sqrt_of_stiffness():
    # four times stiffer: twice as fast (the measurement does not just return its guess)
    speed = dispersion.measure_wave_speed(800, 4 * STIFFNESS, MASS, width=10.0)
    assert abs(speed / (2 * math.sqrt(STIFFNESS / MASS)) - 1) < 0.01


def test_dispersion_relation_at_three_wavenumbers(study):
    rows = study.checkpoints((0.25, 0.5, 0.75))
    for row in rows:
        assert abs(row["relative_error"]) < 0.01, row
    # and the lattice is dispersive: at q a = 3 pi / 4 the continuum line is far off
    assert rows[-1]["continuum"] / rows[-1]["measured"] - 1 > 0.2


def test_every_resolved_wavenumber_follows_the_discrete_relation(study):
    spectrum = study.monatomic
    theory = dispersion.discrete_frequency(spectrum.q, STIFFNESS, MASS)
    resolved = spectrum.q / math.pi > 0.1
    assert np.abs(spectrum.measured[resolved] / theory[resolved] - 1).max() < 0.01


def test_ionic_chain_has_the_gap_between_the_branches(study):
    lower, upper = study.gap_measured
    assert abs(lower / math.sqrt(2 * STIFFNESS / 4.0) - 1) < 0.01
    assert abs(upper / math.sqrt(2 * STIFFNESS / MASS) - 1) < 0.01
    top_optical = math.sqrt(2 * STIFFNESS * (1 / MASS + 1 / 4.0))
    assert abs(study.ionic.measured.max() / top_optical - 1) < 0.01


def test_cli_dispersion_json(capsys):
    import json

    from app.cli import main

    assert main(["dispersion", "--particles", "80", "--json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert abs(data["wave_speed_relative_error"]) < 0.01
