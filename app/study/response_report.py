"""The response curve as a table and a picture: ``format_report`` and ``plot_response``."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

import sim
from app.study.response import ResponseCurve, wrap_lag
from app.study.response_modes import ModeLine, modal_response


def format_report(curve: ResponseCurve) -> str:
    """The table of frequency, amplitude and lag (and the analytic amplitude for one particle),
    the peak and the modes in range."""
    driver = curve.driver
    lines = [
        f"{curve.scene}: {driver.describe()} (frequency replaced by each below); probe particle "
        f"(column {curve.probe[0]}, row {curve.probe[1]}), displacement along the drive",
        f"{curve.integrator}, dt = {curve.dt:g} s; each run from rest: start {driver.start:g} s "
        f"+ ramp {driver.ramp:g} s + settle ("
        + ("estimated per frequency from the damping" if curve.settle is None
           else f"{curve.settle:g} s") + f"), then a fit over {curve.periods} periods",
        "",
    ]
    with_analytic = any(point.analytic is not None for point in curve.points)
    with_prediction = not with_analytic and any(point.predicted for point in curve.points)
    header = f"{'f (Hz)':>9s} {'amplitude (m)':>14s} {'lag (deg)':>9s} {'settle (s)':>10s}"
    if with_analytic:
        header += f" {'analytic (m)':>13s} {'error':>8s}"
    if with_prediction:
        header += f" {'modes (m)':>11s} {'error':>8s}"
    lines.append(header + "  nearest mode")
    for point in curve.points:
        row = (f"{point.frequency:9.4f} {point.amplitude:14.4e} {point.lag:9.1f} "
               f"{point.settle:10.4g}")
        if with_analytic and point.analytic is not None:
            row += f" {point.analytic:13.4e} {point.amplitude / point.analytic - 1:+8.2%}"
        if with_prediction and point.predicted:
            row += f" {point.predicted:11.4e} {point.amplitude / point.predicted - 1:+8.2%}"
        near = curve.nearest_mode(point.frequency)
        if near is not None:
            row += f"  {near.label} ({near.frequency:.4f} Hz)"
        if not point.settled:
            row += f"  not settled ({point.half_change:.1%} between halves)"
        lines.append(row)
    peak = curve.peak()
    near = curve.nearest_mode(peak.frequency)
    lines += ["", f"largest response {peak.amplitude:.4g} m at {peak.frequency:.4f} Hz"
              + (f", next to mode {near.label} at {near.frequency:.4f} Hz" if near else "")]
    unsettled = sum(not point.settled for point in curve.points)
    if unsettled:
        lines.append(f"{unsettled} point(s) not settled: give a longer --settle SECONDS")
    if with_prediction:
        lines.append(_prediction_caption(curve.model) + " in the column 'modes'")
    if driver.kind == "displacement":
        lines.append("displacement driver: the resonances are those of the lattice with the "
                     "driven particle held, near the free lattice's modes listed")
        if (driver.column, driver.row) == curve.probe:
            lines.append("the probe is the driven particle, which follows the prescribed "
                         "motion: probe another one with --probe I,J")
    return "\n".join(lines)


def _prediction_caption(model: sim.Model) -> str:
    what = "normal-mode prediction"
    notes = []
    if not model.linear:
        notes.append("linearised springs")
    return what + (f" ({'; '.join(notes)})" if notes else "")


def _same_frequency(lines: Sequence[ModeLine]) -> list[tuple[float, list[str]]]:
    """(frequency, labels) of the lines, degenerate modes (equal frequencies to 1e-9) merged."""
    groups: list[tuple[float, list[str]]] = []
    for line in sorted(lines, key=lambda line: line.frequency):
        if groups and abs(line.frequency - groups[-1][0]) <= 1e-9 * max(line.frequency, 1e-300):
            groups[-1][1].append(line.label)
        else:
            groups.append((line.frequency, [line.label]))
    return groups


def plot_response(curve: ResponseCurve, path: str) -> None:
    """Amplitude (log scale) and lag against frequency, measured points on the normal modes'
    prediction (force drivers), the modes as labelled vertical lines; PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (axis, lag_axis) = plt.subplots(
        2, 1, figsize=(10, 6.4), sharex=True, gridspec_kw=dict(height_ratios=(3, 1)))
    frequencies = curve.frequencies
    low, high = float(frequencies.min()), float(frequencies.max())
    margin = 0.02 * (high - low or high)
    shown = [line for line in curve.modes if low - margin <= line.frequency <= high + margin]
    groups = _same_frequency(shown)
    for index, (frequency, labels) in enumerate(groups):
        for target in (axis, lag_axis):
            target.axvline(frequency, color="tab:grey", linewidth=0.8, alpha=0.6,
                           linestyle="--", label="normal modes" if index == 0 and
                           target is axis else None)
        if len(groups) <= 30:
            text = " / ".join(labels[:2]) + (" ..." if len(labels) > 2 else "")
            axis.text(frequency, 1.01, text, rotation=90, fontsize=7,
                      ha="center", va="bottom", transform=axis.get_xaxis_transform())
    probe = curve.probe[1] * curve.model.nx + curve.probe[0]
    dense = np.unique(np.concatenate([np.linspace(low, high, 3000),
                                      [line.frequency for line in shown]]))
    prediction = modal_response(curve.model, curve.driver, probe, dense)
    if prediction is not None:
        label = (_prediction_caption(curve.model) if curve.model.n_particles > 1 else
                 "analytic F0 / (m sqrt((w0^2 - w^2)^2 + (beta w)^2))")
        axis.plot(dense, np.abs(prediction), "-", color="black", linewidth=0.8, alpha=0.7,
                  label=label)
        lag_axis.plot(dense, wrap_lag(-np.degrees(np.angle(prediction))), "-", color="black",
                      linewidth=0.6, alpha=0.6)
    else:
        axis.plot(frequencies, curve.amplitudes, "-", color="tab:blue", linewidth=1.0)
    settled = np.array([point.settled for point in curve.points])
    axis.plot(frequencies[settled], curve.amplitudes[settled], "o", color="tab:blue",
              markersize=3.5, label="measured (steady amplitude)")
    if not settled.all():
        axis.plot(frequencies[~settled], curve.amplitudes[~settled], "x", color="tab:red",
                  label="not settled")
    axis.set_yscale("log")
    axis.set_ylabel("steady amplitude (m)")
    axis.legend(fontsize=8, loc="lower left")
    axis.grid(True, which="major", alpha=0.25)
    lag_axis.plot(frequencies, np.array([point.lag for point in curve.points]), "o",
                  color="tab:blue", markersize=2.5)
    lag_axis.set_ylabel("lag (deg)")
    lag_axis.set_yticks([-90, 0, 90, 180, 270])
    lag_axis.set_ylim(-100, 280)
    lag_axis.set_xlabel("drive frequency (Hz)")
    lag_axis.grid(True, alpha=0.25)
    driver = curve.driver
    figure.suptitle(
        f"response of {curve.scene}{' (linearised springs)' if curve.model.linear else ''}: "
        f"{driver.kind} drive A = {driver.amplitude:g} m at (column "
        f"{driver.column}, row {driver.row}), probe (column {curve.probe[0]}, row "
        f"{curve.probe[1]}); {curve.integrator} dt = {curve.dt:g} s",
        fontsize=9,
    )
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
