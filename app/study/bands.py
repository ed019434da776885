"""The band structure of a scene as a report and a picture (``oscillators dispersion SCENE``):
every branch along Gamma-X-M-Gamma (``sim.theory.bands``), its continuum line and what the
scene's integrator at its time step makes of it.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

import sim
from sim.integrators.registry import describe
from sim.theory.bands import BandStructure, NumericalDispersion, PathBands, numerical_omegas

COLOURS = ("tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown")
"""One colour per branch (its band, continuum and numerical lines share it)."""


@dataclasses.dataclass(frozen=True)
class BandPicture:
    """A scene's bands and the integrator's view of them: ``path`` (``PathBands``), per branch
    the ``numerical`` dispersion (None: the method's matrices are not known), the scene's
    ``name``, ``integrator`` and ``dt`` (s), ``speeds`` (m/s: each branch's long-wave speed
    along x, NaN for branches not starting at zero) and ``gaps`` ((component, low, high) rad/s of
    an ionic lattice's gaps)."""

    name: str
    integrator: str
    dt: float
    kind: str
    path: PathBands
    numerical: tuple[NumericalDispersion | None, ...]
    speeds: np.ndarray
    gaps: tuple[tuple[str, float, float], ...]

    def as_dict(self) -> dict[str, Any]:
        corners = {}
        for label, distance in self.path.corners[1:]:
            index = int(np.argmin(np.abs(self.path.distance - distance)))
            corners[label] = {name: float(self.path.omega[row, index])
                              for row, name in enumerate(self.path.names)}
        highest = float(np.max(self.path.omega))
        top = numerical_omegas(self.integrator, np.array([highest]), self.dt)
        return dict(
            scene=self.name, integrator=self.integrator, dt=self.dt, kind=self.kind,
            branches=list(self.path.names),
            long_wave_speed_along_x={name: _finite(speed)
                                     for name, speed in zip(self.path.names, self.speeds,
                                                            strict=True)},
            omega_at_corners=corners, highest_omega=highest,
            highest_omega_numerical=None if top is None else float(top.omega_numerical[0]),
            highest_stable=None if top is None else bool(top.stable[0]),
            gaps=[dict(component=c, low=low, high=high) for c, low, high in self.gaps],
        )


def _finite(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def band_picture(simulation: sim.Simulation, samples: int = 301) -> BandPicture:
    """The bands of ``simulation``'s lattice with its integrator's numerical dispersion at its
    dt (raises ``sim.theory.bands.BandError`` for a lattice without bands)."""
    structure = BandStructure(simulation.model)
    path = structure.along_path(samples)
    numerical = tuple(numerical_omegas(simulation.integrator, row, simulation.dt)
                      for row in path.omega)
    gaps = []
    if structure.kind == "ionic":
        for index in range(0, len(path.names), 2):
            low, high = float(path.omega[index].max()), float(path.omega[index + 1].min())
            if high > low:
                gaps.append((path.names[index].split()[0], low, high))
    return BandPicture(str(simulation.scene.name), simulation.integrator, float(simulation.dt),
                       structure.kind, path, numerical, structure.long_wave_speeds(0.0),
                       tuple(gaps))


def format_report(picture: BandPicture) -> str:
    data = picture.as_dict()
    lines = [f"bands of {picture.name} ({picture.kind}), {describe(picture.integrator).label} "
             f"at dt = {picture.dt:g} s"]
    for name in picture.path.names:
        speed = data["long_wave_speed_along_x"][name]
        at = ", ".join(f"{label} {values[name]:.4g}"
                       for label, values in data["omega_at_corners"].items())
        lines.append(f"  {name:>12}: omega at {at} rad/s; long-wave speed along x "
                     + ("none (does not start at 0)" if speed is None else f"{speed:.4g} m/s"))
    for component, low, high in picture.gaps:
        lines.append(f"  {component} gap: no wave between {low:.4g} and {high:.4g} rad/s")
    if data["highest_omega_numerical"] is None:
        lines.append("  numerical dispersion: not known for this integrator")
    else:
        lines.append(
            f"  the highest wave, omega = {data['highest_omega']:.4g} rad/s, runs at "
            f"{data['highest_omega_numerical']:.4g} rad/s"
            + ("" if data["highest_stable"] else " and GROWS (dt beyond the stable limit)"))
    return "\n".join(lines)


def plot_bands(picture: BandPicture, path: str) -> None:
    """The bands (solid), continuum lines (dashed) and the integrator's numerical dispersion
    (dotted; left out where the wave grows) against the path, corners marked; PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(10.5, 5))
    bands = picture.path
    highest = float(np.max(bands.omega))
    for numerical in picture.numerical:
        if numerical is not None and numerical.stable.any():
            highest = max(highest, float(np.max(numerical.omega_numerical[numerical.stable])))
    top = 1.12 * highest or 1.0
    for row, name in enumerate(bands.names):
        colour = COLOURS[row % len(COLOURS)]
        axis.plot(bands.distance, bands.omega[row], "-", color=colour, lw=2, label=name)
        if np.isfinite(bands.continuum[row]).any():
            axis.plot(bands.distance, bands.continuum[row], "--", color=colour, lw=1,
                      label=f"{name} continuum ω = c|q|")
        numerical = picture.numerical[row]
        if numerical is not None and not numerical.exact:
            shown = np.where(numerical.stable, numerical.omega_numerical, np.nan)
            axis.plot(bands.distance, shown, ":", color=colour, lw=1.6,
                      label=f"{name} as {picture.integrator} runs it")
    gaps: dict[tuple[float, float], list[str]] = {}
    for component, low, high in picture.gaps:
        gaps.setdefault((round(low, 9), round(high, 9)), []).append(component)
    for (low, high), components in gaps.items():
        axis.axhspan(low, high, color="0.88", zorder=0)
        axis.text(bands.distance[-1] * 0.5, 0.5 * (low + high),
                  f"gap of {', '.join(components)}: {low:.3g} to {high:.3g} rad/s",
                  ha="center", va="center", fontsize=9)
    ticks = [distance for _, distance in bands.corners]
    axis.set_xticks(ticks, [label for label, _ in bands.corners])
    for tick in ticks[1:-1]:
        axis.axvline(tick, color="0.6", lw=0.8)
    axis.set_xlim(0.0, ticks[-1])
    axis.set_ylim(0.0, top)
    axis.set_xlabel("wave vector q along the path " + "–".join(label for label, _ in bands.corners)
                    + f" (X at π/a = {ticks[1]:.3g} rad/m)")
    axis.set_ylabel("angular frequency ω (rad/s)")
    label = describe(picture.integrator).label
    axis.set_title(f"{picture.name}: bands, continuum lines and {label} at dt = {picture.dt:g} s",
                   fontsize=10)
    unstable = [n for n, d in zip(bands.names, picture.numerical, strict=True)
                if d is not None and not d.stable.all()]
    if unstable:
        axis.text(0.5, 0.02, f"{label} at this dt makes the highest waves of "
                  + ", ".join(unstable) + " grow: their dotted lines stop",
                  transform=axis.transAxes, ha="center", va="bottom", fontsize=9,
                  color="darkred", backgroundcolor="white")
    axis.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
