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
