"""The named presets (the paper's configurations) as data: one ``Preset`` record each.

A preset gives the default ``Model.create`` parameters, the recommended integrator, time step and
duration, and how to set the initial condition from the built model; ``sim.scenes.build`` turns
one into a ``Scene`` with the user's overrides.

Presets (units: metres, kilograms, seconds; stiffness 35 N/m is the paper's "35 % of maximum"):

================= ==============================================================================
single            one particle held by 4 springs (paper Fig. 3), displaced diagonally
square            2x2, the paper's four particles, one displaced (Fig. 5)
chain             5 in a line, the middle one displaced along the chain (Fig. 4, longitudinal)
grid              12x8 lattice (Fig. 2), one particle near the centre displaced
ionic             12x8 checkerboard of heavy (4 kg) and light (1 kg) particles (Fig. 7)
catenary          15x10 under gravity with dashpots, settling into catenaries (Fig. 8)
interference      682x383, the middle particles of the left and right boundaries displaced in
                  opposite directions, velocity Verlet, pre-tensioned (Figs. 10-14)
interference-open the same behind absorbing walls
resonance         a 12-particle chain driven at its third mode's frequency
bandgap           an ionic chain driven inside its band gap
fput              the Fermi-Pasta-Ulam-Tsingou chain: 32 particles, alpha = 0.25, all the energy
                  in the lowest mode, which comes back (docs/fput.md)
membrane          24x24 drum skin in 3-D, pre-tensioned, a bump pushed out of the plane
elastic-solid     160x160 with diagonal springs (isotropic, k2 = k/2): a pulse sends a P and an S
                  wave
two-sources       ripple tank (u_z of a membrane): two point sources, their nodal lines
single-slit       ripple tank: a plane wave through one slit in a barrier
double-slit       ripple tank: a plane wave through two slits in a barrier
================= ==============================================================================
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from sim.model.lattice import Model
from sim.scenes import ripple_tank

PAPER_STIFFNESS = 35.0
"""The paper's default stiffness: 35 % of a maximum of 100 N/m."""


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named recipe: default model parameters plus how to set the initial condition.

    ``parameters``: keyword arguments of ``Model.create`` (``mass`` may name a layout of
    ``MASS_PATTERNS``); ``integrator``, ``dt`` (s) and ``duration`` (simulated s) are the
    recommended settings; ``initial(model)`` gives the (n_particles, dim) initial positions (m)
    and velocities (m/s) for the model built from them.
    """

    name: str
    description: str
    parameters: dict[str, Any]
    integrator: str
    dt: float
    initial: Callable[[Model], tuple[np.ndarray, np.ndarray]]
    duration: float = 20.0


def _rest(model: Model) -> tuple[np.ndarray, np.ndarray]:
    return model.rest_positions.copy(), np.zeros((model.n_particles, model.dim))


def _displace(picks: Callable[[Model], list[tuple[int, tuple[float, ...]]]]):
    def initial(model: Model) -> tuple[np.ndarray, np.ndarray]:
        positions, velocities = _rest(model)
        for particle, displacement in picks(model):
            positions[particle, : len(displacement)] += displacement
        return positions, velocities

    return initial


def _index(model: Model, column: int, row: int) -> int:
    return row * model.nx + column


def _centre(model: Model) -> int:
    return _index(model, model.nx // 2, model.ny // 2)


def _membrane_bump(model: Model) -> tuple[np.ndarray, np.ndarray]:
    positions, velocities = _rest(model)
    if model.dim == 3:
        rest = model.rest_positions
        half_width = (max(model.nx, model.ny) + 1) * model.spacing / 2
        radius_squared = (rest[:, 0] ** 2 + rest[:, 1] ** 2) / (0.25 * half_width) ** 2
        positions[:, 2] = 0.3 * model.spacing * np.exp(-radius_squared)
    return positions, velocities


def _two_sources(model: Model) -> list[tuple[int, tuple[float, ...]]]:
    """The middle particles of the left and right edges displaced in opposite directions, or,
    behind an absorbing layer, the first particles inside it."""
    inset = model.sponge_width if model.walls.absorbing else 0
    inset = min(inset, (model.nx - 1) // 2)
    return [
        (_index(model, inset, model.ny // 2), (0.0, 0.5 * model.spacing)),
        (_index(model, model.nx - 1 - inset, model.ny // 2), (0.0, -0.5 * model.spacing)),
    ]


def elastic_pulse(model: Model, width: float = 3.0, amplitude: float = 0.05):
    """A smooth pulse in the middle: every particle displaced along x by amplitude * a *
    exp(-r^2 / (2 (width a)^2)), r its distance from the centre; released from rest it sends a
    P wave along x and an S wave along y (``docs/continuum.md``)."""
    positions, velocities = _rest(model)
    rest = model.rest_positions
    centre = rest[_centre(model), :2]
    squared = ((rest[:, :2] - centre) ** 2).sum(axis=1) / (width * model.spacing) ** 2
    positions[:, 0] += amplitude * model.spacing * np.exp(-0.5 * squared)
    return positions, velocities


def _first_mode(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """Every particle displaced along the rows by a sin(pi i / (nx + 1)) (column i from 1): the
    lowest sine mode, one spacing high, at rest."""
    positions, velocities = _rest(model)
    columns = np.arange(model.n_particles) % model.nx + 1
    positions[:, 0] += model.spacing * np.sin(np.pi * columns / (model.nx + 1))
    return positions, velocities


FPUT_PERIOD = 2 * math.pi / (2 * math.sin(math.pi / 66))
"""Period (s) of the fput preset's lowest mode: 66.02 s."""


