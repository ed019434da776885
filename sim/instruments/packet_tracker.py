"""The packet tracker: a wave packet's group and phase speeds measured from a run.

``PacketTracker(model, spec)`` follows the packet ``spec`` (``sim.theory.wave_packet``) launched
into ``model``: ``add(time, positions)`` at each frame keeps three numbers of the displacement u
along the packet's polarisation vector (from the equilibrium), and ``speeds()`` fits them.

* **Group speed**: the centroid of u^2 (x and y, weights u^2 of every particle) against time,
  fitted by a straight line; its slope is the packet's velocity, projected on the direction of
  the theory's group velocity.  For a packet of one branch the u^2 centroid moves at the mean of
  d omega / d q over the packet's wave vectors, weighted by |A(k)|^2: the group velocity at q up
  to the envelope's spread of wave vectors (about -(a / 4 sigma)^2 relative on a chain, sigma the
  envelope's standard deviation; the envelope is made wide enough across q for the same,
  ``sim.theory.wave_packet.ACROSS_BIAS``).  The carrier's 2 omega ripple in u^2 averages out of
  the fit.
* **Phase speed**: Z(t) = sum over particles of u e^(-i q . r), the lattice's Fourier
  coefficient of the field at q.  Each plane wave of the infinite lattice keeps its own
  frequency, so the forward packet's Z turns as e^(-i omega t) whatever its envelope; the
  measured omega is minus the slope of Z's unwrapped phase against time (a straight-line fit),
  and the phase speed omega / |q|.  Unwrapping needs samples closer than half a period; sparser
  ones are unwrapped about the theory's omega (which then only counts the whole turns between
  samples: the measurement holds while |omega - omega_theory| times the interval is below pi).

Limits: both hold while the packet is clear of the walls (what reaches a wall reflects and
brings waves of other wave vectors back): samples later than the plan's ``clear_time`` after the
first one are not kept.  The lattice must be linear enough (small amplitude) and undamped enough
for the packet to keep its shape; a driver or sources add their own waves.
"""

from __future__ import annotations

import math

import numpy as np

from sim.model.lattice import Model
from sim.theory.modes import static_offset
from sim.theory.wave_packet import PacketSpec, plan

LIMIT = 1 << 16
"""Most samples a tracker keeps (later ones are dropped)."""


class PacketTracker:
    """Centroid and Fourier coefficient of a packet's field, sampled at the frames of a run
    (see the module's docstring); ``speeds()`` gives the measured speeds."""

    def __init__(self, model: Model, spec: PacketSpec) -> None:
        self.model, self.spec = model, spec
        self.packet = plan(model, spec)
        equilibrium = static_offset(model).reshape(model.dim, -1).T
        self.rest = model.rest_positions + equilibrium
        self.vector = self.packet.vector
        self.xy = np.ascontiguousarray(model.rest_positions[:, :2])
        self.carrier = np.exp(-1j * (self.xy @ self.packet.q))
        self.clear_time = self.packet.clear_time
        self._samples: list[tuple[float, float, float, complex]] = []
        """(time, centroid x, centroid y, Fourier coefficient) per kept frame: one tuple
        appended at a time, so a reader in another thread (the page's) always sees whole
        samples, and ``clear`` puts a new list in place."""

    def clear(self) -> None:
        self._samples = []

    def add(self, time: float, positions: np.ndarray) -> None:
        """Keep the centroid and Fourier coefficient of a frame at ``time`` (s) with
        (n_particles, dim) ``positions`` (m).  An earlier time than the last starts again
        (the run was reset); frames after the clear time are not kept."""
        time = float(time)
        samples = self._samples
        if samples:
            first, last = samples[0][0], samples[-1][0]
            if time < last:
                self.clear()
                samples = self._samples
            elif time == last or time - first > self.clear_time or len(samples) >= LIMIT:
                return
        field = (np.asarray(positions, dtype=float) - self.rest) @ self.vector
        weights = field * field
        total = float(weights.sum())
        if total > 0:
            centroid = tuple(float(v) for v in weights @ self.xy / total)
        else:
            centroid = (math.nan, math.nan)
        samples.append((time, centroid[0], centroid[1], complex(field @ self.carrier)))

    @property
    def times(self) -> np.ndarray:
        """Times (s) of the kept samples."""
        return np.array([sample[0] for sample in list(self._samples)])

    @property
    def centroids(self) -> np.ndarray:
        """(samples, 2) centroids (m) of u^2."""
        return np.array([sample[1:3] for sample in list(self._samples)]).reshape(-1, 2)

    def speeds(self) -> dict:
        """The measured speeds: ``group_velocity`` (vx, vy) (m/s) of the centroid,
        ``group_speed`` (m/s) its part along the theory's group velocity, ``omega`` (rad/s) of
        the Fourier coefficient at q, ``phase_speed`` = omega / |q| (m/s), and ``samples``,
        ``span`` (s) and ``unwrapped_about_theory`` (whether the samples were too sparse to
        unwrap the phase alone).  None where fewer than three samples were kept."""
        samples = list(self._samples)  # one consistent snapshot, whatever add() does meanwhile
        times = np.array([sample[0] for sample in samples])
        result: dict = {"group_velocity": None, "group_speed": None, "omega": None,
                        "phase_speed": None, "samples": int(times.size),
                        "span": float(times[-1] - times[0]) if times.size else 0.0,
                        "unwrapped_about_theory": False}
        if times.size < 3 or not times[-1] > times[0]:
            return result
        elapsed = times - times[0]
        centroids = np.array([sample[1:3] for sample in samples]).reshape(-1, 2)
        if np.all(np.isfinite(centroids)):
            velocity = [float(np.polyfit(elapsed, centroids[:, i], 1)[0]) for i in range(2)]
            result["group_velocity"] = velocity
            result["group_speed"] = float(np.dot(velocity, self.packet.direction))
        coefficients = np.array([sample[3] for sample in samples])
        if np.all(coefficients != 0):
            omega_theory = self.packet.omega
            sparse = float(np.diff(elapsed).max()) > 0.5 * math.pi / omega_theory
            reference = omega_theory if sparse else 0.0
            phase = np.unwrap(np.angle(coefficients * np.exp(1j * reference * elapsed)))
            omega = reference - float(np.polyfit(elapsed, phase, 1)[0])
            result["omega"] = omega
            result["phase_speed"] = omega / float(np.hypot(*self.packet.q))
            result["unwrapped_about_theory"] = sparse
        return result
