"""Wave packets: a plane wave of one wave vector and one polarisation under a Gaussian envelope,
launched so that it travels one way, and what theory says of its speeds.

A packet is named by a ``PacketSpec``: the wave vector q = (qx, qy) (rad/m, inside the first zone
|qx|, |qy| <= pi / a), the polarisation (a name of ``polarisation_names(model)``) and its length
in wavelengths.  Its displacement is

    u(r) = A E(r) cos(q . (r - c)) e           (e: the polarisation's unit vector)

with E a Gaussian envelope centred on c, and its velocities are those of the wave travelling
forward, u(r, t) ~ E(r - c - vg t) cos(q . (r - c) - omega t): to first order
du/dt = A E omega sin(q . (r - c)) - A (vg . grad E) cos(q . (r - c)).  They are computed exactly
for the infinite lattice, wave vector by wave vector (a discrete Fourier transform of the
lattice: each component k of the packet gets the velocity of its own forward wave,
-i omega(k)), so no backward wave is launched; with diagonal springs each component is also
projected on the branch's own eigenvector at k.

Polarisations: on a lattice of nearest springs each displacement component obeys its own wave
equation (``sim.theory.lattice_waves``): "x", "y" (in the plane) and, in 3-D, "z".  With diagonal
springs (``model.diagonal_stiffness > 0``) the in-plane components are coupled: "S" is the lower
branch and "P" the upper one (eigenvectors of ``dynamical_matrix``; along an axis S is transverse
and P longitudinal), and "z" in 3-D.  On the ionic checkerboard (masses M and m alternating, nearest
springs) the branches are those of ``sim.theory.bands`` ("x acoustic", "x optical", ...): a
Bloch wave of the two-particle cell with the sublattices' amplitudes of the branch's
eigenvector, its velocities to first order in the envelope's slope (``_bloch_packet``).  Other
unequal masses have no bands and are refused.

Geometry (``plan``): the envelope's full width at half maximum along q is ``lengths``
wavelengths; across q it is at least as wide, and wider when the group velocity changes with the
wave vector across q (a narrow packet holds wave vectors across q whose group velocities differ:
the envelope is made wide enough that its centroid moves within ``ACROSS_BIAS`` of the group
velocity at q).  The packet starts as far back against the group velocity as it fits, its
``EDGE``-sigma ellipse inside the walls (inside an absorbing layer), and ``clear_time`` is when
that ellipse (growing by dispersion, Sigma(t) = Sigma0 + t^2 H Sigma0^-1 H, H the Hessian of
omega) first reaches a wall: measurements of its speeds hold until then.

Units: m, kg, s; q in rad/m, omega in rad/s, speeds in m/s.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np

from sim.forces import registry
from sim.model.lattice import Model
from sim.theory.bands import BandStructure, ionic_pair
from sim.theory.lattice_waves import WaveError, dynamical_matrix, polarisation
from sim.theory.modes import static_offset

DEFAULT_LENGTHS = 4.0
"""Full width at half maximum of the envelope along q, in wavelengths."""
DEFAULT_AMPLITUDE = 0.01
"""Peak displacement, in lattice spacings: small enough for the linear regime."""
EDGE = 3.0
"""The packet's edge, in standard deviations of its envelope (amplitude 1.1 % of the peak)."""
ACROSS_BIAS = 0.0025
"""Largest relative shift of the centroid's speed the envelope's width across q may cause."""
WIDEST_ACROSS = 10.0
"""The envelope is at most this many times wider across q than along it."""
FWHM = 2.0 * math.sqrt(2.0 * math.log(2.0))
"""Full width at half maximum of a Gaussian, in standard deviations."""


@dataclasses.dataclass(frozen=True)
class PacketSpec:
    """A wave packet: wave vector (``qx``, ``qy``) (rad/m), polarisation name (see
    ``polarisation_names``) and the envelope's full width at half maximum along q, ``lengths``
    wavelengths."""

    qx: float
    qy: float
    polarisation: str
    lengths: float = DEFAULT_LENGTHS


