"""The energy of a chain's lowest normal modes over time, and the returns of the first mode's
share: the Fermi-Pasta-Ulam-Tsingou experiment's instrument.

A chain of equal masses between fixed walls has the sine modes of ``sim.theory.modes``: mode k
has the shape sin(k pi n / (N + 1)) and the frequency omega_k; its harmonic energy is
E_k = (P_k^2 + omega_k^2 Q_k^2) / 2 in mass-weighted modal coordinates.  ``ModeShares`` samples
E_1 .. E_K along the chain (the x motion) and the total harmonic energy of every mode, at the
times a run gives it; ``recurrences`` finds the times the first mode's share comes back: each
excursion of the share above ``RETURN_SHARE`` after it fell below ``AWAY_SHARE``, at its
peak.  With nonlinear
springs the harmonic energies are not conserved one by one (the sum is the quadratic part of
the energy); that exchange is what the experiment shows.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sim.model.lattice import Model, ModelError
from sim.theory.modes import ModalBasis, mode_energies

AWAY_SHARE = 0.25
"""Mode 1's energy has gone when its share falls below this ..."""
RETURN_SHARE = 0.5
"""... and has come back when it rises above this again (the peak of that excursion, until the
share falls below ``AWAY_SHARE`` once more, is the return)."""
PAST_PEAK = 0.02
"""A return still above ``AWAY_SHARE`` at the end of the samples counts once the share is this
much below its peak."""
SAMPLES_PER_PERIOD = 20
"""Samples per period of the first mode that a run takes (its peaks are then found to within
a twentieth of a period)."""


@dataclasses.dataclass(frozen=True)
class Recurrence:
    """A return of mode 1's energy: its ``time`` (s), in ``periods`` of mode 1, and mode 1's
    ``share`` of the harmonic energy then."""

    time: float
    periods: float
    share: float


class ModeShares:
    """Harmonic energies of modes 1 .. ``modes`` of a one-row chain's motion along itself."""

    def __init__(self, model: Model, modes: int = 8) -> None:
        if model.ny != 1 or not model.uniform_mass or model.row_ends != "walls":
            raise ModelError("the modes' shares are measured on a one-row chain of equal masses "
                             f"between fixed walls; this is a {model.nx}x{model.ny} lattice with "
                             f"{model.boundary} walls")
        self.model = model
        self.modes = max(1, min(int(modes), model.nx))
        self.basis = ModalBasis.of(model)
        omega = math.sqrt(float(self.basis.omega_squared[0].reshape(-1)[0]))
        self.period = 2.0 * math.pi / omega
        """Period (s) of mode 1."""
        self.samples_per_period = SAMPLES_PER_PERIOD
        self._times: list[float] = []
        self._energies: list[np.ndarray] = []
        self._totals: list[float] = []

    def add(self, time: float, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Sample the state at ``time`` (s): (n_particles, dim) positions (m), velocities (m/s)."""
        energies = mode_energies(self.model, positions, velocities, self.basis)[0].reshape(-1)
        self._times.append(float(time))
        self._energies.append(energies[: self.modes].copy())
        self._totals.append(float(energies.sum()))

    @property
    def times(self) -> np.ndarray:
        return np.asarray(self._times)

    @property
    def energies(self) -> np.ndarray:
        """(samples, modes) harmonic energies (J)."""
        return np.asarray(self._energies).reshape(-1, self.modes)

    @property
    def shares(self) -> np.ndarray:
        """(samples, modes): each mode's share of the harmonic energy of every mode."""
        totals = np.asarray(self._totals)[:, None]
        return self.energies / np.where(totals > 0, totals, 1.0)

    def recurrences(self) -> list[Recurrence]:
        """Every return of mode 1's share above ``RETURN_SHARE`` after it fell below
        ``AWAY_SHARE``, at its peak (the last one once the share is ``PAST_PEAK`` below it)."""
        share = self.shares[:, 0] if self._times else np.zeros(0)
        times = self.times
        found, away, peak = [], False, None
        for index, value in enumerate(share):
            if value < AWAY_SHARE:
                if peak is not None:
                    found.append(peak)
                    peak = None
                away = True
            elif away and (peak is not None or value > RETURN_SHARE) and (
                    peak is None or value > share[peak]):
                peak = index
        if peak is not None and share[-1] < share[peak] - PAST_PEAK:
            found.append(peak)  # the share has turned down since: that return has peaked
        return [Recurrence(float(times[i]), float(times[i] / self.period), float(share[i]))
                for i in found]

    def lowest_share(self) -> tuple[float, float]:
        """(time in periods of mode 1, share) where mode 1's share is lowest before its first
        return."""
        share = self.shares[:, 0]
        returns = self.recurrences()
        end = np.searchsorted(self.times, returns[0].time) if returns else share.size
        index = int(np.argmin(share[:max(1, end)]))
        return float(self.times[index] / self.period), float(share[index])

    def report(self, points: int = 2000) -> dict:
        """The series (at most ``points`` samples, evenly thinned) and the returns, as JSON."""
        every = max(1, math.ceil(len(self._times) / points))
        returns = self.recurrences()
        lowest = self.lowest_share() if self._times else (None, None)
        return {
            "mode_period": self.period,
            "modes": list(range(1, self.modes + 1)),
            "times": self.times[::every].tolist(),
            "mode_energies": self.energies[::every].tolist(),
            "harmonic_energy": np.asarray(self._totals)[::every].tolist(),
            "lowest_share": {"periods": lowest[0], "share": lowest[1]},
            "recurrences": [dataclasses.asdict(r) for r in returns],
            "first_recurrence": dataclasses.asdict(returns[0]) if returns else None,
        }
