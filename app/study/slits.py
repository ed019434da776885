"""Slit experiments measured: run a scene with a slit barrier (presets single-slit and
double-slit, or any scene with a column barrier and a source), record the intensity screen
(``sim.instruments.screen.IntensityScreen``: <u^2> over whole periods along a column) and set the measured
fringes beside the far-field theory lines (``sim.scenes.ripple_tank.SlitSetup``: lambda from the
lattice's own dispersion relation at the driving frequency).

``measure(scene, ...)`` returns a ``SlitMeasurement``; ``plot(measurement, path)`` draws the
screen (intensity against y, m) with the theory lines as a PNG.
"""

from __future__ import annotations

import dataclasses
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import sim
from sim.instruments.screen import IntensityScreen
from sim.scenes import ripple_tank

PERIODS = 4
"""Whole periods the screen averages over."""


@dataclasses.dataclass(frozen=True)
class SlitMeasurement:
    """The screen at the end of a run and the fringes: ``y`` (ny,) m and ``intensity`` (ny,)
    m^2 along ``column``; ``fringes`` one dict per theory line (order, kind, theory y,
    measured y or None, difference in m); ``wavelength`` (m, the lattice's) and
    ``continuum_wavelength`` (m, c / f with the long-wave speed) and ``distance`` barrier to
    screen (m); ``field`` (ny, nx) the displacement component at the end (m), ``barrier_x``
    and ``screen_x`` (m), ``extent`` (x0, x1, y0, y1) of the lattice (m)."""

    scene: str
    column: int
    time: float
    y: np.ndarray
    intensity: np.ndarray
    fringes: list[dict[str, Any]]
    wavelength: float
    continuum_wavelength: float
    distance: float
    field: np.ndarray
    barrier_x: float
    screen_x: float
    extent: tuple[float, float, float, float]
    centre: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene, "screen_column": self.column, "time": self.time,
            "wavelength": self.wavelength, "continuum_wavelength": self.continuum_wavelength,
            "distance": self.distance, "fringes": self.fringes,
            "y": self.y.tolist(), "intensity": self.intensity.tolist(),
        }


def measure(scene: sim.Scene, *, column: int | None = None, duration: float | None = None,
            integrator: str | None = None, dt: float | None = None,
            progress: Any = None) -> SlitMeasurement:
    """Run ``scene`` (with ``integrator`` and ``dt`` if given) for ``duration`` s (default: the
    scene's) with a screen at ``column`` (default: just inside the right wall's layer) and
    compare its fringes with the theory; ``progress(fraction)`` is called as it runs.
    Raises ``ripple_tank.SlitError`` or ``ValueError`` on a scene without slits."""
    model = scene.model
    setup = ripple_tank.SlitSetup.of(model)
    column = ripple_tank.default_screen_column(model) if column is None else int(column)
    fringes = setup.theory(model, column)
    period = 1.0 / setup.frequency
    screen = IntensityScreen(model, column, setup.component, period, periods=PERIODS)
    simulation = sim.Simulation(scene, integrator=integrator, dt=dt)
    duration = scene.duration if duration is None else float(duration)
    steps_per_look = max(1, int(period / simulation.dt / 16))
    while simulation.time < duration:
        simulation.step(steps_per_look)
        screen.observe(simulation.time, simulation.positions)
        if progress is not None:
            progress(min(1.0, simulation.time / duration))
    intensity = screen.intensity
    if intensity is None:
        raise ValueError(f"the run of {duration:g} s is shorter than one period ({period:g} s)")
    y = np.asarray(model.rest_positions[screen.rows, 1])
    rows = compare(y, intensity, fringes, model)
    wave = sim.theory.lattice_waves.polarisation(model, setup.component)
    speed = wave.long_wave_speeds()[0]
    x0, y0 = model.origin
    component = "xyz".index(setup.component)
    shape = (model.ny, model.nx, model.dim)
    field = (simulation.positions.reshape(shape)[..., component]
             - model.rest_positions.reshape(shape)[..., component])
    screen_x = x0 + column * model.spacing
    extent = (x0, x0 + (model.nx - 1) * model.spacing, y0, y0 + (model.ny - 1) * model.spacing)
    return SlitMeasurement(scene.name, column, simulation.time, y, intensity, rows,
                           setup.wavelength(model), speed / setup.frequency,
                           screen_x - setup.barrier_x, np.array(field), setup.barrier_x, screen_x,
                           extent, setup.centre)


def compare(y: np.ndarray, intensity: np.ndarray, fringes: list, model: Any
            ) -> list[dict[str, Any]]:
    """One dict per theory fringe (``sim.theory.slits.Fringe``): order, kind, theory y, the measured y
    of the intensity's extremum within 0.3 fringe spacings of it (None if there is none inside)
    and their difference (m); ``y`` (ny,) m and ``intensity`` (ny,) along the screen."""
    spacing = _fringe_spacing(fringes, model)
    rows = []
    for fringe in fringes:
        found = _extremum(y, intensity, fringe.y, 0.3 * spacing, fringe.kind)
        rows.append({"order": fringe.order, "kind": fringe.kind, "theory_y": fringe.y,
                     "measured_y": found,
                     "difference": None if found is None else found - fringe.y})
    return rows


