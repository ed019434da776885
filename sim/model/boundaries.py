"""The boundaries of the lattice, described as data: one ``Boundary`` per choice, in one registry.

A boundary says how the rows end at the left and right (``row_ends``: walls of anchors, a ring,
or free ends), whether the kernels close each row into a ring or drop the end springs (compile-time
flags of ``sim.forces.springs.SpringParameters``), and whether an absorbing layer damps the particles
next to the walls (``sim.model.forcing``).  The top and bottom walls are always anchors.  Menus, scene
files, the CLI and the normal-mode code read these objects instead of comparing names.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Boundary:
    """One boundary choice.

    ``row_ends``: "walls" (springs to fixed anchors), "ring" (each row's last particle joined to
    its first) or "free" (no spring to the left and right walls).  ``absorbing``: a sponge layer
    damps the particles near the walls.  ``label`` and ``description`` are for people.
    """

    name: str
    label: str
    row_ends: str
    absorbing: bool = False
    description: str = ""

    @property
    def periodic(self) -> bool:
        """Whether each row is a ring."""
        return self.row_ends == "ring"

    @property
    def free_ends(self) -> bool:
        """Whether the rows' end particles have no spring to the left and right walls."""
        return self.row_ends == "free"


_REGISTRY: dict[str, Boundary] = {}


def register(boundary: Boundary) -> Boundary:
    """Add (or replace) a boundary; every menu and check sees it at once."""
    _REGISTRY[boundary.name] = boundary
    return boundary


def names() -> tuple[str, ...]:
    """Names of the registered boundaries, in registration order."""
    return tuple(_REGISTRY)


def get(name: str) -> Boundary:
    """The boundary called ``name`` (case and surrounding blanks ignored); ``KeyError`` if none."""
    return _REGISTRY[str(name).strip().lower()]


FIXED = register(Boundary(
    "fixed", "fixed walls", "walls",
    description="every row ends in springs to anchors that never move: waves reflect inverted",
))
DEFAULT_LAYER_WIDTH = 3
"""Depth of the absorbing walls' layer in particles: at the default strength
(``DEFAULT_LAYER_STRENGTH``) it reflects at most 0.43 % of the energy of a wave of 5 to 80
spacings at 0 and 45 degrees (``oscillators reflection``, docs/instruments.md; the
requirement is 1 %).  A deeper one reflects less (4 particles at strength 1: 0.2 %) but costs
a step more and hides more of the lattice."""
DEFAULT_LAYER_STRENGTH = 1.25
"""Peak damping rate of the absorbing layer in units of omega_0 = sqrt(k / m)
(``sponge_strength``): of 0.75, 1, 1.25 and 1.5, the strength whose worst reflection over 5 to
80 spacings at 0 and 45 degrees is the lowest for the default layer (the reflection study in
docs/instruments.md)."""

ABSORBING = register(Boundary(
    "absorbing", "absorbing walls", "walls", absorbing=True,
    description="fixed walls behind a sponge layer that damps the waves before they reach them",
))
PERIODIC = register(Boundary(
    "periodic", "periodic rows", "ring",
    description="each row is a ring: a wave leaving on the right comes back on the left",
))
FREE = register(Boundary(
    "free", "free row ends", "free",
    description="no springs to the left and right walls: waves reflect upright",
))
