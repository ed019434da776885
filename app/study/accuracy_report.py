"""The accuracy study as text and a picture: the runs' table, the report with the orders and the
recommendation, and the work-precision plot (error against wall time and against dt)."""

from __future__ import annotations

import math

from app.study.accuracy import AccuracyStudy
from sim.integrators.registry import describe


def _format(value: float | None, spec: str = ".3g") -> str:
    if value is None:
        return "-"
    if isinstance(value, float) and math.isinf(value):
        return "inf"
    return format(value, spec)


def format_table(study: AccuracyStudy) -> str:
    """The runs as a fixed-width text table."""
    header = (
        f"{'integrator':10s} {'precision':9s} {'dt (s)':>10s} {'dt/limit':>8s} {'wall (s)':>9s} "
        f"{'steps/s':>9s} {'error':>9s} {'energy':>9s} {'phase':>9s}"
    )
    lines = [header, "-" * len(header)]
    for run in sorted(study.runs, key=lambda run: (run.integrator, run.precision, run.dt)):
        marker = " *" if run.refined else ""
        lines.append(
            f"{run.integrator:10s} {run.precision:9s} {run.dt:10.4g} {_format(run.dt_over_limit, '.3f'):>8s} "
            f"{run.wall_seconds:9.3g} {run.steps_per_second:9.3g} "
            f"{'blew up' if run.blew_up else _format(run.error):>9s} "
            f"{_format(run.energy_drift):>9s} {_format(run.phase_error):>9s}{marker}"
        )
    return "\n".join(lines)


def format_report(study: AccuracyStudy, recommendation: str | None = None) -> str:
    """Table, orders, reference and recommendation as text (``recommendation``: the lines
    that say it, in place of the sweep's fastest run within the tolerance)."""
    reference = study.reference
    ref_text = (
        f"reference: {reference.kind}"
        + (f", dt = {reference.dt:.3g} s, own error ~ {reference.error:.2g}"
           if reference.dt else "")
        + (f" ({reference.note})" if reference.note else "")
    )
    limits = ", ".join(
        f"{name} {_format(limit, '.4g')}" for name, limit in study.limits.items()
    )
    orders = ", ".join(
        f"{name} {_format(order, '.2f')} (theory {describe(name).order})"
        for name, order in study.orders.items()
    )
    return "\n".join(
        [
            f"scene {study.scene}: {study.description}",
            f"error at T = {study.until:.4g} s; omega_max = {study.omega_max:.4g} rad/s; "
            f"stable dt: {limits}",
            ref_text,
            "error = max particle position error / initial disturbance; energy = relative drift "
            "of kinetic + potential + dissipated; phase = dominant mode (rad)",
            "",
            format_table(study),
            "(* dt predicted from the measured order to just meet the tolerance)",
            "",
            f"measured convergence orders: {orders}",
            recommendation or (f"recommendation for tolerance "
                               f"{study.recommendation.tolerance:g}: "
                               f"{study.recommendation.reason}"),
        ]
    )


def plot_work_precision(study: AccuracyStudy, path: str, ax=None, recommendation: str = "") -> None:
    """Error against wall time, log-log, one curve per integrator; saved as a PNG at ``path``.
    ``recommendation``: a line saying the verified choice (`oscillators choose`'s answer), shown
    under the title in place of the sweep's own fastest run within the tolerance."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5))
    single_precisions = sorted({run.precision for run in study.runs} - {"float64"})
    for name in study.orders:
        runs = [run for run in study.runs_of(name, refined=None) if run.usable and run.error > 0]
        if not runs:
            continue
        order = study.orders[name]
        label = f"{name} (order {order:.2f})" if order is not None else name
        colour = tuple(channel / 255 for channel in describe(name).colour)
        left.loglog([r.wall_seconds for r in runs], [r.error for r in runs], "o-", color=colour,
                    label=label)
        right.loglog([r.dt for r in runs], [r.error for r in runs], "o-", color=colour,
                     label=label)
        for precision in single_precisions:  # hollow markers, dashed: same integrator, float32
            other = [run for run in study.runs_of(name, refined=None, precision=precision)
                     if run.usable and run.error > 0]
            if not other:
                continue
            style = dict(color=colour, linestyle="--", marker="o", markerfacecolor="none",
                         label=f"{name} {precision}")
            left.loglog([r.wall_seconds for r in other], [r.error for r in other], **style)
            right.loglog([r.dt for r in other], [r.error for r in other], **style)
    tolerance = study.recommendation.tolerance
    for axis in (left, right):
        axis.axhline(tolerance, color="grey", linestyle=":", label=f"tolerance {tolerance:g}")
        if study.reference.error > 0:
            axis.axhline(study.reference.error, color="grey", linestyle="--",
                         label="reference's own error")
        axis.set_ylabel("relative position error at T")
        axis.grid(True, which="both", alpha=0.3)
    if study.recommendation.integrator and not recommendation:
        left.plot([study.recommendation.wall_seconds], [study.recommendation.error], "k*",
                  markersize=14, label="recommended")
    if study.exact is not None and not study.exact.blew_up:
        left.axvline(study.exact.wall_seconds, color="black", linestyle="-.",
                     label=f"exact solver: {study.exact.wall_seconds * 1e3:.2g} ms, "
                     f"error {study.exact.error:.0e} (any dt)")
    left.set_xlabel("wall time (s)")
    left.set_title("work-precision")
    right.set_xlabel("dt (s)")
    right.set_title("convergence")
    left.legend(fontsize=8)
    title = f"{study.scene}: {study.description}; T = {study.until:.3g} s"
    figure.suptitle(title + (f"\n{recommendation}" if recommendation else ""), fontsize=9)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