def polarisation_names(model: Model) -> tuple[str, ...]:
    """The polarisations a packet on ``model`` may have: ("x", "y"[, "z"]) with nearest springs
    only, ("S", "P"[, "z"]) with diagonal springs ("z" in 3-D); on the ionic checkerboard the
    branches of ``sim.theory.bands`` ("x acoustic", "x optical", ...)."""
    if ionic_pair(model) is not None:
        return tuple(f"{c} {kind}" for c in "xyz"[: model.dim] for kind in ("acoustic", "optical"))
    names = ("S", "P") if registry.linear_stiffness(model).diagonal > 0 else ("x", "y")
    return names + (("z",) if model.dim == 3 else ())


class _Branch:
    """One branch's frequency omega(qx, qy) (rad/s) and polarisation vectors e(qx, qy)
    (unit, ``dim`` components), vectorised over arrays of wave vectors."""

    def __init__(self, model: Model, name: str) -> None:
        self.model, self.name, self.dim = model, name, model.dim
        self.coupled = name in ("S", "P")
        if not self.coupled:
            self.component = "xyz".index(name)
            self.wave = polarisation(model, name)

    def _eigen(self, qx, qy) -> tuple[np.ndarray, np.ndarray]:
        values, vectors = np.linalg.eigh(dynamical_matrix(self.model, qx, qy))
        index = 0 if self.name == "S" else 1
        return np.sqrt(np.maximum(values[..., index], 0.0)), vectors[..., :, index]

    def omega(self, qx, qy) -> np.ndarray:
        if self.coupled:
            return self._eigen(qx, qy)[0]
        return self.wave.omega(qx, qy)

    def vectors(self, qx, qy) -> np.ndarray:
        qx, qy = np.broadcast_arrays(np.asarray(qx, float), np.asarray(qy, float))
        result = np.zeros(qx.shape + (self.dim,))
        if self.coupled:
            result[..., :2] = self._eigen(qx, qy)[1]
        else:
            result[..., self.component] = 1.0
        return result


class _IonicBranch:
    """One branch of the ionic checkerboard (masses M and m, ``sim.theory.bands``): a Bloch wave
    of the two-particle cell, u_j = Re(a_s e^(i q . r_j)) e along one component e, with the
    amplitudes (a_M, a_m) of the heavy and light sublattices from the eigenvector w of the
    mass-weighted dynamical matrix, a = w / sqrt(mass) (``cell``)."""

    coupled = False

    def __init__(self, model: Model, name: str) -> None:
        component, kind = name.split()
        self.model, self.name, self.dim = model, name, model.dim
        self.component = "xyz".index(component)
        self.index = 0 if kind == "acoustic" else 1
        self.structure = BandStructure(model)
        self.pair = ionic_pair(model)

    def _eigen(self, qx, qy) -> tuple[np.ndarray, np.ndarray]:
        if self.structure.chain:  # one row between walls: its one sine mode across
            qy = np.full_like(np.asarray(qx, dtype=float), 0.5 * math.pi / self.model.spacing)
        matrix = self.structure.ionic_matrices(np.asarray(qx, float), np.asarray(qy, float))
        values, vectors = np.linalg.eigh(matrix[self.component])
        return np.sqrt(np.maximum(values[..., self.index], 0.0)), vectors[..., :, self.index]

    def omega(self, qx, qy) -> np.ndarray:
        return self._eigen(qx, qy)[0]

    def vectors(self, qx, qy) -> np.ndarray:
        qx, qy = np.broadcast_arrays(np.asarray(qx, float), np.asarray(qy, float))
        result = np.zeros(qx.shape + (self.dim,))
        result[..., self.component] = 1.0
        return result

    def cell(self, qx: float, qy: float) -> tuple[float, float]:
        """(a_M, a_m): the heavy and light sublattices' amplitudes at q, the larger 1."""
        heavy, light = self.pair
        w = self._eigen(qx, qy)[1]
        amplitudes = np.array([w[0] / math.sqrt(heavy), w[1] / math.sqrt(light)])
        amplitudes /= float(np.abs(amplitudes).max())
        return float(amplitudes[0]), float(amplitudes[1])


