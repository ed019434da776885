"""Launching a wave packet into a running lattice: the packet's description and state
(``sim.theory.wave_packet``, re-exported here) and ``launch_packet``, the command that puts it
into a simulation.

A page or command posts ``functools.partial(launch_packet, spec=spec)`` to the runner (or
calls it between steps); it replaces the lattice's positions and velocities like exciting one
mode does (``sim.theory.modes.excited_state``): the clock runs on, the dissipated energy starts
again from zero.  Measure the packet with ``sim.instruments.packet_tracker.PacketTracker``.
"""

from __future__ import annotations

from typing import Any

from sim.theory.wave_packet import (
    DEFAULT_AMPLITUDE,
    DEFAULT_LENGTHS,
    PacketSpec,
    packet_state,
    polarisation_names,
    theory,
)

__all__ = ["DEFAULT_AMPLITUDE", "DEFAULT_LENGTHS", "PacketSpec", "launch_packet",
           "packet_state", "polarisation_names", "theory"]


def launch_packet(simulation: Any, spec: PacketSpec, amplitude: float | None = None) -> None:
    """Set ``simulation``'s state to the packet ``spec`` (``packet_state``; ``amplitude`` in m,
    default ``DEFAULT_AMPLITUDE`` spacings).  Raises WaveError (a ValueError) before touching
    the state when the packet is refused."""
    positions, velocities = packet_state(simulation.model, spec, amplitude)
    simulation.positions[...] = positions
    simulation.velocities[...] = velocities
    simulation.state.dissipated = 0.0
