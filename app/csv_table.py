"""Series as a CSV table: a header row naming each quantity with its unit, one row a sample.

The page's plots (``app.web.folders``: energy, probes) and ``oscillators run --csv`` write their
series through ``csv_text``, so that a spreadsheet or ``numpy.loadtxt(..., delimiter=",",
skiprows=1)`` reads every one the same way.  Numbers keep nine significant figures.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence

ENERGY_COLUMNS = {"kinetic": "kinetic energy", "spring": "springs' potential energy",
                  "gravity": "gravity's potential energy", "total": "total energy",
                  "dissipated": "energy dissipated", "driven": "driver's work"}
"""The column of each term of the energy account (``sim.theory.observables.Energy``), in J."""


def header(name: str, unit: str) -> str:
    """A column's heading: ``kinetic energy (J)``; a quantity without a unit has none."""
    return f"{name} ({unit})" if unit else name


def csv_text(columns: Sequence[tuple[str, str]], rows: Iterable[Sequence[float]]) -> str:
    """The table of ``rows`` under ``columns`` ((name, unit) each) as CSV text."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([header(name, unit) for name, unit in columns])
    for row in rows:
        if len(row) != len(columns):
            raise ValueError(f"a row of {len(row)} values under {len(columns)} columns")
        writer.writerow([f"{float(value):.9g}" for value in row])
    return out.getvalue()
