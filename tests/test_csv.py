"""Series out as CSV: the page's energy plot downloads as a table with each column's quantity
and unit, and `oscillators run --csv` writes the run's energy account and probes the same way;
the numbers are the run's own (the total is the kinetic plus the potential energy, the probe's
last displacement is the state's)."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from app.cli import main
from tests.helpers import wait_for
from tests.test_web_safety import PageClient, press


def test_the_energy_plot_downloads_as_csv_with_units(web_app):
    web_app.runner.play()
    folder = web_app.panel.folders["energy"]
    assert wait_for(lambda: len(folder.history) >= 5, timeout=60)
    web_app.runner.pause()
    client = PageClient()
    press(folder.download, client)
    (name, content), = client.downloads
    assert name == "grid-energy.csv"
    lines = content.decode().splitlines()
    assert lines[0] == ("simulated time t (s),kinetic energy (J),springs' potential energy (J),"
                        "total energy (J),energy dissipated (J)")
    table = np.loadtxt(lines[1:], delimiter=",")
    assert table.shape[1] == 5 and np.all(np.diff(table[:, 0]) > 0)
    assert np.allclose(table[:, 1] + table[:, 2], table[:, 3], rtol=1e-8)  # kinetic + springs


def test_oscillators_run_writes_its_series_as_csv(tmp_path, capsys):
    path = tmp_path / "chain.csv"
    assert main(["run", "chain", "--set", "linear=true", "--steps", "300", "--probe", "2,0",
                 "--csv", str(path), "--quiet", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    lines = path.read_text().splitlines()
    header = next(csv.reader(lines[:1]))  # a heading with a comma is quoted
    assert header[:3] == ["simulated time t (s)", "kinetic energy (J)",
                          "springs' potential energy (J)"]
    assert header[-2:] == ["probe (column 2, row 0) displacement x (m)",
                           "probe (column 2, row 0) displacement y (m)"]
    table = np.loadtxt(lines[1:], delimiter=",")
    assert table[0, 0] == 0.0 and table[-1, 0] == pytest.approx(summary["time"])
    energy = dict(zip(header, table[-1], strict=True))
    assert energy["kinetic energy (J)"] == pytest.approx(summary["energy_end"]["kinetic"], rel=1e-8)
    assert energy["energy-balance error"] == pytest.approx(summary["energy_balance_error"],
                                                           rel=1e-6, abs=1e-12)
    # refused up front: an existing file without --force, a name that is not .csv
    assert main(["run", "chain", "--steps", "10", "--csv", str(path), "--quiet"]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["run", "chain", "--steps", "10", "--csv", str(tmp_path / "x.txt"),
                 "--quiet"]) == 2
    assert "ending in .csv" in capsys.readouterr().err


def test_the_accuracy_and_probe_plots_download_as_csv(web_app):
    probes, accuracy = web_app.panel.folders["probes"], web_app.panel.folders["accuracy"]
    model = web_app.runner.simulation.model  # 11 x 7
    probes.start([3 * model.nx + 5, 3])
    web_app.runner.play()
    assert wait_for(lambda: probes.series is not None and len(probes.series.times) >= 40,
                    timeout=60)
    web_app.runner.pause()
    client = PageClient()
    for button in (accuracy.download, probes.series_download, probes.spectrum_download):
        press(button, client)
    names = [name for name, _ in client.downloads]
    assert names == ["grid-energy-balance-error.csv", "grid-probes.csv", "grid-probe-spectra.csv"]
    tables = {name: content.decode().splitlines() for name, content in client.downloads}
    assert tables["grid-energy-balance-error.csv"][0] == \
        "simulated time t (s),energy-balance error"
    series = tables["grid-probes.csv"]
    header = next(csv.reader(series[:1]))
    assert header[1:3] == ["probe 1 (column 5, row 3) displacement x (m)",
                           "probe 1 (column 5, row 3) displacement y (m)"]
    values = np.loadtxt(series[1:], delimiter=",")
    last = probes.series.samples()[1][values.shape[0] - 1]
    assert values[-1, 1:] == pytest.approx(last.ravel(), rel=1e-8, abs=1e-15)
    spectra = tables["grid-probe-spectra.csv"]
    assert next(csv.reader(spectra[:1]))[0] == "frequency f (Hz)"
    assert np.loadtxt(spectra[1:], delimiter=",").shape[1] == 3  # frequency, two probes


def test_the_mode_energies_download_as_csv(web_app):
    modes = web_app.panel.folders["spectrum"]
    web_app.runner.play()
    assert wait_for(lambda: web_app.runner.simulation.time > 0.2, timeout=60)
    web_app.runner.pause()
    modes._draw(None)  # the folder's picture (drawn about once a second while playing)
    client = PageClient()
    press(modes.download, client)
    (name, content), = client.downloads
    lines = content.decode().splitlines()
    assert name == "grid-mode-energies.csv"
    assert next(csv.reader(lines[:1])) == ["polarisation (0 x, 1 y, 2 z)", "mode m", "mode n",
                                           "frequency f (Hz)", "energy (J)"]
    table = np.loadtxt(lines[1:], delimiter=",")
    model = web_app.runner.simulation.model  # 11 x 7, k = 35 N/m, m = 1 kg, L = a: no tension
    assert table.shape[0] == 2 * model.nx * model.ny
    along_x = table[table[:, 0] == 0]
    expected = np.sqrt(4 * 35.0 * np.sin(along_x[:, 1] * np.pi / (2 * (model.nx + 1))) ** 2)
    assert along_x[:, 3] == pytest.approx(expected / (2 * np.pi), rel=1e-8)  # 9 figures
    assert np.all(table[:, 4] >= 0) and table[:, 4].sum() > 0


def test_the_dispersion_plot_downloads_as_csv(web_app):
    folder = web_app.panel.folders["dispersion"]
    assert folder.plot is not None
    client = PageClient()
    press(folder.download, client)
    (name, content), = client.downloads
    lines = content.decode().splitlines()
    header = next(csv.reader(lines[:1]))
    assert name == "grid-dispersion.csv" and header[0].endswith("(π/a)")
    assert "x ω (rad/s)" in header and "y ω (rad/s)" in header
    table = np.loadtxt(lines[1:], delimiter=",")
    labels = [series["label"] for series in folder.plot.series]
    plotted = np.asarray(folder.plot.data[labels.index("x")])
    assert table[:, header.index("x ω (rad/s)")] == pytest.approx(plotted, rel=1e-8, abs=1e-12)
