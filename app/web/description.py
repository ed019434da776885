"""The lattice described in words, for students who read the page with a screen reader or
cannot see the picture: what runs, where the largest motion is, where the energy is, and what
the followed particle does (``app.web.folders.description`` shows it about once a second)."""

from __future__ import annotations

import numpy as np

from sim.runtime.runner import Frame

_THIRDS = {"x": ("left", "centre", "right"), "y": ("bottom", "middle", "top")}


def _third(index: int, count: int, axis: str) -> str:
    """"left", "centre" or "right" (or bottom, middle, top) of ``index`` among ``count``."""
    return _THIRDS[axis][min(2, 3 * index // max(count, 1))]


def _length(metres: float) -> str:
    """A length in the unit that reads best: 3.2 mm, 0.12 m, 45 µm."""
    size = abs(metres)
    if size >= 0.1:
        return f"{metres:.2g} m"
    if size >= 1e-4:
        return f"{1e3 * metres:.2g} mm"
    return f"{1e6 * metres:.2g} µm"


def _particle(index: int, nx: int) -> str:
    return f"particle (column {index % nx}, row {index // nx})"


def describe(frame: Frame, followed: int | None = None) -> str:
    """A few sentences on ``frame``; ``followed`` the particle a student follows (a selected
    one), or None."""
    model = frame.model
    nx, ny = model.nx, model.ny
    state = "playing" if frame.playing else "paused"
    lines = [f"t = {frame.time:.4g} s, step {frame.step}, {state}; {frame.integrator} at "
             f"dt = {frame.dt:g} s. A lattice of {nx} × {ny} particles."]
    displacement = frame.positions - model.rest_positions
    size = np.sqrt((displacement**2).sum(axis=1))
    largest = int(np.argmax(size)) if size.size else 0
    if size.size and size[largest] > 0:
        column, row = largest % nx, largest // nx
        place = (_third(column, nx, "x") if ny == 1
                 else f"{_third(row, ny, 'y')} {_third(column, nx, 'x')}")
        lines.append(f"The largest motion is {_length(float(size[largest]))}, at "
                     f"{_particle(largest, nx)}, in the {place} of the lattice.")
    else:
        lines.append("Every particle is at rest in its place.")
    energy = frame.energy
    total = energy.kinetic + energy.potential
    if total > 0 and energy.potential >= 0:
        lines.append(f"Energy {total:.3g} J: {100 * energy.kinetic / total:.0f} % in motion, "
                     f"{100 * energy.potential / total:.0f} % stored in the springs"
                     + (" and gravity" if energy.gravity else "")
                     + f"; energy-balance error {100 * frame.energy_balance_error:+.2g} %.")
    else:
        lines.append(f"Energy in motion {energy.kinetic:.3g} J, stored {energy.potential:.3g} J; "
                     f"energy-balance error {100 * frame.energy_balance_error:+.2g} %.")
    if followed is not None and 0 <= followed < size.size:
        moved = displacement[followed]
        words = []
        for value, plus, minus in ((moved[0], "right", "left"), (moved[1], "up", "down")):
            if abs(value) > 1e-12:
                words.append(f"{_length(abs(float(value)))} {plus if value > 0 else minus}")
        where = " and ".join(words) if words else "exactly in its place"
        lines.append(f"You follow {_particle(followed, nx)}: {where}"
                     + (" of its place." if words else "."))
    return "\n".join(lines)