def branch(model: Model, name: str) -> _Branch | _IonicBranch:
    """The branch called ``name`` of ``model`` (raises WaveError for an unknown name, or for
    unequal masses that are not the ionic checkerboard)."""
    ionic = ionic_pair(model) is not None
    if not model.uniform_mass and not ionic:
        raise WaveError("a wave packet of one wave vector needs equal masses or the ionic "
                        "checkerboard (other masses have no repeating cell, so no bands)")
    if ionic and registry.linear_stiffness(model).diagonal:
        raise WaveError("the ionic checkerboard with diagonal springs has no bands drawn")
    names = polarisation_names(model)
    if name not in names:
        raise WaveError(f"polarisation must be one of {', '.join(names)} on this lattice, "
                        f"got {name!r}")
    return _IonicBranch(model, name) if ionic else _Branch(model, name)


def _gradient(function, q: np.ndarray, step: float) -> np.ndarray:
    return np.array([(function(*(q + step * axis)) - function(*(q - step * axis))) / (2 * step)
                     for axis in np.eye(2)])


def _hessian(function, q: np.ndarray, step: float) -> np.ndarray:
    return np.array([_gradient(function, q + step * axis, step)
                     - _gradient(function, q - step * axis, step) for axis in np.eye(2)]) \
        / (2 * step)


@dataclasses.dataclass(frozen=True)
class Packet:
    """A packet's numbers on one model: ``omega`` (rad/s), ``group_velocity`` (m/s, (2,)),
    ``vector`` (its polarisation at q, ``dim`` components), the envelope's standard deviations
    ``sigma_along`` / ``sigma_across`` q (m; inf across: uniform, a plane front, where nothing
    couples the rows or columns across q) and its inverse covariance ``precision`` (1/m^2), its
    start ``centre`` (m, (2,)), ``hessian`` of omega (m^2/s), ``clear_time`` (s: when its edge
    first reaches a wall)."""

    model: Model
    spec: PacketSpec
    branch: _Branch
    omega: float
    group_velocity: np.ndarray
    vector: np.ndarray
    sigma_along: float
    sigma_across: float
    precision: np.ndarray
    centre: np.ndarray
    hessian: np.ndarray
    clear_time: float

    @property
    def q(self) -> np.ndarray:
        return np.array([self.spec.qx, self.spec.qy], dtype=float)

    @property
    def direction(self) -> np.ndarray:
        """Unit vector of the group velocity (of q where the group velocity is zero)."""
        speed = float(np.hypot(*self.group_velocity))
        return self.group_velocity / speed if speed > 0 else self.q / float(np.hypot(*self.q))

    @property
    def plane(self) -> bool:
        """Whether the envelope is uniform across q (a plane front: a chain, or rows that
        nothing couples)."""
        return math.isinf(self.sigma_across)

    def extent(self, time: float) -> np.ndarray:
        """Half widths (m) along x and y of the packet's ``EDGE``-sigma ellipse at ``time`` (s)
        after launch, grown by quadratic dispersion (Sigma0 + t^2 H Sigma0^-1 H); 0 across a
        plane front."""
        if self.plane:
            along = self.q / float(np.hypot(*self.q))
            curvature = float(along @ self.hessian @ along)
            width = math.sqrt(self.sigma_along**2 + (time * curvature / self.sigma_along) ** 2)
            return EDGE * width * np.abs(along)
        covariance = np.linalg.inv(self.precision)
        spread = covariance + time**2 * self.hessian @ self.precision @ self.hessian
        return EDGE * np.sqrt(np.diag(spread))


