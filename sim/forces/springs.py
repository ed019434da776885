"""Numba kernels: the spring forces of the lattice, computed one row of particles at a time.

Everything here is a pure function over arrays and scalars, compiled with ``@njit(cache=True)``;
the loop shapes (``sim.loops``: row sweep, row blocks, wavefront, leapfrog) fuse the integrators'
updates into sweeps over these row functions, and the Python layer (``sim.integrators.steppers``,
``sim.runtime.simulation``) orchestrates.

Layout (chosen for speed, see ``docs/speed.md``):

* a field over the lattice is a C-contiguous ``(ny, nx)`` float64 array per component:
  ``x, y`` (and ``z`` for out-of-plane motion) in m, ``vx, vy, vz`` in m/s;
* particle ``(row j, column i)`` rests at ``(origin_x + i*spacing, origin_y + j*spacing)``; the wall
  anchors sit one spacing outside the lattice on all four sides and never move, so they are not
  stored: a spring to a wall is the same spring computation with an anchor (``site``) as one end;
* ``SpringParameters.periodic`` joins the ends of every row into a ring (the left and right
  wall springs become one spring between the last and the first particle of the row), again
  chosen at compile time; rows stay independent sweeps, so the wavefronts are unchanged;
  ``SpringParameters.free_ends`` removes the left and right wall springs (free ends), likewise;
* each spring is computed once per sweep: ``vertical_springs(j)`` gives the forces of the springs
  that end in row j from below (row j-1 to j; j = 0 from the bottom wall, j = ny to the top wall),
  a buffer of ``nx``; ``horizontal_springs(j)`` those of row j, a buffer of ``nx + 1``;
  ``row_accelerations`` sums them for the particles of row j.  A sweep keeps the buffer of the
  springs below the current row from the previous row, so rows already swept may be overwritten:
  that lets the integrators fuse their updates into the force sweep.

Specialisation: optional terms are passed as ``None`` when a scene does not have them (``z, vz``
for a planar scene, ``dashpot``, ``drag``, ``gravity``), and so are the compile-time choices of
the spring law (``linearised``) and of a row's ends (wall anchors or particles).  Numba compiles
one machine-code version per combination of argument types and prunes the ``is None`` branches
at compile time, so an undamped planar scene runs code with no damping, drag, gravity or
out-of-plane arithmetic at all.  A force term is added in one place: the spring law
(``spring_force``) or the sum of the forces on a particle (``particle_acceleration``).

Spring law: force on the first end F = k (|d| - L) d / |d| with d = r_second - r_first (the
paper's equation (11) with the sign kept: a compressed spring pushes); a dashpot beside it adds
c ((v_second - v_first) . d) d / |d|^2.  The linearised law (``linear=True``) uses stiffness k
along the rest direction of the spring and T/a across it (``tension_stiffness``), T = k (a - L).
A spring squeezed to zero length exerts no force instead of producing NaN.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from sim.forces import registry
from sim.forces.axial import along_force, tension_factor
from sim.forces.dashpot import dashpot_factor
from sim.forces.diagonal import ROWS, diagonal_net, diagonal_springs
from sim.forces.drag import drag_force, drag_power
from sim.forces.gravity import gravity_vector
from sim.forces.term import in_precision
from sim.forces.terms import inverse_mass_at

__all__ = ["BUFFER_ROWS", "SpringParameters", "components", "drag_power", "horizontal_springs",
           "particle_acceleration", "row_accelerations",
           "scalar_terms", "site", "spring_between", "spring_force", "vertical_springs"]

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

BUFFER_ROWS = ROWS
"""Rows of a buffer of the springs between two rows of particles (``vertical_springs``): their
forces (3) and what the terms of those springs add (the diagonal springs' net forces)."""

_BASE_FIELDS = (
    ("stiffness", "number"), ("rest_length", "number"), ("tension_stiffness", "number"),
    ("spacing", "number"), ("origin_x", "number"), ("origin_y", "number"),
    ("smallest_squared_length", "number"), ("inverse_sqrt_estimate", "flag"),
    ("periodic", "flag"), ("free_ends", "flag"),
)
_FIELDS = _BASE_FIELDS + tuple((field.name, field.kind) for field in registry.fields("springs"))
_KINDS = dict(_FIELDS)


class SpringParameters(namedtuple("SpringParameters", [name for name, _ in _FIELDS],
                                  defaults=(1e-24,) + (None,) * (len(_FIELDS) - 7))):
    """The spring constants as the kernels take them (a numba-friendly named tuple).

    ``stiffness`` k (N/m), ``rest_length`` L (m), ``tension_stiffness`` T/a (N/m) of the
    linearised law, ``spacing`` a (m), ``origin_x``/``origin_y`` rest position of particle (0, 0)
    (m); ``smallest_squared_length`` (m^2): below it a spring has no direction and its force is
    taken as zero.  ``inverse_sqrt_estimate`` None: 1/sqrt computed as 1 / sqrt(x); True: from
    the CPU's single-precision estimate and two Newton steps (float64 only; which is faster
    depends on the host, ``sim.loops.host_tuning``).  ``periodic`` True: each row is a ring, its
    last particle joined to its first by one spring (None: walls at the rows' ends);
    ``free_ends`` True: no spring to the left and right walls.  Then one field per
    ``KernelField`` a force term adds to this record (``sim.forces.registry``: the diagonal
    springs' k2, ...), None where the model does not have the term.  Flags and absent terms
    are compile-time choices.  All numbers have the precision of the state they are used with
    (``as_type``).
    """

    __slots__ = ()

    def as_type(self, dtype, inverse_sqrt_estimate: object = None) -> SpringParameters:
        """The same parameters as scalars of ``dtype`` (np.float64 or np.float32)."""
        scalar = np.dtype(dtype).type
        values = {name: in_precision(_KINDS[name], value, scalar)
                  for name, value in self._asdict().items()}
        values["inverse_sqrt_estimate"] = inverse_sqrt_estimate
        return SpringParameters(**values)


@njit(**_JIT)
def _inverse_square_root(value, estimate_first):
    """1 / sqrt(value) in the precision of ``value``.

    ``estimate_first`` None: computed as 1 / sqrt(value) (with fastmath, float32 becomes the CPU's
    estimate and one Newton step).  True (float64 only): the CPU's single-precision estimate
    refined by two Newton steps, each of which doubles the correct bits (about 12 -> 24 -> 48+;
    relative error below 1e-15) -- faster on CPUs with 512-bit vectors and slow double square
    roots, slower on others; ``sim.loops.host_tuning`` measures which at first use.
    """
    if estimate_first is None:
        return type(value)(1.0) / np.sqrt(value)
    estimate = np.float64(np.float32(1.0) / np.sqrt(np.float32(value)))
    estimate = estimate * (1.5 - 0.5 * value * estimate * estimate)
    return estimate * (1.5 - 0.5 * value * estimate * estimate)


# --- one spring: its two ends and its law -------------------------------------------------------
#
# A spring end is a tuple (x, y, z, vx, vy, vz) in m and m/s: a particle of the state, or a wall
# anchor (a rest site of the lattice that never moves).  The force of a spring depends only on
# its two ends, so the wall, ring and interior springs are one computation with different ends.
# The per-spring functions take scalars and tuples only, never arrays: LLVM inlines them into the
# row loops, which load the ends themselves (a call per spring that passes arrays would cost
# reference counting and vectorisation).


@njit(**_JIT)
def site(i, j, parameters):
    """The rest site of column i, row j as a spring end at rest; i = -1 or nx, j = -1 or ny are
    the wall anchors."""
    T = type(parameters.spacing)
    zero = T(0.0)
    return (parameters.origin_x + T(i) * parameters.spacing,
            parameters.origin_y + T(j) * parameters.spacing, zero, zero, zero, zero)


@njit(**_JIT)
def particle(x, y, z, vx, vy, vz, r, i):
    """The particle stored at row index r, column i of the (rows, nx) fields as a spring end; z
    and vz are zero in a planar scene (``z``, ``vz`` None).  For the ends of a row; the row loops
    load their particles inline."""
    zero = type(x[r, i])(0.0)
    if z is None:
        return x[r, i], y[r, i], zero, vx[r, i], vy[r, i], zero
    return x[r, i], y[r, i], z[r, i], vx[r, i], vy[r, i], vz[r, i]


@njit(**_JIT)
def _nonlinear_law(dx, dy, dz, dvx, dvy, dvz, parameters, dashpot):
    """Force (fx, fy, fz) on the first end of a spring with d = r_second - r_first and
    dv = v_second - v_first: k (|d| - L) d / |d|, plus the dashpot's c (dv . d) d / |d|^2; and the
    power the dashpot dissipates (W).  A spring shorter than the smallest length has no force."""
    squared = max(dx * dx + dy * dy + dz * dz, parameters.smallest_squared_length)
    inverse_length = _inverse_square_root(squared, parameters.inverse_sqrt_estimate)
    factor = tension_factor(squared, inverse_length, parameters)
    power = 0.0
    if dashpot is not None:
        damping_factor, power = dashpot_factor(dashpot, dx * dvx + dy * dvy + dz * dvz,
                                               inverse_length)
        factor += damping_factor
    return factor * dx, factor * dy, factor * dz, power


@njit(**_JIT)
def _linear_law(dx, dy, dz, dvx, dvy, dvz, axis, parameters, dashpot):
    """The linearised law: stiffness k along the spring's rest direction (``axis`` 0: x, 1: y),
    T/a across it, the dashpot along it; same arguments and results as ``_nonlinear_law``."""
    tension_stiffness = parameters.tension_stiffness
    spacing = parameters.spacing
    power = 0.0
    if axis == 0:
        fx = along_force(dx - spacing, parameters)
        fy = tension_stiffness * dy
        if dashpot is not None:
            fx += dashpot * dvx
            power = dashpot * dvx * dvx
    else:
        fx = tension_stiffness * dx
        fy = along_force(dy - spacing, parameters)
        if dashpot is not None:
            fy += dashpot * dvy
            power = dashpot * dvy * dvy
    return fx, fy, tension_stiffness * dz, power


@njit(**_JIT)
def spring_force(first, second, axis, linearised, parameters, dashpot):
    """Force (fx, fy, fz) in N on the first end of the spring between two ends, and the power its
    dashpot dissipates (W).  ``axis`` 0 for a horizontal spring, 1 for a vertical one;
    ``linearised`` None for the nonlinear law, True for the linearised one (compile-time)."""
    dx = second[0] - first[0]
    dy = second[1] - first[1]
    dz = second[2] - first[2]
    dvx = second[3] - first[3]
    dvy = second[4] - first[4]
    dvz = second[5] - first[5]
    if linearised is None:
        return _nonlinear_law(dx, dy, dz, dvx, dvy, dvz, parameters, dashpot)
    return _linear_law(dx, dy, dz, dvx, dvy, dvz, axis, parameters, dashpot)


@njit(**_JIT)
def scalar_terms(terms, zero):
    """The scene's terms (``sim.forces.terms.Terms``) as the per-spring and per-particle
    functions take them, made once per row: scalars, tuples and None only, no arrays, so that
    those functions inline into the row loops without reference counting (a record that holds
    arrays, passed per particle, cost the fused leapfrog 15-25 %).  (``law``, drag, gravity's
    pull (ax, ay, az)); ``law`` = (spring law, dashpot) is what the functions of the springs
    take (``spring_between``, ``horizontal_springs``)."""
    return ((terms.linear, terms.dashpot), terms.drag, gravity_vector(terms.gravity, zero))


@njit(**_JIT)
def spring_between(first, second, axis, law, parameters):
    """``spring_force`` of a nearest spring with the scene's ``law`` (``scalar_terms``: its
    spring law and dashpot): what a loop calls for one spring."""
    return spring_force(first, second, axis, law[0], parameters, law[1])


@njit(**_JIT)
def _other_forces(fx, fy, fz, velocity, drag, diagonal):
    """The net spring force (fx, fy, fz) plus the diagonal springs' (None: none) and drag on
    ``velocity`` (``drag`` None: none)."""
    if diagonal is not None:
        fx += diagonal[0]
        fy += diagonal[1]
        fz += diagonal[2]
    if drag is not None:
        drag_x, drag_y, drag_z = drag_force(drag, velocity)
        fx += drag_x
        fy += drag_y
        fz += drag_z
    return fx, fy, fz


@njit(**_JIT)
def particle_acceleration(left, right, below, above, velocity, scalars, inverse_mass,
                          diagonal=None):
    """Acceleration (ax, ay, az) in m/s^2 of one particle: the net force of its springs
    (``left``, ``right``, ``below``, ``above``: the forces (fx, fy, fz) on the left or lower ends
    of its four springs) and of the scene's terms (``scalars``: ``scalar_terms``; drag on its
    ``velocity`` (vx, vy, vz)) times its ``inverse_mass`` (``sim.forces.terms.inverse_mass_at``), plus
    gravity's pull; ``diagonal`` the net force of the diagonal springs
    (``sim.forces.diagonal.diagonal_net``, None: none).  This is the one place where the forces
    on a particle are summed."""
    fx, fy, fz = _other_forces(right[0] - left[0] + above[0] - below[0],
                               right[1] - left[1] + above[1] - below[1],
                               right[2] - left[2] + above[2] - below[2], velocity, scalars[1],
                               diagonal)
    pull = scalars[2]
    return (fx * inverse_mass + pull[0], fy * inverse_mass + pull[1],
            fz * inverse_mass + pull[2])



# --- the springs of one row ---------------------------------------------------------------------


@njit(**_JIT)
def _vertical_row(lower, upper, j, x, y, z, vx, vy, vz, linearised, parameters, dashpot, out):
    """Forces of the springs from row j - 1 (stored at index ``lower``) to row j (at ``upper``)
    into ``out`` (3, nx); ``lower`` None: the bottom wall's anchors instead (j = 0), ``upper``
    None: the top wall's anchors (j = ny).  Both are compile-time choices.  Returns the power."""
    zero = type(parameters.spacing)(0.0)
    power = 0.0
    for i in range(x.shape[1]):
        if lower is None:
            first = site(i, j - 1, parameters)
        elif z is None:
            first = (x[lower, i], y[lower, i], zero, vx[lower, i], vy[lower, i], zero)
        else:
            first = (x[lower, i], y[lower, i], z[lower, i], vx[lower, i], vy[lower, i],
                     vz[lower, i])
        if upper is None:
            second = site(i, j, parameters)
        elif z is None:
            second = (x[upper, i], y[upper, i], zero, vx[upper, i], vy[upper, i], zero)
        else:
            second = (x[upper, i], y[upper, i], z[upper, i], vx[upper, i], vy[upper, i],
                      vz[upper, i])
        fx, fy, fz, p = spring_force(first, second, 1, linearised, parameters, dashpot)
        power += p
        out[0, i] = fx
        out[1, i] = fy
        if z is not None:
            out[2, i] = fz
    return power


@njit(**_JIT)
def _vertical_springs(j, ny, x, y, z, vx, vy, vz, linearised, parameters, dashpot, out):
    rows = x.shape[0]
    diagonal_springs(parameters.diagonal_stiffness, j, ny, x, y, z, linearised, parameters, out)
    if j == 0:
        return _vertical_row(None, j % rows, j, x, y, z, vx, vy, vz, linearised, parameters,
                             dashpot, out)
    if j == ny:
        return _vertical_row((j - 1) % rows, None, j, x, y, z, vx, vy, vz, linearised, parameters,
                             dashpot, out)
    return _vertical_row((j - 1) % rows, j % rows, j, x, y, z, vx, vy, vz, linearised,
                         parameters, dashpot, out)


@njit(**_JIT)
def as_row(j):
    """The row index ``j`` as an ordinary integer.  numba types a constant argument (a caller's
    ``vertical_springs(0, ...)``) as that literal and compiles every function it is passed on to
    once more for it: passed through here, the springs below are compiled once per kernel."""
    return np.intp(j)


@njit(**_JIT)
def vertical_springs(j, ny, x, y, z, vx, vy, vz, terms, parameters, out):
    """Forces (3, nx) on the lower ends of the springs between row j-1 and row j (j = 0: from
    the bottom wall anchors; j = ny: from row ny-1 to the top anchors), written into ``out``
    (``sim.forces.diagonal.ROWS``, nx), the diagonal springs' net forces in its rows 3 .. 8.

    ``parameters`` is a ``SpringParameters`` record in the precision of the arrays; ``terms``
    the scene's ``sim.forces.terms.Terms`` (its ``linear``: None for the nonlinear law, True for
    the linearised one, a compile-time choice as ``out_of_plane``; its dashpots).
    ``ny`` is the number of rows of the lattice; the arrays may hold fewer rows, as a ring buffer
    in which row j is stored at index j % rows (a full array is the case rows == ny).
    Returns the power dissipated by the dashpots of those springs (W).
    """
    return _vertical_springs(as_row(j), ny, x, y, z, vx, vy, vz, terms.linear, parameters,
                             terms.dashpot, out)


@njit(**_JIT)
def _store(out, i, force, z):
    out[0, i] = force[0]
    out[1, i] = force[1]
    if z is not None:
        out[2, i] = force[2]
    return force[3]


@njit(**_JIT)
def horizontal_springs(j, x, y, z, vx, vy, vz, linearised, parameters, dashpot, out):
    """Forces (3, nx + 1) on the left ends of the springs of row j, written into ``out``: spring i
    joins particle i - 1 to particle i, spring 0 comes from the left wall anchor and spring nx
    goes to the right one (on a ring both are the closing spring; at free ends both are zero).
    ``linearised`` None: the nonlinear law, True: the linearised one; ``dashpot`` None: none (a
    loop passes its scene's ``law`` of ``scalar_terms`` as these two, calling this function
    directly: a function between a row loop and this one left the leapfrog 10-18 % slower in
    the kernels read from the cache, ``docs/web.md``, "Compiled apart").  Arrays as for
    ``vertical_springs``; returns the power dissipated by their dashpots (W)."""
    T = type(parameters.spacing)
    zero = T(0.0)
    r = j % x.shape[0]
    nx = x.shape[1]
    still = (zero, zero, zero, zero)
    if linearised is not None:
        # the linearised law leaves out each spring's rest tension T = k (a - L), which cancels
        # on every particle with a spring on both sides; a free end has none outside it, so its
        # missing spring carries -T relative to that law (the end particle is pulled inward)
        still = (-parameters.tension_stiffness * parameters.spacing, zero, zero, zero)
    power = 0.0
    if parameters.free_ends is not None:  # no spring to the left wall
        _store(out, 0, still, z)
    else:
        if parameters.periodic is not None:  # the ring's closing spring, seen from particle 0
            last = particle(x, y, z, vx, vy, vz, r, nx - 1)
            first = (last[0] - T(nx) * parameters.spacing, last[1], last[2], last[3], last[4],
                     last[5])
        else:
            first = site(-1, j, parameters)
        power += _store(out, 0, spring_force(first, particle(x, y, z, vx, vy, vz, r, 0), 0,
                                             linearised, parameters, dashpot), z)
    for i in range(1, nx):
        if z is None:
            first = (x[r, i - 1], y[r, i - 1], zero, vx[r, i - 1], vy[r, i - 1], zero)
            second = (x[r, i], y[r, i], zero, vx[r, i], vy[r, i], zero)
        else:
            first = (x[r, i - 1], y[r, i - 1], z[r, i - 1], vx[r, i - 1], vy[r, i - 1],
                     vz[r, i - 1])
            second = (x[r, i], y[r, i], z[r, i], vx[r, i], vy[r, i], vz[r, i])
        fx, fy, fz, p = spring_force(first, second, 0, linearised, parameters, dashpot)
        power += p
        out[0, i] = fx
        out[1, i] = fy
        if z is not None:
            out[2, i] = fz
    if parameters.periodic is not None:  # the right edge is the closing spring again
        _store(out, nx, (out[0, 0], out[1, 0], out[2, 0], zero), z)
    elif parameters.free_ends is not None:
        _store(out, nx, still, z)
    else:
        power += _store(out, nx, spring_force(particle(x, y, z, vx, vy, vz, r, nx - 1),
                                              site(nx, j, parameters), 0, linearised, parameters,
                                              dashpot), z)
    return power


# --- accelerations ------------------------------------------------------------------------------


@njit(**_JIT)
def row_accelerations(j, ny, x, y, z, vx, vy, vz, terms, parameters, below, above, horizontal,
                      out):
    """Accelerations (3, nx) of the particles of row j, written into ``out``.

    ``terms`` is the scene's ``sim.forces.terms.Terms`` record, ``parameters`` its
    ``SpringParameters``.  ``below`` must hold ``vertical_springs(j)``; this function fills
    ``above`` with ``vertical_springs(j + 1)`` (so the caller swaps the two buffers for the next
    row) and uses ``horizontal`` (3, nx + 1) as scratch.  Returns the power dissipated in row j
    by the horizontal springs, the springs above it and drag (W).
    """
    linearised, dashpot, drag = terms.linear, terms.dashpot, terms.drag
    power = _vertical_springs(j + 1, ny, x, y, z, vx, vy, vz, linearised, parameters, dashpot,
                              above)
    power += horizontal_springs(j, x, y, z, vx, vy, vz, linearised, parameters, dashpot,
                                horizontal)
    zero = type(parameters.spacing)(0.0)
    scalars = scalar_terms(terms, zero)
    k2 = parameters.diagonal_stiffness
    r = j % x.shape[0]
    for i in range(x.shape[1]):
        w = inverse_mass_at(terms.uniform_inverse_mass, terms.inverse_mass, j, i)
        if z is None:
            ax, ay, _ = particle_acceleration(
                (horizontal[0, i], horizontal[1, i], zero),
                (horizontal[0, i + 1], horizontal[1, i + 1], zero),
                (below[0, i], below[1, i], zero), (above[0, i], above[1, i], zero),
                (vx[r, i], vy[r, i], zero), scalars, w, diagonal_net(k2, below, above, i),
            )
        else:
            ax, ay, out[2, i] = particle_acceleration(
                (horizontal[0, i], horizontal[1, i], horizontal[2, i]),
                (horizontal[0, i + 1], horizontal[1, i + 1], horizontal[2, i + 1]),
                (below[0, i], below[1, i], below[2, i]), (above[0, i], above[1, i], above[2, i]),
                (vx[r, i], vy[r, i], vz[r, i]), scalars, w, diagonal_net(k2, below, above, i),
            )
        out[0, i] = ax
        out[1, i] = ay
    return power + drag_power(drag, vx, vy, vz, r)


@njit(**_JIT)
def components(out_of_plane, array):
    """(x, y, z) component fields of a (dim, ny, nx) array; z is None for planar scenes."""
    if out_of_plane is None:
        return array[0], array[1], None
    return array[0], array[1], array[2]
