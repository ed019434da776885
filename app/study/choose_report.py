"""The picture of a ``choose`` answer: every run it made, measured error against wall time
(log-log), one colour per integrator (the registry's), the tolerance as a line and the verified
answer ringed.  Drawn from ``Choice.as_dict()`` so a saved JSON can be drawn again."""

from __future__ import annotations

from typing import Any

from sim.integrators.registry import describe


def plot_choice(data: dict[str, Any], path: str) -> None:
    """Save the work-precision picture of one ``choose`` result (its ``as_dict()``) as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7.5, 4.8))
    runs = [run for run in data["runs"] if run["error"] is not None and run["error"] > 0]
    for name in dict.fromkeys(run["integrator"] for run in runs):
        own = sorted((run for run in runs if run["integrator"] == name),
                     key=lambda run: run["wall_seconds"])
        description = describe(name)
        colour = tuple(channel / 255 for channel in description.colour)
        axes.plot([run["wall_seconds"] for run in own], [run["error"] for run in own], "o-",
                  color=colour, label=description.short_label)
        for run in own:
            axes.annotate(f"dt={run['dt']:.3g}", (run["wall_seconds"], run["error"]),
                          textcoords="offset points", xytext=(4, 4), fontsize=7)
    axes.axhline(data["tolerance"], color="black", linestyle="--", linewidth=1,
                 label=f"tolerance {data['tolerance']:g}")
    if data["met"]:
        axes.plot([data["wall_seconds"]], [data["error"]], "o", markersize=16,
                  markerfacecolor="none", markeredgecolor="black", markeredgewidth=2,
                  label=f"verified choice: {data['integrator']}, dt = {data['dt']:.4g} s")
    axes.set_xscale("log")
    axes.set_yscale("log")
    axes.set_xlabel("wall time of the whole run (s)")
    axes.set_ylabel(f"{data['measure']} error over {data['duration']:g} s"
                    + (" (the larger)" if " and " in data["measure"] else ""))
    axes.set_title(f"{data['scene']}: every run of `choose` (error against cost)")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