def check_spec(model: Model, spec: PacketSpec) -> None:
    """Refuse a wave vector outside the first zone, zero, not finite, with qy != 0 on a chain,
    or a length that is not a positive number (WaveError)."""
    edge = math.pi / model.spacing
    for name, value in (("qx", spec.qx), ("qy", spec.qy)):
        if isinstance(value, bool) or not (isinstance(value, numbers.Real)
                                           and math.isfinite(value)):
            raise WaveError(f"{name} must be a finite number of rad/m, got {value!r}")
        if abs(value) > edge * (1 + 1e-12):
            raise WaveError(f"{name} = {value:g} rad/m is outside the first zone: |{name}| <= "
                            f"pi / a = {edge:.6g} rad/m")
    if spec.qx == 0 and spec.qy == 0:
        raise WaveError("the wave vector must not be zero (a packet needs a wavelength)")
    if model.ny == 1 and spec.qy != 0:
        raise WaveError(f"a chain (ny = 1) carries waves along x only: qy must be 0, got "
                        f"{spec.qy:g} rad/m")
    if not (math.isfinite(spec.lengths) and spec.lengths > 0):
        raise WaveError(f"the packet's length must be a positive number of wavelengths, got "
                        f"{spec.lengths!r}")


def plan(model: Model, spec: PacketSpec) -> Packet:
    """The packet's frequency, group velocity, envelope, start and clear time on ``model``
    (see the module's docstring); raises WaveError for a refused spec or a branch that carries
    no wave at q."""
    check_spec(model, spec)
    wave = branch(model, spec.polarisation)
    a = model.spacing
    q = np.array([spec.qx, spec.qy], dtype=float)
    omega = float(wave.omega(*q))
    if not omega > 0.0:
        raise WaveError(f"the {spec.polarisation} branch carries no wave at q = ({spec.qx:g}, "
                        f"{spec.qy:g}) rad/m (omega = 0: no spring resists that motion)")

    def frequency(qx, qy):
        return float(wave.omega(qx, qy))

    velocity = _gradient(frequency, q, 1e-6 / a)
    hessian = _hessian(frequency, q, 1e-4 / a)
    along = q / float(np.hypot(*q))
    across = np.array([-along[1], along[0]])
    wavelength = 2 * math.pi / float(np.hypot(*q))
    sigma_along = spec.lengths * wavelength / FWHM
    sigma_across = sigma_along
    speed = float(np.hypot(*velocity))
    if model.ny == 1 or _independent_across(frequency, q, across, a):
        sigma_across = math.inf  # nothing couples the rows (columns): one plane front
    elif speed > 0:
        direction = velocity / speed
        step = 0.01 / a

        def projected(qx, qy):  # the group velocity along the packet's direction
            return float(_gradient(frequency, np.array([qx, qy]), 1e-5 / a) @ direction)

        curvature = (projected(*(q + step * across)) - 2 * projected(*q)
                     + projected(*(q - step * across))) / step**2
        # the envelope's |A(k)|^2 has variance 1 / (2 sigma^2) across q: the centroid's speed
        # shifts by curvature / (4 sigma^2)
        needed = math.sqrt(abs(curvature) / (4 * ACROSS_BIAS * speed))
        sigma_across = min(max(sigma_along, needed), WIDEST_ACROSS * sigma_along)
    frame = np.column_stack([along, across])
    precision = frame @ np.diag([sigma_along**-2, sigma_across**-2]) @ frame.T
    packet = Packet(model, spec, wave, omega, velocity, wave.vectors(*q), sigma_along,
                    sigma_across, precision, np.zeros(2), hessian, 0.0)
    centre = _start(packet)
    packet = dataclasses.replace(packet, centre=centre)
    return dataclasses.replace(packet, clear_time=_clear_time(packet))


