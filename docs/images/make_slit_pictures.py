"""The pictures of docs/instruments.md "Sources and slits": the double- and single-slit screens
(``oscillators slits ... --plot``) and the anisotropy lesson (a point source on the planar
pre-tensioned lattice draws an ellipse).  Run from the repository root:

    python docs/images/make_slit_pictures.py
"""

from __future__ import annotations

import dataclasses
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import sim  # noqa: E402
from app.cli import main  # noqa: E402


def slits() -> None:
    main(["slits", "double-slit", "--plot", "docs/images/double-slit.png", "--quiet"])
    main(["slits", "single-slit", "--plot", "docs/images/single-slit.png", "--quiet"])


def ellipse(path: str = "docs/images/point-source-ellipse.png", time: float = 12.0) -> None:
    """u_y of a 2-D lattice (k = 35 N/m, L = 0.8 a) driven along y at one particle, with the
    front predicted by the long-wave speeds: sqrt(T / a m) along x, sqrt(k / m) along y."""
    n = 181
    source = dict(column=n // 2, row=n // 2, direction="y", amplitude=0.05, frequency=0.12,
                  kind="force", ramp=1.0)
    model = sim.Model.create(n, n, stiffness=35.0, rest_length=0.8, linear=True,
                             boundary="absorbing", sponge_width=10, sources=[source])
    simulation = sim.Simulation(model, integrator="verlet", dt=0.02)
    simulation.step(int(round(time / 0.02)))
    field = (simulation.positions[:, 1] - model.rest_positions[:, 1]).reshape(n, n)
    along, across = sim.theory.lattice_waves.polarisation(model, "y").long_wave_speeds()
    figure, axes = plt.subplots(figsize=(5.6, 5.2), dpi=100)
    limit = float(np.abs(field).max())
    half = (n - 1) / 2
    axes.imshow(field, origin="lower", cmap="RdBu_r", vmin=-limit, vmax=limit,
                extent=(-half, half, -half, half))
    angle = np.linspace(0, 2 * math.pi, 400)
    axes.plot(along * time * np.cos(angle), across * time * np.sin(angle), "k--", lw=1.2,
              label=f"front: {along:.2f} m/s along x, {across:.2f} m/s along y")
    axes.set_title(f"u_y of a point source, t = {time:g} s (planar lattice, L = 0.8 a)",
                   fontsize=9)
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.legend(fontsize=8, loc="lower right")
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)


def two_sources(path: str = "docs/images/two-sources.png", time: float = 50.0) -> None:
    """u_z of the two-sources preset: in phase, and with the second source half a period
    behind (phase pi): the nodal lines swing."""
    figure, panels = plt.subplots(1, 2, figsize=(10.0, 5.0), dpi=100)
    for axes, phase in zip(panels, (0.0, math.pi), strict=True):
        scene = sim.scenes.build("two-sources")
        first, second = scene.model.sources
        model = scene.model.replace(sources=[first, dataclasses.replace(second, phase=phase)])
        simulation = sim.Simulation(dataclasses.replace(scene, model=model))
        simulation.step(int(round(time / simulation.dt)))
        field = (simulation.positions[:, 2] - model.rest_positions[:, 2]).reshape(model.ny, model.nx)
        limit = float(np.abs(field).max())
        half = (model.nx - 1) / 2
        axes.imshow(field, origin="lower", cmap="RdBu_r", vmin=-limit, vmax=limit,
                    extent=(-half, half, -half, half))
        axes.set_title(f"phase difference {phase:.2f} rad, t = {time:g} s", fontsize=9)
        axes.set_xlabel("x (m)")
        axes.set_ylabel("y (m)")
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)


if __name__ == "__main__":
    slits()
    ellipse()
    two_sources()
