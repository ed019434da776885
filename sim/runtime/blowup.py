"""When a run has blown up: the rule ``Simulation`` checks after every chunk of steps.

A run is unstable when any of these holds (``BlowUpRule.problem``):

* a position or velocity is not finite;
* its energy of motion (kinetic + spring, J) plus what its dampers, drag and sponges have taken
  out since the rule was set exceeds ``RUNAWAY_FACTOR`` (a symplectic method; ``DRIFT_FACTOR``
  for a method whose energy drifts by its own error) times what the exact dynamics could
  have supplied: the energy of motion then, plus what gravity has released since (the drop of
  the gravitational energy), plus the work a driver has done (in either direction).  The exact
  dynamics spend exactly that supply (energy balance), so the rule holds from a start at rest
  (0 J, a lattice that only sags under gravity) as well as from a displaced one, and it also
  catches an unstable step whose energy the dampers keep pouring away;

  the spring energy is counted from the lowest value the springs can reach (``release``), so
  both sides are never negative and the balance is exact: the observables measure it from the
  rest lattice, which is its minimum between walls (a row or column of pre-stretched springs
  between fixed ends is at least as long as the span, and by convexity its energy is least when
  every spring shares the span equally); with free left and right ends a pre-stretched row can
  contract, its nx - 1 springs releasing at most their rest-lattice stretch energy
  1/2 k (a - L)^2 each (linearised springs too: their end tension k (a - L) is balanced once
  each spring is compressed by a - L);
* a particle is further from its rest position than ``COORDINATE_FACTOR`` times the lattice's
  size plus its sag under its whole weight ((max(nx, ny) + 1) spacing + M g / k, m).

A tiny floor (a spring energy of 1/1000 of a spacing per particle) keeps a lattice at rest from
counting round-off as growth.  A driver's work is counted after each step, as the stepping
reports it, so at worst the motion of the last step is seen before the work that made it: a
factor of about 2 from a start at rest, far inside ``RUNAWAY_FACTOR``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.model.lattice import Model
from sim.model.state import State
from sim.runtime.rest_distance import farthest_from_rest
from sim.theory.observables import Energy

RUNAWAY_FACTOR = 10.0
"""Energy of motion and dissipation, over what the initial energy, gravity and the drivers could
supply, that counts as a blow-up.  The exact dynamics give 1.  A stable symplectic step shows at
most 1 / (1 - (omega dt / 2)^2) times a mode's energy (the energy it conserves weighs the
spring energy by 1 - (omega dt / 2)^2): 10 at 0.95 of that mode's stability limit.  A step just
past the limit of a damped lattice's sagging (large-amplitude) state feeds a high mode whose
energy the dashpots pour away as fast as it comes: its energy of motion stays small while the
dissipated energy grows steadily (for the catenary at 0.97 of its measured limit, 3.5 kW, ten
times the whole supply within about 17 s)."""

DRIFT_FACTOR = 100.0
"""The same for a method that conserves no energy, whose energy drifts by its own error at every
step (explicit Euler's grows by 1 + (omega dt)^2 a step on an undamped lattice, at every dt; the
Runge-Kutta methods' decays below their limit): that drift is the method's accuracy, shown as the
energy-balance error, so only a hundredfold counts as a blow-up."""


def runaway_factor(symplectic: bool) -> float:
    """The factor of the energy rule for a method that is (or is not) symplectic."""
    return RUNAWAY_FACTOR if symplectic else DRIFT_FACTOR


CHECKS_PER_RUN = 200
"""Times ``oscillators run`` (and the whole-run stability study) looks at a run, at least:
the rule is checked at each look, and a burst of energy that dashpots take out again between two
looks can pass unseen."""

COORDINATE_FACTOR = 10.0
"""Distance from rest, in lattice sizes (plus sag), that counts as a blow-up."""


@dataclasses.dataclass(frozen=True)
class BlowUpRule:
    """The blow-up rule from one starting state (see the module docstring).

    ``motion`` kinetic + spring energy (J) at the start, the spring energy counted from its
    lowest reachable value; ``gravity`` the gravitational energy (J) then, ``driven`` the
    driver's work (J) then, ``dissipated`` the energy taken out (J) then, ``floor`` the least
    energy (J) counted as growth, ``bound`` the largest distance from rest (m), ``release`` the
    most spring energy (J) below the rest lattice's that the springs can reach.
    """

    motion: float
    gravity: float
    driven: float
    dissipated: float
    floor: float
    bound: float
    release: float = 0.0

    @classmethod
    def starting_from(cls, model: Model, energy: Energy) -> BlowUpRule:
        """The rule for a run that starts from a state with this energy account."""
        floor = 0.5 * model.stiffness * (1e-3 * model.spacing) ** 2 * model.n_particles
        release = spring_release(model)
        return cls(
            motion=_motion(energy, release), gravity=float(energy.gravity),
            driven=float(energy.driven), dissipated=float(energy.dissipated), floor=floor,
            bound=reach(model), release=release,
        )

    def supply(self, energy: Energy) -> float:
        """What the exact dynamics could have given the lattice by now (J)."""
        released = max(0.0, self.gravity - energy.gravity)
        return self.motion + released + abs(energy.driven - self.driven)

    def problem(self, model: Model, state: State, energy: Energy,
                factor: float = RUNAWAY_FACTOR) -> str | None:
        """Why the run counts as blown up, or None while it does not; ``factor`` that of the
        method (``runaway_factor``)."""
        motion = _motion(energy, self.release)
        spent = motion + max(0.0, energy.dissipated - self.dissipated)
        if not math.isfinite(spent) or not state.is_finite():
            return "positions or velocities became infinite or NaN"
        supply = self.supply(energy)
        if spent > factor * supply + self.floor:
            return (
                f"the energy ran away ({spent:.3g} J of motion and dissipation, more than "
                f"{factor:g} times the {supply:.3g} J the initial energy, gravity and "
                "drivers can supply)"
            )
        distance = largest_displacement(model, state)
        if distance > self.bound:
            return (
                f"a particle moved {distance:.3g} m from its rest position, beyond "
                f"{self.bound:.3g} m ({COORDINATE_FACTOR:g} times the lattice's size and sag)"
            )
        return None


def reach(model: Model) -> float:
    """The largest distance (m) of a particle from its rest position that is not a blow-up:
    ``COORDINATE_FACTOR`` times the lattice's size plus its sag under its whole weight."""
    weight = float(model.masses.sum()) * float(np.linalg.norm(model.gravity[: model.dim]))
    size = (max(model.nx, model.ny) + 1) * model.spacing + weight / model.stiffness
    return COORDINATE_FACTOR * size


def spring_release(model: Model) -> float:
    """The most spring energy (J) below the rest lattice's that the springs can reach (see the
    module docstring): 1/2 k (a - L)^2 for each of the ny (nx - 1) springs of pre-stretched rows
    with free ends, else 0."""
    stretch = model.spacing - model.rest_length
    if not model.walls.free_ends or stretch <= 0:
        return 0.0
    return 0.5 * model.stiffness * stretch**2 * model.ny * max(model.nx - 1, 0)


def _motion(energy: Energy, release: float) -> float:
    """Kinetic + spring energy (J), the spring energy counted from its lowest reachable value."""
    return abs(float(energy.kinetic)) + max(0.0, float(energy.spring) + release)


def largest_displacement(model: Model, state: State) -> float:
    """The largest distance (m) of a particle from its rest position (per coordinate)."""
    if not state.positions.size:
        return 0.0
    origin_x, origin_y = model.origin
    return float(farthest_from_rest(state.positions, float(origin_x), float(origin_y),
                                    float(model.spacing)))