def chain_mode_frequency(mode: int, particles: int, stiffness_across: float, mass: float) -> float:
    """Frequency (Hz) of normal mode ``mode`` (1, 2, ...) of a chain of ``particles`` equal
    masses between fixed walls, for a spring stiffness ``stiffness_across`` (N/m; k for
    longitudinal motion, T/a for transverse): 2 sqrt(s/m) sin(n pi / (2 (N + 1))) / (2 pi)."""
    omega = 2.0 * math.sqrt(stiffness_across / mass) * math.sin(
        mode * math.pi / (2 * (particles + 1))
    )
    return omega / (2.0 * math.pi)


# the resonance preset: a 12-particle chain driven along its length at its third mode
_RESONANCE_FREQUENCY = chain_mode_frequency(3, 12, PAPER_STIFFNESS, 1.0)
# the bandgap preset: the 4 kg / 1 kg ionic chain, band edges sqrt(2k/M) and sqrt(2k/m) (rad/s)
_ACOUSTIC_TOP = math.sqrt(2 * PAPER_STIFFNESS / 4.0) / (2 * math.pi)
_OPTICAL_BOTTOM = math.sqrt(2 * PAPER_STIFFNESS / 1.0) / (2 * math.pi)
_OPTICAL_TOP = math.sqrt(2 * PAPER_STIFFNESS * (1 / 1.0 + 1 / 4.0)) / (2 * math.pi)


def ionic_masses(nx: int, ny: int, heavy: float = 4.0, light: float = 1.0) -> np.ndarray:
    """(ny, nx) masses (kg) of a checkerboard of ``heavy`` and ``light`` particles, heavy at (0, 0)."""
    rows, columns = np.indices((ny, nx))
    return np.where((rows + columns) % 2 == 0, heavy, light).astype(float)