def _region(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(lowest, highest) (x, y) (m) the packet may reach: the walls, or one spacing inside the
    inner edges of an absorbing layer."""
    half = np.array([(model.nx + 1) / 2, (model.ny + 1) / 2]) * model.spacing
    low, high = -half, half.copy()
    if model.walls.absorbing:
        # to the first particle none of whose springs the layer relaxes: what starts inside
        # the layer excites its slow zero-frequency modes (``sim.forces.absorbing_kicks.SHIFT``)
        inset = (model.sponge_width + 1) * model.spacing
        sides = model.sponge_sides
        low = low + inset * np.array(["left" in sides, "bottom" in sides])
        high = high - inset * np.array(["right" in sides, "top" in sides])
    return low, high


def _independent_across(frequency, q: np.ndarray, across: np.ndarray, a: float) -> bool:
    """Whether omega does not change across q at all (a branch with no stiffness across)."""
    shifts = np.linspace(-math.pi / a, math.pi / a, 7)
    values = np.array([frequency(*(q + shift * across)) for shift in shifts])
    return bool(np.ptp(values) <= 1e-12 * values.max())


def _start(packet: Packet) -> np.ndarray:
    """The centre (m) as far back against the group velocity as the packet's edge fits."""
    if not np.any(packet.group_velocity):
        low, high = _region(packet.model)
        return 0.5 * (low + high)
    direction = packet.direction
    low, high = _region(packet.model)
    middle = 0.5 * (low + high)
    room = 0.5 * (high - low) - packet.extent(0.0)
    back = [room[i] / abs(direction[i]) for i in range(2) if abs(direction[i]) > 1e-12]
    return middle - max(0.0, min(back)) * direction


def _clear_time(packet: Packet) -> float:
    """The first time (s) the packet's edge reaches a wall (0: it does not fit at launch)."""
    low, high = _region(packet.model)

    def fits(time: float) -> bool:
        centre = packet.centre + packet.group_velocity * time
        extent = packet.extent(time)
        return bool(np.all(centre - extent >= low) and np.all(centre + extent <= high))

    if not fits(0.0):
        return 0.0
    speed = float(np.hypot(*packet.group_velocity))
    horizon = 2 * float(np.max(high - low)) / speed if speed > 0 else 1e4 * 2 * math.pi / packet.omega
    times = np.linspace(0.0, horizon, 2001)
    bad = [time for time in times[1:] if not fits(float(time))]
    if not bad:
        return float(horizon)
    high = float(bad[0])
    low = high - float(times[1])
    for _ in range(40):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if fits(middle) else (low, middle)
    return low


def theory(model: Model, spec: PacketSpec) -> dict:
    """What theory says of the packet (the lattice's dispersion relation at q):

    ``omega`` (rad/s) and ``frequency`` (Hz); ``group_velocity`` (vx, vy) = d omega / d q (m/s);
    ``group_speed_theory`` = |d omega / d q| (m/s), the speed of the envelope along its
    direction of travel (the group velocity's own direction, which on an anisotropic lattice
    need not be that of q); ``phase_speed_theory`` = omega / |q| (m/s), the speed of the crests
    along q; ``wavelength`` 2 pi / |q| (m); ``polarisation_vector`` at q; the envelope's
    ``sigma_along`` and ``sigma_across`` q (m; None across a plane front), its start
    ``centre`` (x, y) (m), and ``clear_time`` (s) with ``clear_distance`` (m): how long and
    how far it travels before its edge reaches a wall."""
    packet = plan(model, spec)
    speed = float(np.hypot(*packet.group_velocity))
    return {
        "omega": packet.omega, "frequency": packet.omega / (2 * math.pi),
        "group_velocity": [float(v) for v in packet.group_velocity],
        "group_speed_theory": speed,
        "phase_speed_theory": packet.omega / float(np.hypot(*packet.q)),
        "wavelength": 2 * math.pi / float(np.hypot(*packet.q)),
        "polarisation_vector": [float(v) for v in packet.vector],
        "sigma_along": packet.sigma_along,
        "sigma_across": None if packet.plane else packet.sigma_across,
        "centre": [float(v) for v in packet.centre],
        "clear_time": packet.clear_time, "clear_distance": speed * packet.clear_time,
    }


def packet_state(model: Model, spec: PacketSpec,
                 amplitude: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(positions (m), velocities (m/s)) as (n_particles, dim) arrays: the lattice at its
    equilibrium plus the packet, peak displacement ``amplitude`` (m; default
    ``DEFAULT_AMPLITUDE`` spacings), moving forward along its group velocity (module
    docstring)."""
    packet = plan(model, spec)
    if amplitude is None:
        amplitude = DEFAULT_AMPLITUDE * model.spacing
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise WaveError(f"the amplitude must be a positive number of metres, got {amplitude!r}")
    rest = model.rest_positions
    offset = rest[:, :2] - packet.centre
    envelope = np.exp(-0.5 * np.einsum("pi,ij,pj->p", offset, packet.precision, offset))
    equilibrium = static_offset(model).reshape(model.dim, -1).T
    if isinstance(packet.branch, _IonicBranch):
        displacement, velocity = _bloch_packet(packet, offset, envelope, amplitude)
        return rest + equilibrium + displacement, velocity
    field = (amplitude * envelope * np.exp(1j * offset @ packet.q)).reshape(model.ny, model.nx)
    spectrum = np.fft.fft2(field)
    kx = 2 * np.pi * np.fft.fftfreq(model.nx, model.spacing)
    ky = 2 * np.pi * np.fft.fftfreq(model.ny, model.spacing)
    kx, ky = np.meshgrid(kx, ky)
    omega = packet.branch.omega(kx, ky)
    vectors = packet.branch.vectors(kx, ky)  # (ny, nx, dim)
    if packet.branch.coupled:  # keep the branch's own part of each wave vector
        vectors = vectors * (vectors @ packet.vector)[..., None]
    displacement = np.empty((model.n_particles, model.dim))
    velocity = np.empty_like(displacement)
    for component in range(model.dim):
        part = spectrum * vectors[..., component]
        displacement[:, component] = np.fft.ifft2(part).real.ravel()
        velocity[:, component] = np.fft.ifft2(omega * part).imag.ravel()
    return rest + equilibrium + displacement, velocity


def _bloch_packet(packet: Packet, offset: np.ndarray, envelope: np.ndarray,
                  amplitude: float) -> tuple[np.ndarray, np.ndarray]:
    """A packet of the ionic checkerboard's branch: u = A E Re(c), c = a_s e^(i q . (r - c0)),
    moving forward, du/dt = A (omega E Im(c) - (vg . grad E) Re(c)) (the module docstring's
    first order in the envelope's slope; the envelope spans several wavelengths)."""
    model = packet.model
    heavy, light = packet.branch.cell(*packet.q)
    rows, columns = np.indices((model.ny, model.nx))
    sublattice = np.where(((rows + columns) % 2 == 0).ravel(), heavy, light)
    carrier = sublattice * np.exp(1j * (offset @ packet.q))
    slope = envelope * (offset @ packet.precision @ packet.group_velocity)  # -vg . grad E
    displacement = np.zeros((model.n_particles, model.dim))
    velocity = np.zeros_like(displacement)
    component = packet.branch.component
    displacement[:, component] = amplitude * envelope * carrier.real
    velocity[:, component] = amplitude * (packet.omega * envelope * carrier.imag
                                          + slope * carrier.real)
    return displacement, velocity


def default_polarisation(model: Model, qx: float, qy: float) -> str:
    """The first of ``polarisation_names(model)`` that carries a wave at (qx, qy) (rad/m):
    "x" (or "S" with diagonal springs) unless no spring resists that motion at q."""
    names = polarisation_names(model)
    for name in names:
        if float(branch(model, name).omega(qx, qy)) > 0:
            return name
    return names[0]
