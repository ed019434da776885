"""The ripple tank: presets built on the membrane's u_z, the intensity screen in recordings and
the ``slits`` command, and (slow) the double slit's fringes against the far-field theory with the
lattice's own wavelength."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import sim
from app.cli import main
from sim.scenes import ripple_tank, scene_files
from tests.test_recording import read_chunks, temporal
from tests.test_recording_instruments import tensor

PULL = 0.035
"""How far (a fraction of its distance from the axis) a measured double-slit maximum m = +-1 may lie
inside its far-field line: each slit's wave weakens away from the axis (cos(theta) / sqrt(r)),
which pulls the intensity maxima toward it (measured: 3 % at the preset's screen 105 m away)."""
MODEL_TOLERANCE = 0.5
"""How far (m, half a spacing) a measured maximum may lie from the maximum of the two-slit
intensity predicted from the dispersion relation (``sim.theory.slits.two_slit_intensity``)."""


@pytest.mark.parametrize("name", ["two-sources", "single-slit", "double-slit"])
def test_ripple_tank_presets_drive_the_membranes_u_z_behind_absorbing_walls(name):
    model = sim.scenes.build(name).model
    assert model.dim == 3 and model.walls.absorbing and model.sources
    assert all(source.direction == (0.0, 0.0, 1.0) for source in model.sources)
    wave = sim.theory.lattice_waves.polarisation(model, "z")
    along, across = wave.long_wave_speeds()
    assert along == pytest.approx(across)  # isotropic at long wavelengths
    # speed sqrt(T / (a m)), T = k (a - L): sqrt(35 * 0.2) m/s
    assert along == pytest.approx(math.sqrt(35.0 * (1.0 - 0.8)))


def test_slit_setup_reads_the_barrier_and_uses_the_lattices_wavelength():
    model = sim.scenes.build("double-slit").model
    setup = ripple_tank.SlitSetup.of(model)
    assert setup.centre == pytest.approx(0.0)
    low, high = (0.5 * sum(opening) for opening in setup.openings)
    assert high - low == pytest.approx(20.0)
    # the lattice's u_z dispersion: omega = 2 sqrt(T / (a m)) sin(q a / 2)
    omega = 2 * math.pi * setup.frequency
    q = 2 * math.asin(omega / (2 * math.sqrt(7.0)))
    assert setup.wavelength(model) == pytest.approx(2 * math.pi / q, rel=1e-9)
    assert setup.wavelength(model) < math.sqrt(7.0) / setup.frequency  # shorter than c / f
    maxima = {fringe.order: fringe.y for fringe in setup.theory(model, 164)}
    distance = 164 - 45

    def wavelength_along(angle: float) -> float:  # the same dispersion along a slanted line
        low, high = 0.0, math.pi
        for _ in range(200):
            middle = 0.5 * (low + high)
            value = 4 * 7.0 * (math.sin(middle * math.cos(angle) / 2) ** 2
                               + math.sin(middle * math.sin(angle) / 2) ** 2)
            low, high = (middle, high) if value < omega**2 else (low, middle)
        return 2 * math.pi / low

    # far field on the lattice: the two slits' phases differ by q . (0, d) = d q_y, with q the
    # wave vector whose group velocity ~ (sin q_x, sin q_y) (a = 1) points at the maximum
    low, high = 0.0, 1.2  # the angle of q where d q_y = 2 pi, by bisection
    for _ in range(200):
        phi = 0.5 * (low + high)
        qy = 2 * math.pi / wavelength_along(phi) * math.sin(phi)
        low, high = (phi, high) if 20.0 * qy < 2 * math.pi else (low, phi)
    q = 2 * math.pi / wavelength_along(phi)
    ray = math.atan2(math.sin(q * math.sin(phi)), math.sin(q * math.cos(phi)))
    assert ray > phi + math.radians(1.0)  # the ray leans off q by more than a degree
    assert maxima[1] == pytest.approx(distance * math.tan(ray), rel=1e-5)
    textbook = math.asin(wavelength_along(phi) / 20.0)  # d sin(theta) = lambda along q
    assert maxima[1] > 1.05 * distance * math.tan(textbook)
    assert maxima[-1] == pytest.approx(-maxima[1])


@pytest.fixture(scope="module")
def small_slits(tmp_path_factory) -> Path:
    """A 50x41 tank with two slits, saved as a scene file."""
    model = sim.Model.create(
        50, 41, dim=3, stiffness=35.0, rest_length=0.8, linear=True, boundary="absorbing",
        sponge_width=8,
        sources=[dict(column=10, row="all", direction="z", amplitude=0.01, frequency=0.33,
                      kind="force", ramp=2.0)],
        barriers=[{"column": 18, "openings": [[15, 17], [23, 25]]}],
    )
    scene = sim.Scene(name="small-slits", model=model, integrator="verlet", dt=0.05,
                      duration=30.0)
    return scene_files.save(scene, tmp_path_factory.mktemp("slits") / "small-slits.toml")


@pytest.mark.slow  # the recorder's compiled paths for a 3-D layer: about a minute cold
def test_a_recording_holds_the_intensity_screen(small_slits, tmp_path):
    path = tmp_path / "slits.rrd"
    assert main(["record", str(small_slits), "--duration", "30", "--every", "4", "--screen", "36",
                 "-o", str(path), "--quiet"]) == 0
    chunks = read_chunks(path)
    profiles = temporal(chunks, "/screen/intensity", "BarChart:values")
    assert len(profiles) >= 4
    last = tensor(profiles[max(profiles)])
    assert last.shape == (41,) and last.max() > 0
    # the tank is mirror-symmetric about its middle row
    np.testing.assert_allclose(last, last[::-1], rtol=1e-6, atol=1e-12 * last.max())
    rows = {chunk.entity_path for chunk in chunks if chunk.entity_path.startswith("/screen/rows/")}
    assert "/screen/rows/20" in rows  # m = 0


def test_a_screen_off_the_lattice_is_refused(small_slits, tmp_path, capsys):
    assert main(["record", str(small_slits), "--duration", "1", "--screen", "80",
                 "-o", str(tmp_path / "x.rrd"), "--quiet"]) == 2
    assert "screen" in capsys.readouterr().err


@pytest.mark.slow  # the screen recorder's compiled paths for a 3-D layer, as above
def test_the_slits_command_reports_the_fringes_and_draws_the_screen(small_slits, tmp_path,
                                                                    capsys):
    picture = tmp_path / "screen.png"
    assert main(["slits", str(small_slits), "--screen", "36", "--json", "--plot", str(picture),
                 "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {fringe["order"] for fringe in data["fringes"]} >= {0}
    central = next(fringe for fringe in data["fringes"] if fringe["order"] == 0)
    assert central["measured_y"] == pytest.approx(0.0, abs=1e-6)
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_slits_command_refuses_a_scene_without_slits(capsys):
    assert main(["slits", "grid", "--quiet", "--no-plot"]) == 2
    assert "barrier" in capsys.readouterr().err


@pytest.mark.slow
def test_double_slit_maxima_agree_with_the_lattice_theory():
    """The measured maxima m = 0, +-1 of the double-slit preset, 105 m beyond the slits: on the
    axis, just inside the far-field lines d q_y = 2 pi m (q the lattice's wave vector along each
    ray), and on the maxima of the intensity of two point sources with the lattice's ray phase
    and amplitude cos(theta) / sqrt(r).  The textbook line with lambda along theta, d sin(theta)
    = m lambda(theta), lies inside the measured maxima (q leans off the ray on the lattice)."""
    from app.study import slits as study

    scene = sim.scenes.build("double-slit")
    model = scene.model
    measurement = study.measure(scene, column=150)
    fringes = {fringe["order"]: fringe for fringe in measurement.fringes}
    assert {-1, 0, 1} <= set(fringes)
    assert fringes[0]["measured_y"] == pytest.approx(0.0, abs=0.1)
    setup = ripple_tank.SlitSetup.of(model)
    wave = sim.theory.lattice_waves.polarisation(model, "z")
    omega = 2 * math.pi * setup.frequency
    centres = tuple(0.5 * (low + high) for low, high in setup.openings)
    ys = np.linspace(-90.0, 90.0, 3601)
    predicted = sim.theory.slits.two_slit_intensity(wave, omega, centres, measurement.distance, ys)
    d = centres[1] - centres[0]
    for order in (-1, 1):
        fringe = fringes[order]
        measured, line = fringe["measured_y"], fringe["theory_y"]
        assert 0.0 <= (line - measured) * order <= PULL * abs(line), (order, measured, line)
        near = np.abs(ys - line) < 10.0
        model_maximum = ys[near][np.argmax(predicted[near])]
        assert measured == pytest.approx(model_maximum, abs=MODEL_TOLERANCE)
        textbook = math.asin(wave.wavelength(omega, math.asin(line / math.hypot(
            measurement.distance, line))) / d)
        assert abs(measured) > measurement.distance * math.tan(textbook) + 0.5


def test_barriers_from_the_command_line_and_one_line_errors(capsys):
    scene = sim.scenes.build(
        "double-slit", barriers="column=45,openings=89-91 109-111;column=150,openings=none")
    assert [barrier.as_table() for barrier in scene.model.barriers] == [
        {"column": 45, "openings": [[89, 91], [109, 111]]}, {"column": 150, "openings": []}]
    for text, said in (("column=45,openings=89-x", "opening end must be a whole number"),
                       ("column=4.5", "barrier column must be a whole number"),
                       ("colum=3", "unknown barrier field"),
                       ("column=45,openings=91-89", "ends before it starts"),
                       ("column=500", "outside the 190x201 lattice")):
        assert main(["run", "double-slit", "--set", f"barriers={text}", "--steps", "1"]) == 2
        error = capsys.readouterr().err.strip()
        assert said in error and "\n" not in error and "Traceback" not in error