PRESETS: dict[str, Preset] = {
    preset.name: preset
    for preset in [
        Preset(
            "single", "One particle held by four springs to the walls (paper Fig. 3).",
            dict(nx=1, ny=1, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(0, (0.3 * m.spacing, 0.2 * m.spacing))]),
        ),
        Preset(
            "square", "Four particles in a square; one is displaced and passes its energy on "
            "(paper Fig. 5).",
            dict(nx=2, ny=2, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(0, (0.3 * m.spacing, 0.3 * m.spacing))]),
        ),
        Preset(
            "chain", "Five particles in a line between two walls; the middle one is pushed "
            "along the chain (longitudinal waves; displace along y for transverse ones, Fig. 4).",
            dict(nx=5, ny=1, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(_index(m, m.nx // 2, 0), (0.3 * m.spacing, 0.0))]),
        ),
        Preset(
            "grid", "A 12x8 lattice (paper Fig. 2); a particle near the centre is displaced "
            "and the disturbance spreads to its neighbours (Fig. 6).",
            dict(nx=12, ny=8, stiffness=PAPER_STIFFNESS), "rk4", 0.01,
            _displace(lambda m: [(_centre(m), (0.4 * m.spacing, 0.3 * m.spacing))]),
        ),
        Preset(
            "ionic", "A 12x8 ionic crystal: a checkerboard of heavy (4 kg) and light (1 kg) "
            "particles; a heavy one is displaced and the light sublattice rings (paper Fig. 7).",
            dict(nx=12, ny=8, stiffness=PAPER_STIFFNESS, mass="ionic"), "rk4", 0.01,
            _displace(
                lambda m: [(_index(m, 2 * (m.nx // 4), 2 * (m.ny // 4)), (0.3 * m.spacing, 0.0))]
            ),
        ),
        Preset(
            "catenary", "A 15x10 lattice (150 particles) under gravity with dashpots: it sags "
            "and settles into catenary curves (paper Fig. 8).",
            dict(nx=15, ny=10, stiffness=PAPER_STIFFNESS, gravity=9.81, damping=2.0),
            "verlet", 0.01, _rest, duration=30.0,
        ),
        Preset(
            "interference", "The paper's continuum-limit run (Figs. 10-14): 682x383 = 261,206 "
            "particles, the middle particles of the left and right boundaries displaced in "
            "opposite directions; pre-tension (L = 0.8 a) lets the disturbance spread in 2-D.",
            # velocity Verlet at dt = 0.02 s keeps the energy balance within 1 % over 150 s at
            # less cost than RK4 at 0.05 s, which loses 60 % of the energy by numerical damping
            # of the short waves (docs/accuracy.md, "Live accuracy")
            dict(nx=682, ny=383, stiffness=PAPER_STIFFNESS, rest_length=0.8), "verlet", 0.02,
            _displace(_two_sources),
            duration=150.0,  # longitudinal fronts meet near t = 58 s, transverse ones near 130 s
        ),
        Preset(
            "interference-open", "The interference run with absorbing walls: a matched layer "
            "along every wall takes the waves out, so the pattern of the two sources "
            "(displaced just inside it) is seen without wall reflections.",
            dict(nx=682, ny=383, stiffness=PAPER_STIFFNESS, rest_length=0.8,
                 boundary="absorbing"),
            # the layer's splitting adds to Verlet's error: at dt = 0.02 s the energy balance
            # is off by 1.05 % over 150 s, at 0.015 s by 0.59 % (second order)
            "verlet", 0.015, _displace(_two_sources), duration=150.0,
        ),
        Preset(
            "resonance", "A chain of 12 particles with light drag, its first particle pushed "
            f"back and forth along the chain at the third mode's frequency (f3 = "
            f"{_RESONANCE_FREQUENCY:.4f} Hz): the amplitude builds up into a standing wave with "
            "3 loops.  Change the driver's frequency to see the response fall off the resonance.",
            dict(nx=12, ny=1, stiffness=PAPER_STIFFNESS, drag=0.1,
                 driver=dict(column=0, row=0, direction="x", amplitude=0.02,
                             frequency=_RESONANCE_FREQUENCY, kind="force", ramp=5.0)),
            "verlet", 0.01, _rest, duration=60.0,
        ),
        Preset(
            "bandgap", "An ionic chain (4 kg and 1 kg alternating, 100 particles, absorbing at "
            f"the right end) driven along its length at 0.95 Hz, inside the band gap "
            f"({_ACOUSTIC_TOP:.3f} to {_OPTICAL_BOTTOM:.3f} Hz): no wave can travel, the "
            "response dies out exponentially from the driven end.  Driven at 0.4 Hz "
            f"(acoustic band) or 1.4 Hz (optical band, up to {_OPTICAL_TOP:.3f} Hz) a wave "
            "travels to the absorbing end.",
            dict(nx=100, ny=1, stiffness=PAPER_STIFFNESS, mass="ionic", boundary="absorbing",
                 sponge_width=20, sponge_strength=2.0, sponge_sides="right",
                 driver=dict(column=0, row=0, direction="x", amplitude=0.02, frequency=0.95,
                             kind="force", ramp=5.0)),
            "verlet", 0.01, _rest, duration=60.0,
        ),
        Preset(
            "fput", "The Fermi-Pasta-Ulam-Tsingou chain (1955): 32 particles, k = m = a = 1, "
            "fixed ends, springs k (s + 0.25 s^2) acting along the chain; all the energy starts "
            "in the lowest mode.  It spreads to the next modes and, instead of being shared "
            "out, comes back: 98 % of it near 153 periods of mode 1 (t = 10,130 s).",
            # the linearised law's springs act along their rest direction: a chain moving along
            # itself is the FPU chain, its springs to the walls above and below exert nothing
            dict(nx=32, ny=1, stiffness=1.0, mass=1.0, linear=True, spring_alpha=0.25),
            "verlet", 0.05, _first_mode, duration=round(160 * FPUT_PERIOD),
        ),
        Preset(
            "membrane", "A 24x24 drum skin moving out of the plane (3-D), pre-tensioned "
            "(L = 0.9 a); a smooth bump in the middle is released and the membrane drums.",
            dict(nx=24, ny=24, dim=3, stiffness=PAPER_STIFFNESS, rest_length=0.9), "rk4", 0.02,
            _membrane_bump, duration=40.0,
        ),
        Preset(
            "elastic-solid", "An elastic solid: 160x160 particles with nearest springs k and "
            "diagonal springs k/2 (isotropic, Lame lambda = mu = k/2, unstressed).  A pulse in "
            "the middle, pushed along x, sends a fast P wave along x (speed a sqrt(3k/2m)) and "
            "a slower S wave along y (a sqrt(k/2m)).",
            dict(nx=160, ny=160, stiffness=PAPER_STIFFNESS,
                 diagonal_stiffness=PAPER_STIFFNESS / 2),
            # the fronts reach the walls 80 a away near t = 11 s (P) and 19 s (S)
            "verlet", 0.02, elastic_pulse, duration=16.0,
        ),
    ] + [
        # the ripple tank: waves cross the 190-column tank in about 70 s
        Preset(name, ripple_tank.DESCRIPTIONS[name], parameters, "verlet", 0.05, _rest,
               duration=90.0)
        for name, parameters in ripple_tank.PARAMETERS.items()
    ]
}


MASS_PATTERNS: dict[str, Callable[[int, int], np.ndarray]] = {"ionic": ionic_masses}
"""Named mass layouts a preset (or override) may give as ``mass``: (nx, ny) -> (ny, nx) kg."""
