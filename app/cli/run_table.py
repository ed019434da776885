"""``oscillators run --csv``: the run's energy account, its energy-balance error and the probes'
displacements at every sample time, written at the end as one CSV table (``app.csv_table``: each
column's quantity and unit in its header), atomically, where the user said."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from app.cli.arguments import check_output_file
from app.csv_table import ENERGY_COLUMNS, csv_text

COMPONENTS = "xyz"


class RunTable:
    """Rows of the run's series; ``path`` checked before the run (an existing file only with
    ``force``), written by ``write``."""

    def __init__(self, path: str, force: bool, simulation: Any,
                 particles: list[int] | None = None) -> None:
        self.path, self.force = Path(path), force
        if self.path.suffix.lower() != ".csv":
            raise ValueError(f"--csv {path}: give a file name ending in .csv")
        check_output_file(self.path, force, ".csv")
        self.model = simulation.model
        self.particles = particles or []
        nx, dim = self.model.nx, self.model.dim
        self.columns = [("simulated time t", "s")] + [(name, "J")
                                                      for name in ENERGY_COLUMNS.values()]
        self.columns.append(("energy-balance error", ""))
        self.columns += [(f"probe (column {p % nx}, row {p // nx}) displacement "
                          f"{COMPONENTS[c]}", "m") for p in self.particles for c in range(dim)]
        self.rows: list[list[float]] = []
        self.add(simulation)

    def add(self, simulation: Any) -> None:
        """A row of the state ``simulation`` is in now."""
        energy = simulation.energy()
        row = [simulation.time, *(energy[term] for term in ENERGY_COLUMNS),
               simulation.energy_balance_error()]
        if self.particles:
            displacement = (simulation.state.particle_positions()[self.particles]
                            - self.model.rest_positions[self.particles])
            row += [float(value) for value in displacement.ravel()]
        self.rows.append(row)

    def write(self) -> str:
        """Write the table; returns its path."""
        from sim.storage.files import write_bytes

        return str(write_bytes(self.path, csv_text(self.columns, self.rows).encode(),
                               overwrite=self.force).resolve())
