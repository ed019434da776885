"""The continuum-limit study as a table and a picture (``app.study.continuum``).

The picture has two panels: the error against the spacing a on log axes with the a^2 line (and
the a line for a pluck) through the finest run; and the dispersion relation of the lattices run,
omega(q) = (2c/a) sin(q a / 2) up to q = pi / a, beside the continuum's c q, with the modes the
initial shape excites (|b_n| above a thousandth of the largest) marked on the continuum line.
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path

import numpy as np

from app.study.continuum import ContinuumStudy
from sim.scenes.continuum import lattice_frequencies

EXCITED_SHARE = 1e-3
"""A mode counts as excited when its coefficient is above this share of the largest."""


def format_report(study: ContinuumStudy) -> str:
    """The table: per particle count the spacing, error, its parts and the step used."""
    body = study.body
    lines = [
        f"continuum limit of the {body.describe()}",
        f"compared at t = {', '.join(f'{t:.4g}' for t in study.times)} s "
        f"(fractions of the crossing time 2 L0 / c = {body.crossing_time:.4g} s)",
        "",
        f"{'particles':>9} {'a (m)':>10} {'error':>10} {'lattice':>10} {'time step':>10} "
        f"{'dt (s)':>10} {'steps':>7} {'order':>6}",
    ]
    previous = None
    for run in study.runs:
        local = ""
        if previous is not None and run.error > 0 and previous.error > 0:
            local = f"{math.log(previous.error / run.error) / math.log(previous.spacing / run.spacing):6.2f}"
        lines.append(
            f"{run.particles:>9} {run.spacing:10.4g} {run.error:10.3e} "
            f"{run.discretisation_error:10.3e} {run.time_error:10.2e} {run.dt:10.3g} "
            f"{run.steps:>7} {local:>6}"
        )
        previous = run
    lines += [
        "",
        "error: relative L2 distance of the run from the continuum solution at the particles "
        "(largest over the times);",
        "lattice: the lattice's exact normal-mode solution against the continuum (the "
        "continuum-limit error alone);",
        f"time step: the run against the lattice's exact solution ({study.runs[0].integrator}, "
        "dt halved until it is at most a tenth of the 'lattice' column).",
    ]
    if study.order is not None:
        lines.append(f"measured order in a: {study.order:.2f} (expected {study.expected_order:g}: "
                     f"{study.why})")
    unverified = [run.particles for run in study.runs if not run.step_verified]
    if unverified:
        lines.append(f"the time step could not be made accurate enough (time-stepping error above a "
                     f"tenth of the lattice's) at {', '.join(map(str, unverified))} particles: "
                     "these errors are the integrator's, not the continuum limit's")
    loose = [run.particles for run in study.runs if run.series_change > 1e-3 * run.error]
    if loose:
        lines.append("the continuum series is not converged well below the error at "
                     f"{', '.join(map(str, loose))} particles")
    return "\n".join(lines)


def excited_modes(study: ContinuumStudy, largest: int) -> np.ndarray:
    """Mode numbers n <= ``largest`` whose sine coefficient is above ``EXCITED_SHARE`` of the
    largest."""
    b = np.abs(study.body.shape.coefficients(largest))
    return np.flatnonzero(b > EXCITED_SHARE * b.max()) + 1


def plot_continuum(study: ContinuumStudy, path: str) -> None:
    """The two panels (see the module docstring), written atomically to the PNG ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    body = study.body
    figure, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    spacing = np.array([run.spacing for run in study.runs])
    errors = np.array([run.error for run in study.runs])
    left.loglog(spacing, errors, "o-", color="tab:blue", label="lattice run vs continuum")
    left.loglog(spacing, [run.discretisation_error for run in study.runs], "x", color="k",
                markersize=7, label="lattice's exact solution vs continuum")
    left.loglog(spacing, [max(run.time_error, 1e-300) for run in study.runs], "s", color="tab:grey",
                markersize=4, label="time-stepping error (run vs lattice's exact)")
    a = np.geomspace(spacing.min(), spacing.max(), 50)
    left.loglog(a, errors[-1] * (a / spacing[-1]) ** 2, "--", color="tab:green", label="a^2")
    if not body.shape.smooth:
        left.loglog(a, errors[-1] * (a / spacing[-1]), ":", color="tab:red", label="a")
    for run in study.runs:
        left.annotate(f"N={run.particles}", (run.spacing, run.error), textcoords="offset points",
                      xytext=(4, 4), fontsize=7)
    left.set_xlabel("spacing a (m)")
    left.set_ylabel("relative L2 error")
    order = "" if study.order is None else f", measured order {study.order:.2f}"
    left.set_title(f"{body.kind}, {body.shape.describe()}{order}", fontsize=9)
    left.legend(fontsize=7, loc="upper left")
    left.grid(True, which="both", alpha=0.3)

    q_top = math.pi / spacing.min()
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(study.runs)))
    for run, colour in zip(study.runs, colours, strict=True):
        modes = np.arange(1, run.particles + 1)
        q = modes * math.pi / body.length
        right.plot(q, lattice_frequencies(body, run.particles, modes), "-", color=colour,
                   linewidth=1.2, label=f"lattice N={run.particles}")
    q = np.linspace(0.0, q_top, 200)
    right.plot(q, body.speed * q, "--", color="tab:red", label=f"continuum c q, c = {body.speed:.3g} m/s")
    excited = excited_modes(study, max(run.particles for run in study.runs))
    qe = excited * math.pi / body.length
    right.plot(qe, body.speed * qe, "o", color="tab:orange", markersize=4,
               label=f"modes the shape excites ({len(excited)})")
    right.set_xscale("log")
    right.set_yscale("log")
    right.set_xlabel("wavenumber q = n pi / L0 (1/m)")
    right.set_ylabel("omega (rad/s)")
    right.set_title("dispersion along a side: (2c/a) sin(q a/2) against c q", fontsize=9)
    right.legend(fontsize=7, loc="upper left")
    right.grid(True, which="both", alpha=0.3)
    figure.tight_layout()
    target = Path(path)
    handle = tempfile.NamedTemporaryFile(dir=target.parent, prefix=f".{target.name}.",
                                         suffix=".png", delete=False)
    try:
        with handle:
            figure.savefig(handle, format="png", dpi=110)
        os.chmod(handle.name, 0o644)  # a picture others may read, like any saved file
        os.replace(handle.name, target)
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)
        raise
    finally:
        plt.close(figure)
