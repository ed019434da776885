"""``oscillators run SCENE --packet QX,QY[,POLARISATION]``: launch a wave packet and measure its
group and phase speeds against the lattice's dispersion relation (``sim.scenes.packet``,
``sim.instruments.packet_tracker``).
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from app.cli.arguments import ascii_float

PACKET_HELP = (
    "replace the scene's initial state by a wave packet of wave vector (QX, QY) in rad/m "
    "(inside the first zone, |QX|, |QY| <= pi / spacing) and polarisation x, y or z (nearest "
    "springs) or S, P or z (with diagonal springs; default: the first of these that carries "
    "the wave at q), and measure its group and phase speeds against theory; without --steps or "
    "--duration the run lasts until the packet's edge would reach a wall.  Example: "
    "oscillators run interference --set nx=150 --set ny=150 --packet 1,0,y"
)


def add_packet_argument(parser: argparse.ArgumentParser) -> None:
    """The ``--packet`` option of ``run``."""
    parser.add_argument("--packet", metavar="QX,QY[,POL]", help=PACKET_HELP)


def parse_packet(text: str, model: Any):
    """``"1,0,y"`` -> the checked PacketSpec (ValueError naming --packet otherwise)."""
    from sim.theory.wave_packet import PacketSpec, default_polarisation, plan

    parts = [part.strip() for part in text.split(",")]
    if len(parts) not in (2, 3):
        raise ValueError(f"--packet takes QX,QY or QX,QY,POLARISATION, got {text!r}")
    try:
        qx, qy = ascii_float(parts[0]), ascii_float(parts[1])
    except ValueError:
        raise ValueError(f"--packet: QX and QY must be numbers (rad/m), got {text!r}") from None
    if not (math.isfinite(qx) and math.isfinite(qy)):
        raise ValueError(f"--packet: QX and QY must be finite numbers (rad/m), got {text!r}")
    try:
        name = parts[2] if len(parts) == 3 else default_polarisation(model, qx, qy)
        spec = PacketSpec(qx, qy, name)
        plan(model, spec)
    except ValueError as error:
        raise ValueError(f"--packet {text}: {error}") from None
    return spec


class PacketRun:
    """A packet launched into ``simulation``: its theory, the tracker fed during the run, the
    default duration and the sampling interval, and the report."""

    def __init__(self, simulation: Any, text: str) -> None:
        from sim.instruments.packet_tracker import PacketTracker
        from sim.scenes.packet import launch_packet, theory

        model = simulation.model
        self.spec = parse_packet(text, model)
        self.theory = theory(model, self.spec)
        if self.theory["clear_time"] <= 0:
            width, height = (model.nx + 1) * model.spacing, (model.ny + 1) * model.spacing
            raise ValueError(
                f"--packet {text}: the packet does not fit in the lattice ({width:g} x "
                f"{height:g} m between the walls): it is {self.theory['sigma_along']:.3g} m "
                "(one standard deviation) long"
                + ("" if self.theory["sigma_across"] is None else
                   f" and {self.theory['sigma_across']:.3g} m wide")
                + "; it needs about six of these each way and room to travel: enlarge the "
                "lattice (--set nx=... --set ny=...) or shorten the wavelength")
        launch_packet(simulation, self.spec)
        self.start = simulation.time
        self.tracker = PacketTracker(model, self.spec)
        self.tracker.add(simulation.time, simulation.state.particle_positions())

    def duration(self) -> float:
        """Simulated seconds until the packet's edge reaches a wall."""
        return float(self.theory["clear_time"])

    def chunk(self, dt: float) -> int:
        """Steps between samples: eight per period of the carrier."""
        return max(1, int(2 * math.pi / self.theory["omega"] / 8 / dt))

    def add(self, simulation: Any) -> None:
        self.tracker.add(simulation.time, simulation.state.particle_positions())

    def report(self) -> dict[str, Any]:
        """The measured and theory speeds (m/s) and frequencies (rad/s), with the packet."""
        measured = self.tracker.speeds()
        theory = self.theory
        return {
            "group_speed": measured["group_speed"],
            "group_speed_theory": theory["group_speed_theory"],
            "phase_speed": measured["phase_speed"],
            "phase_speed_theory": theory["phase_speed_theory"],
            "omega": measured["omega"], "omega_theory": theory["omega"],
            "packet": {
                "qx": self.spec.qx, "qy": self.spec.qy, "polarisation": self.spec.polarisation,
                "lengths": self.spec.lengths, "wavelength": theory["wavelength"],
                "group_velocity": measured["group_velocity"],
                "group_velocity_theory": theory["group_velocity"],
                "clear_time": theory["clear_time"], "samples": measured["samples"],
                "measured_span": measured["span"],
            },
        }


def _relative(measured: float | None, theory: float) -> str:
    if measured is None:
        return "not measured (too few samples)"
    if theory == 0:
        return f"{measured:.5g} m/s measured, 0 m/s theory"
    return (f"{measured:.5g} m/s measured, {theory:.5g} m/s theory "
            f"({measured / theory - 1:+.3%})")


def print_packet(summary: dict[str, Any]) -> None:
    """The packet's lines of ``run``'s text summary."""
    packet = summary["packet"]
    print(f"packet q = ({packet['qx']:g}, {packet['qy']:g}) rad/m, {packet['polarisation']} "
          f"polarisation, wavelength {packet['wavelength']:.4g} m, omega "
          f"{summary['omega_theory']:.5g} rad/s (theory)"
          + ("" if summary["omega"] is None else f", {summary['omega']:.5g} rad/s measured"))
    print(f"group speed: {_relative(summary['group_speed'], summary['group_speed_theory'])}")
    print(f"phase speed: {_relative(summary['phase_speed'], summary['phase_speed_theory'])}")
    print(f"measured over {packet['measured_span']:.4g} s ({packet['samples']} samples); the "
          f"packet's edge reaches a wall at {packet['clear_time']:.4g} s")