def _fringe_spacing(fringes: list, model: Any) -> float:
    ys = sorted(fringe.y for fringe in fringes)
    gaps = np.diff(ys)
    return float(gaps.min()) if gaps.size else model.ny * model.spacing


def _extremum(y: np.ndarray, intensity: np.ndarray, near: float, reach: float,
              kind: str) -> float | None:
    """y (m) of the largest (kind "maximum") or smallest intensity within ``reach`` of ``near``,
    refined by a parabola through it and its neighbours; None if it lies on the window's edge
    (no extremum inside)."""
    inside = np.flatnonzero(np.abs(y - near) <= reach)
    if inside.size < 3:
        return None
    values = intensity[inside] if kind == "maximum" else -intensity[inside]
    best = int(np.argmax(values))
    if best in (0, inside.size - 1):
        return None
    k = inside[best]
    a, b, c = intensity[k - 1], intensity[k], intensity[k + 1]
    curvature = a - 2.0 * b + c
    offset = 0.5 * (a - c) / curvature if curvature != 0.0 else 0.0
    return float(y[k] + offset * (y[k + 1] - y[k]))


def plot(measurement: SlitMeasurement, path: str | Path) -> Path:
    """A PNG at ``path``: left, the wave field at the end (colour: displacement) with the
    barrier, the screen and the theory rays from the slits' centre; right, the screen's
    intensity (relative to its peak) against y with the theory lines dashed and the measured
    fringes as dots."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    m = measurement
    figure, (left, right) = plt.subplots(1, 2, figsize=(11.0, 5.0), dpi=100,
                                         gridspec_kw={"width_ratios": [1.25, 1.0]})
    limit = float(np.abs(m.field).max()) or 1.0
    left.imshow(m.field, origin="lower", extent=m.extent, cmap="RdBu_r", vmin=-limit, vmax=limit,
                interpolation="nearest")
    left.axvline(m.barrier_x, color="black", lw=1.0)
    left.axvline(m.screen_x, color="#2e7d32", lw=1.5, label="screen")
    for fringe in m.fringes:
        colour = "#c0392b" if fringe["kind"] == "maximum" else "#7d3c98"
        left.plot([m.barrier_x, m.screen_x], [m.centre, fringe["theory_y"]], color=colour,
                  ls="--", lw=1.0)
    left.set_xlim(m.extent[0], m.extent[1])
    left.set_ylim(m.extent[2], m.extent[3])
    left.set_xlabel("x (m)")
    left.set_ylabel("y (m)")
    left.set_title(f"{m.scene} at t = {m.time:.0f} s (colour: displacement)", fontsize=9)
    left.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16))

    peak = float(m.intensity.max()) or 1.0
    right.plot(m.y, m.intensity / peak, color="#1f4e79", lw=1.8,
               label="measured <u²> (whole periods)")
    for index, fringe in enumerate(m.fringes):
        colour = "#c0392b" if fringe["kind"] == "maximum" else "#7d3c98"
        right.axvline(fringe["theory_y"], color=colour, ls="--", lw=1.2,
                      label=f"theory {fringe['kind']} (lattice λ)" if index == 0 else None)
        right.text(fringe["theory_y"], 1.04, f"m={fringe['order']}", ha="center", fontsize=8,
                   backgroundcolor="white")
        if fringe["measured_y"] is not None:
            at = int(np.argmin(np.abs(m.y - fringe["measured_y"])))
            right.plot([fringe["measured_y"]], [m.intensity[at] / peak], "o", color=colour, ms=5)
    right.set_xlabel("y along the screen (m)")
    right.set_ylabel("intensity / peak")
    right.set_ylim(0, 1.12)
    right.set_title(f"screen {m.distance:.0f} m beyond the barrier; λ = {m.wavelength:.2f} m "
                    f"(continuum c/f = {m.continuum_wavelength:.2f} m)", fontsize=9)
    right.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    figure.tight_layout()
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as stream:
            figure.savefig(stream, format="png")
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
    finally:
        plt.close(figure)
    return path


def format_report(measurement: SlitMeasurement) -> str:
    """The fringes as a table: order, kind, theory and measured y (m) and their difference."""
    lines = [
        f"{measurement.scene}: screen at column {measurement.column}, "
        f"{measurement.distance:g} m beyond the barrier, t = {measurement.time:.4g} s",
        f"wavelength from the lattice's dispersion: {measurement.wavelength:.4g} m "
        f"(continuum c / f: {measurement.continuum_wavelength:.4g} m)",
        f"{'m':>3s} {'kind':8s} {'theory y (m)':>13s} {'measured y (m)':>15s} {'diff (m)':>9s}",
    ]
    for fringe in measurement.fringes:
        measured = fringe["measured_y"]
        lines.append(
            f"{fringe['order']:3d} {fringe['kind']:8s} {fringe['theory_y']:13.3f} "
            + (f"{measured:15.3f} {fringe['difference']:9.3f}" if measured is not None
               else f"{'not found':>15s} {'':>9s}"))
    return "\n".join(lines)
