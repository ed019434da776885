"""When a run has blown up: the rule ``Simulation`` checks after every chunk of steps.

A run is unstable when any of these holds (``BlowUpRule.problem``):

* a position or velocity is not finite;
* its energy of motion (kinetic + spring, J) plus what its dampers, drag and sponges have taken
  out since the rule was set exceeds ``RUNAWAY_FACTOR`` times what the exact dynamics could
  have supplied: the energy of motion then, plus what gravity has released since (the drop of
  the gravitational energy), plus the work a driver has done (in either direction).  The exact
  dynamics spend exactly that supply (energy balance), so the rule holds from a start at rest
  (0 J, a lattice that only sags under gravity) as well as from a displaced one, and it also
  catches an unstable step whose energy the dampers keep pouring away;
* a particle is further from its rest position than ``COORDINATE_FACTOR`` times the lattice's
  size plus its sag under its whole weight ((max(nx, ny) + 1) spacing + M g / k, m).

A tiny floor (a spring energy of 1/1000 of a spacing per particle) keeps a lattice at rest from
counting round-off as growth.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.model import Model
from sim.observables import Energy
from sim.state import State

RUNAWAY_FACTOR = 100.0
"""Energy of motion, over what the initial energy, gravity and the drivers could supply, that
counts as a blow-up."""

COORDINATE_FACTOR = 10.0
"""Distance from rest, in lattice sizes (plus sag), that counts as a blow-up."""


@dataclasses.dataclass(frozen=True)
class BlowUpRule:
    """The blow-up rule from one starting state (see the module docstring).

    ``motion`` kinetic + spring energy (J) at the start, ``gravity`` the gravitational energy
    (J) then, ``driven`` the driver's work (J) then, ``dissipated`` the energy taken out (J)
    then, ``floor`` the least energy (J) counted as growth,
    ``bound`` the largest distance from rest (m).
    """

    motion: float
    gravity: float
    driven: float
    dissipated: float
    floor: float
    bound: float

    @classmethod
    def starting_from(cls, model: Model, energy: Energy) -> BlowUpRule:
        """The rule for a run that starts from a state with this energy account."""
        floor = 0.5 * model.stiffness * (1e-3 * model.spacing) ** 2 * model.n_particles
        if model.walls.free_ends and model.rest_length < model.spacing:
            # free ends under tension contract towards their equilibrium, releasing up to what
            # each spring's pre-stretch holds
            stretch = model.spacing - model.rest_length
            floor += RUNAWAY_FACTOR * 0.5 * model.stiffness * stretch**2 * model.n_particles
        for driver in ((model.driver,) if model.driver is not None else ()) + tuple(model.sources):
            # a drive's work is counted as it is done, a step late on some loops: allow what a
            # spring stretched by its amplitude holds, over every particle it drives
            floor += RUNAWAY_FACTOR * 0.5 * model.stiffness * driver.amplitude ** 2 * max(
                1, model.ny if getattr(driver, "row", 0) == "all" else 1)
        weight = float(model.masses.sum()) * float(np.linalg.norm(model.gravity[: model.dim]))
        size = (max(model.nx, model.ny) + 1) * model.spacing + weight / model.stiffness
        return cls(
            motion=abs(energy.kinetic) + abs(energy.spring), gravity=float(energy.gravity),
            driven=float(energy.driven), dissipated=float(energy.dissipated), floor=floor,
            bound=COORDINATE_FACTOR * size,
        )

    def supply(self, energy: Energy) -> float:
        """What the exact dynamics could have given the lattice by now (J)."""
        released = max(0.0, self.gravity - energy.gravity)
        return self.motion + released + abs(energy.driven - self.driven)

    def problem(self, model: Model, state: State, energy: Energy) -> str | None:
        """Why the run counts as blown up, or None while it does not."""
        motion = abs(energy.kinetic) + abs(energy.spring)
        spent = motion + max(0.0, energy.dissipated - self.dissipated)
        if not math.isfinite(spent) or not state.is_finite():
            return "positions or velocities became infinite or NaN"
        supply = self.supply(energy)
        if spent > RUNAWAY_FACTOR * supply + self.floor:
            return (
                f"the energy ran away ({spent:.3g} J of motion and dissipation, more than "
                f"{RUNAWAY_FACTOR:g} times the {supply:.3g} J the initial energy, gravity and "
                "drivers can supply)"
            )
        distance = largest_displacement(model, state)
        if distance > self.bound:
            return (
                f"a particle moved {distance:.3g} m from its rest position, beyond "
                f"{self.bound:.3g} m ({COORDINATE_FACTOR:g} times the lattice's size and sag)"
            )
        return None


def largest_displacement(model: Model, state: State) -> float:
    """The largest distance (m) of a particle from its rest position (per coordinate)."""
    rest = model.rest_positions.T.reshape(state.positions.shape)
    return float(np.abs(state.positions - rest).max()) if state.positions.size else 0.0
