"""Numba kernels: the spring forces of the lattice, computed one row of particles at a time.

Everything here is a pure function over arrays and scalars, compiled with ``@njit(cache=True)``;
``sim.stepping`` builds the integrators' fused sweeps from these row functions and the Python
layer (``sim.integrators``, ``sim.simulation``) orchestrates.

Layout (chosen for speed, see the README's benchmark section):

* a field over the lattice is a C-contiguous ``(ny, nx)`` float64 array per component:
  ``x, y`` (and ``z`` for out-of-plane motion) in m, ``vx, vy, vz`` in m/s;
* particle ``(row j, column i)`` rests at ``(origin_x + i*spacing, origin_y + j*spacing)``; the wall
  anchors sit one spacing outside the lattice on all four sides and never move, so they are not
  stored and the inner loops have no boundary branches (walls are handled by peeled iterations);
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
for a planar scene, ``dashpot``, ``drag``, ``gravity``).  Numba compiles one machine-code version
per combination of argument types and prunes the ``is None`` branches at compile time, so an
undamped planar scene runs code with no damping, drag, gravity or out-of-plane arithmetic at all.

Spring law: force on the first end F = k (|d| - L) d / |d| with d = r_second - r_first (the
paper's equation (11) with the sign kept: a compressed spring pushes); a dashpot beside it adds
c ((v_second - v_first) . d) d / |d|^2.  The linearised law (``linear=True``) uses stiffness k
along the rest direction of the spring and T/a across it (``tension_stiffness``), T = k (a - L).
A spring squeezed to zero length exerts no force instead of producing NaN.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

class SpringParameters(NamedTuple):
    """The spring constants as the kernels take them (a numba-friendly named tuple).

    ``stiffness`` k (N/m), ``rest_length`` L (m), ``tension_stiffness`` T/a (N/m) of the
    linearised law, ``spacing`` a (m), ``origin_x``/``origin_y`` rest position of particle (0, 0)
    (m).  All fields have the precision of the state they are used with (``as_type``).
    """

    stiffness: float
    rest_length: float
    tension_stiffness: float
    spacing: float
    origin_x: float
    origin_y: float
    smallest_squared_length: float = 1e-24
    """Below this squared length (m^2) a spring has no direction; its force is taken as zero."""
    inverse_sqrt_estimate: object = None
    """None: 1/sqrt computed as 1 / sqrt(x); True: from the CPU's single-precision estimate and
    two Newton steps (float64 only; which is faster depends on the host, ``sim.host_tuning``)."""
    periodic: object = None
    """None: walls at the left and right ends of the rows; True: each row is a ring, its last
    particle joined to its first by one spring (the left and right edges are the same spring,
    seen from both sides).  A compile-time choice like the optional terms."""
    free_ends: object = None
    """True: the rows' end particles have no spring to the left and right walls (free ends);
    None: they do.  A compile-time choice."""

    def as_type(self, dtype, inverse_sqrt_estimate: object = None) -> SpringParameters:
        """The same parameters as scalars of ``dtype`` (np.float64 or np.float32)."""
        scalar = np.dtype(dtype).type
        numbers = (scalar(value) for value in self[:7])
        return SpringParameters(*numbers, inverse_sqrt_estimate=inverse_sqrt_estimate,
                                periodic=self.periodic, free_ends=self.free_ends)


@njit(**_JIT)
def _inverse_square_root(value, estimate_first):
    """1 / sqrt(value) in the precision of ``value``.

    ``estimate_first`` None: computed as 1 / sqrt(value) (with fastmath, float32 becomes the CPU's
    estimate and one Newton step).  True (float64 only): the CPU's single-precision estimate
    refined by two Newton steps, each of which doubles the correct bits (about 12 -> 24 -> 48+;
    relative error below 1e-15) -- faster on CPUs with 512-bit vectors and slow double square
    roots, slower on others; ``sim.host_tuning`` measures which at first use.
    """
    if estimate_first is None:
        return type(value)(1.0) / np.sqrt(value)
    estimate = np.float64(np.float32(1.0) / np.sqrt(np.float32(value)))
    estimate = estimate * (1.5 - 0.5 * value * estimate * estimate)
    return estimate * (1.5 - 0.5 * value * estimate * estimate)


@njit(**_JIT)
def _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny, estimate_first):
    """Force factor of one spring (and its dashpot) and the power the dashpot dissipates.

    (dx, dy, dz) = r_second - r_first and (dvx, dvy, dvz) the same for velocities; the force on
    the first end is factor * (dx, dy, dz).  ``dashpot`` is None for an undamped scene;
    ``tiny`` the smallest squared length (m^2).
    """
    squared = max(dx * dx + dy * dy + dz * dz, tiny)
    inverse_length = _inverse_square_root(squared, estimate_first)
    factor = stiffness - stiffness * rest_length * inverse_length
    power = 0.0
    if dashpot is not None:
        rate = dx * dvx + dy * dvy + dz * dvz
        damping_factor = dashpot * rate * inverse_length * inverse_length
        factor += damping_factor
        power = damping_factor * rate
    return factor, power


@njit(**_JIT)
def _nonlinear_vertical(j, ny, x, y, z, vx, vy, vz, parameters, dashpot, out):
    T = type(parameters.spacing)
    stiffness, rest_length = parameters.stiffness, parameters.rest_length
    spacing, origin_x, origin_y = parameters.spacing, parameters.origin_x, parameters.origin_y
    tiny, estimate_first = parameters.smallest_squared_length, parameters.inverse_sqrt_estimate
    rows, nx = x.shape
    upper = j % rows
    lower = (j - 1) % rows
    power = 0.0
    dz = T(0.0)
    dvx = T(0.0)
    dvy = T(0.0)
    dvz = T(0.0)
    if j == 0:
        for i in range(nx):
            dx = x[upper, i] - (origin_x + T(i) * spacing)
            dy = y[upper, i] - (origin_y - spacing)
            if z is not None:
                dz = z[upper, i]
            if dashpot is not None:
                dvx = vx[upper, i]
                dvy = vy[upper, i]
                if vz is not None:
                    dvz = vz[upper, i]
            f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny,
                              estimate_first)
            power += p
            out[0, i] = f * dx
            out[1, i] = f * dy
            if z is not None:
                out[2, i] = f * dz
    elif j == ny:
        top = origin_y + T(ny) * spacing
        for i in range(nx):
            dx = (origin_x + T(i) * spacing) - x[lower, i]
            dy = top - y[lower, i]
            if z is not None:
                dz = -z[lower, i]
            if dashpot is not None:
                dvx = -vx[lower, i]
                dvy = -vy[lower, i]
                if vz is not None:
                    dvz = -vz[lower, i]
            f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny,
                              estimate_first)
            power += p
            out[0, i] = f * dx
            out[1, i] = f * dy
            if z is not None:
                out[2, i] = f * dz
    else:
        for i in range(nx):
            dx = x[upper, i] - x[lower, i]
            dy = y[upper, i] - y[lower, i]
            if z is not None:
                dz = z[upper, i] - z[lower, i]
            if dashpot is not None:
                dvx = vx[upper, i] - vx[lower, i]
                dvy = vy[upper, i] - vy[lower, i]
                if vz is not None:
                    dvz = vz[upper, i] - vz[lower, i]
            f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny,
                              estimate_first)
            power += p
            out[0, i] = f * dx
            out[1, i] = f * dy
            if z is not None:
                out[2, i] = f * dz
    return power


@njit(**_JIT)
def _nonlinear_horizontal(j, ny, x, y, z, vx, vy, vz, parameters, dashpot, out):
    T = type(parameters.spacing)
    stiffness, rest_length = parameters.stiffness, parameters.rest_length
    spacing, origin_x, origin_y = parameters.spacing, parameters.origin_x, parameters.origin_y
    tiny, estimate_first = parameters.smallest_squared_length, parameters.inverse_sqrt_estimate
    r = j % x.shape[0]
    nx = x.shape[1]
    power = 0.0
    dz = T(0.0)
    dvx = T(0.0)
    dvy = T(0.0)
    dvz = T(0.0)
    row_y_rest = origin_y + T(j) * spacing
    if parameters.periodic is None:
        # left wall anchor to particle 0
        dx = x[r, 0] - (origin_x - spacing)
        dy = y[r, 0] - row_y_rest
        if z is not None:
            dz = z[r, 0]
        if dashpot is not None:
            dvx = vx[r, 0]
            dvy = vy[r, 0]
            if vz is not None:
                dvz = vz[r, 0]
    else:
        # the ring's closing spring: particle nx - 1, one period to the left, to particle 0
        dx = x[r, 0] - (x[r, nx - 1] - T(nx) * spacing)
        dy = y[r, 0] - y[r, nx - 1]
        if z is not None:
            dz = z[r, 0] - z[r, nx - 1]
        if dashpot is not None:
            dvx = vx[r, 0] - vx[r, nx - 1]
            dvy = vy[r, 0] - vy[r, nx - 1]
            if vz is not None:
                dvz = vz[r, 0] - vz[r, nx - 1]
    f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny,
                              estimate_first)
    if parameters.free_ends is not None:  # no wall spring at a free end
        f = T(0.0) * f
        p = 0.0
    power += p
    out[0, 0] = f * dx
    out[1, 0] = f * dy
    if z is not None:
        out[2, 0] = f * dz
    for i in range(1, nx):
        dx = x[r, i] - x[r, i - 1]
        dy = y[r, i] - y[r, i - 1]
        if z is not None:
            dz = z[r, i] - z[r, i - 1]
        if dashpot is not None:
            dvx = vx[r, i] - vx[r, i - 1]
            dvy = vy[r, i] - vy[r, i - 1]
            if vz is not None:
                dvz = vz[r, i] - vz[r, i - 1]
        f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny,
                              estimate_first)
        power += p
        out[0, i] = f * dx
        out[1, i] = f * dy
        if z is not None:
            out[2, i] = f * dz
    if parameters.periodic is not None:  # the right edge is the closing spring again
        out[0, nx] = out[0, 0]
        out[1, nx] = out[1, 0]
        if z is not None:
            out[2, nx] = out[2, 0]
        return power
    if parameters.free_ends is not None:
        out[0, nx] = T(0.0)
        out[1, nx] = T(0.0)
        if z is not None:
            out[2, nx] = T(0.0)
        return power
    # particle nx - 1 to the right wall anchor
    dx = (origin_x + T(nx) * spacing) - x[r, nx - 1]
    dy = row_y_rest - y[r, nx - 1]
    if z is not None:
        dz = -z[r, nx - 1]
    if dashpot is not None:
        dvx = -vx[r, nx - 1]
        dvy = -vy[r, nx - 1]
        if vz is not None:
            dvz = -vz[r, nx - 1]
    f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot, tiny,
                              estimate_first)
    power += p
    out[0, nx] = f * dx
    out[1, nx] = f * dy
    if z is not None:
        out[2, nx] = f * dz
    return power


@njit(**_JIT)
def _linear_vertical(j, ny, x, y, z, vx, vy, stiffness, tension_stiffness, spacing, origin_x,
                     origin_y, dashpot, out):
    T = type(spacing)
    rows, nx = x.shape
    upper = j % rows
    lower = (j - 1) % rows
    power = 0.0
    if j == 0:
        for i in range(nx):
            out[0, i] = tension_stiffness * (x[upper, i] - (origin_x + T(i) * spacing))
            out[1, i] = stiffness * (y[upper, i] - origin_y)
            if z is not None:
                out[2, i] = tension_stiffness * z[upper, i]
            if dashpot is not None:
                out[1, i] += dashpot * vy[upper, i]
                power += dashpot * vy[upper, i] * vy[upper, i]
    elif j == ny:
        top_stretch_base = origin_y + T(ny) * spacing - spacing
        for i in range(nx):
            out[0, i] = tension_stiffness * ((origin_x + T(i) * spacing) - x[lower, i])
            out[1, i] = stiffness * (top_stretch_base - y[lower, i])
            if z is not None:
                out[2, i] = -tension_stiffness * z[lower, i]
            if dashpot is not None:
                out[1, i] -= dashpot * vy[lower, i]
                power += dashpot * vy[lower, i] * vy[lower, i]
    else:
        for i in range(nx):
            out[0, i] = tension_stiffness * (x[upper, i] - x[lower, i])
            out[1, i] = stiffness * (y[upper, i] - y[lower, i] - spacing)
            if z is not None:
                out[2, i] = tension_stiffness * (z[upper, i] - z[lower, i])
            if dashpot is not None:
                relative = vy[upper, i] - vy[lower, i]
                out[1, i] += dashpot * relative
                power += dashpot * relative * relative
    return power


@njit(**_JIT)
def _linear_horizontal(j, ny, x, y, z, vx, vy, stiffness, tension_stiffness, spacing, origin_x,
                       origin_y, dashpot, out, periodic=None, free_ends=None):
    T = type(spacing)
    r = j % x.shape[0]
    nx = x.shape[1]
    power = 0.0
    row_y_rest = origin_y + T(j) * spacing
    if periodic is not None:
        # the ring's closing spring, from particle nx - 1 (one period to the left) to particle 0
        out[0, 0] = stiffness * (x[r, 0] - x[r, nx - 1] + T(nx - 1) * spacing)
        out[1, 0] = tension_stiffness * (y[r, 0] - y[r, nx - 1])
        if z is not None:
            out[2, 0] = tension_stiffness * (z[r, 0] - z[r, nx - 1])
        if dashpot is not None:
            relative = vx[r, 0] - vx[r, nx - 1]
            out[0, 0] += dashpot * relative
            power += dashpot * relative * relative
    elif free_ends is not None:
        out[0, 0] = T(0.0)
        out[1, 0] = T(0.0)
        if z is not None:
            out[2, 0] = T(0.0)
    else:
        out[0, 0] = stiffness * (x[r, 0] - origin_x)
        out[1, 0] = tension_stiffness * (y[r, 0] - row_y_rest)
        if z is not None:
            out[2, 0] = tension_stiffness * z[r, 0]
        if dashpot is not None:
            out[0, 0] += dashpot * vx[r, 0]
            power += dashpot * vx[r, 0] * vx[r, 0]
    for i in range(1, nx):
        out[0, i] = stiffness * (x[r, i] - x[r, i - 1] - spacing)
        out[1, i] = tension_stiffness * (y[r, i] - y[r, i - 1])
        if z is not None:
            out[2, i] = tension_stiffness * (z[r, i] - z[r, i - 1])
        if dashpot is not None:
            relative = vx[r, i] - vx[r, i - 1]
            out[0, i] += dashpot * relative
            power += dashpot * relative * relative
    if periodic is not None:
        out[0, nx] = out[0, 0]
        out[1, nx] = out[1, 0]
        if z is not None:
            out[2, nx] = out[2, 0]
        return power
    if free_ends is not None:
        out[0, nx] = T(0.0)
        out[1, nx] = T(0.0)
        if z is not None:
            out[2, nx] = T(0.0)
        return power
    out[0, nx] = stiffness * ((origin_x + T(nx - 1) * spacing) - x[r, nx - 1])
    out[1, nx] = tension_stiffness * (row_y_rest - y[r, nx - 1])
    if z is not None:
        out[2, nx] = -tension_stiffness * z[r, nx - 1]
    if dashpot is not None:
        out[0, nx] -= dashpot * vx[r, nx - 1]
        power += dashpot * vx[r, nx - 1] * vx[r, nx - 1]
    return power


@njit(**_JIT)
def vertical_springs(j, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, out):
    """Forces (3, nx) on the lower ends of the springs between row j-1 and row j (j = 0: from
    the bottom wall anchors; j = ny: from row ny-1 to the top anchors), written into ``out``.

    ``parameters`` is a ``SpringParameters`` record in the precision of the arrays.
    ``ny`` is the number of rows of the lattice; the arrays may hold fewer rows, as a ring buffer
    in which row j is stored at index j % rows (a full array is the case rows == ny).
    Returns the power dissipated by the dashpots of those springs (W).
    """
    if linear:
        return _linear_vertical(j, ny, x, y, z, vx, vy, parameters.stiffness,
                                parameters.tension_stiffness, parameters.spacing,
                                parameters.origin_x, parameters.origin_y, dashpot, out)
    return _nonlinear_vertical(j, ny, x, y, z, vx, vy, vz, parameters, dashpot, out)


@njit(**_JIT)
def row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear, parameters, dashpot, drag,
                      gravity, below, above, horizontal, out, uniform_inverse_mass=None):
    """Accelerations (3, nx) of the particles of row j, written into ``out``.

    ``below`` must hold ``vertical_springs(j)``; this function fills ``above`` with
    ``vertical_springs(j + 1)`` (so the caller swaps the two buffers for the next row) and uses
    ``horizontal`` (3, nx + 1) as scratch.  ``uniform_inverse_mass`` (1/kg), when given, replaces
    the (ny, nx) ``inverse_mass`` array for lattices of equal masses (one memory stream less).
    Returns the power dissipated in row j by the
    horizontal springs, the springs above it and drag (W).
    """
    power = vertical_springs(j + 1, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, above)
    if linear:
        power += _linear_horizontal(j, ny, x, y, z, vx, vy, parameters.stiffness,
                                    parameters.tension_stiffness, parameters.spacing,
                                    parameters.origin_x, parameters.origin_y, dashpot, horizontal,
                                    parameters.periodic, parameters.free_ends)
    else:
        power += _nonlinear_horizontal(j, ny, x, y, z, vx, vy, vz, parameters, dashpot, horizontal)
    r = j % x.shape[0]
    nx = x.shape[1]
    for i in range(nx):
        if uniform_inverse_mass is not None:
            w = uniform_inverse_mass
        else:
            w = inverse_mass[j, i]
        fx = horizontal[0, i + 1] - horizontal[0, i] + above[0, i] - below[0, i]
        fy = horizontal[1, i + 1] - horizontal[1, i] + above[1, i] - below[1, i]
        if drag is not None:
            fx -= drag * vx[r, i]
            fy -= drag * vy[r, i]
        out[0, i] = fx * w
        out[1, i] = fy * w
        if gravity is not None:
            out[0, i] += gravity[0]
            out[1, i] += gravity[1]
        if z is not None:
            fz = horizontal[2, i + 1] - horizontal[2, i] + above[2, i] - below[2, i]
            if drag is not None:
                fz -= drag * vz[r, i]
            out[2, i] = fz * w
            if gravity is not None:
                out[2, i] += gravity[2]
    if drag is not None:
        for i in range(nx):
            speed_squared = vx[r, i] * vx[r, i] + vy[r, i] * vy[r, i]
            if vz is not None:
                speed_squared += vz[r, i] * vz[r, i]
            power += drag * speed_squared
    return power


@njit(**_JIT)
def _spring_energy(dx, dy, dz, axis, linear, stiffness, rest_length, tension_stiffness, spacing):
    """Energy (J) of one spring with separation (dx, dy, dz) relative to the rest lattice;
    ``axis`` 0 for a horizontal spring, 1 for a vertical one (used by the linearised law)."""
    if linear:
        if axis == 0:
            stretch = dx - spacing
            across = dy * dy + dz * dz
        else:
            stretch = dy - spacing
            across = dx * dx + dz * dz
        return 0.5 * stiffness * stretch * stretch + 0.5 * tension_stiffness * across
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    rest_stretch = spacing - rest_length
    return 0.5 * stiffness * ((length - rest_length) ** 2 - rest_stretch * rest_stretch)


@njit(**_JIT)
def energy_terms(x, y, z, vx, vy, vz, masses, linear, parameters):
    """(kinetic, spring) energy in J of a state, in one pass; (ny, nx) arrays, z/vz None in 2-D.

    The spring energy is measured from the rest lattice.  A NaN or infinity anywhere in the
    state makes the result non-finite, so this doubles as the blow-up check.
    """
    stiffness, rest_length = parameters.stiffness, parameters.rest_length
    tension_stiffness, spacing = parameters.tension_stiffness, parameters.spacing
    origin_x, origin_y = parameters.origin_x, parameters.origin_y
    ny, nx = x.shape
    kinetic = 0.0
    spring = 0.0
    dz = 0.0
    for j in range(ny):
        row_y_rest = origin_y + j * spacing
        for i in range(nx):
            speed_squared = vx[j, i] * vx[j, i] + vy[j, i] * vy[j, i]
            if vz is not None:
                speed_squared += vz[j, i] * vz[j, i]
            kinetic += 0.5 * masses[j, i] * speed_squared
            # the spring to the left neighbour (or the left wall anchor, or the ring's closing
            # spring from the last particle of the row)
            if i == 0 and parameters.periodic is not None:
                dx = x[j, 0] - (x[j, nx - 1] - nx * spacing)
                dy = y[j, 0] - y[j, nx - 1]
                if z is not None:
                    dz = z[j, 0] - z[j, nx - 1]
            elif i == 0:
                dx = x[j, 0] - (origin_x - spacing)
                dy = y[j, 0] - row_y_rest
                if z is not None:
                    dz = z[j, 0]
            else:
                dx = x[j, i] - x[j, i - 1]
                dy = y[j, i] - y[j, i - 1]
                if z is not None:
                    dz = z[j, i] - z[j, i - 1]
            if i > 0 or parameters.free_ends is None:
                spring += _spring_energy(dx, dy, dz, 0, linear, stiffness, rest_length,
                                         tension_stiffness, spacing)
            # the spring to the neighbour below (or the bottom wall anchor)
            if j == 0:
                dx = x[0, i] - (origin_x + i * spacing)
                dy = y[0, i] - (origin_y - spacing)
                if z is not None:
                    dz = z[0, i]
            else:
                dx = x[j, i] - x[j - 1, i]
                dy = y[j, i] - y[j - 1, i]
                if z is not None:
                    dz = z[j, i] - z[j - 1, i]
            spring += _spring_energy(dx, dy, dz, 1, linear, stiffness, rest_length,
                                     tension_stiffness, spacing)
        if parameters.periodic is None and parameters.free_ends is None:
            # the spring from the last particle of the row to the right wall anchor
            dx = (origin_x + nx * spacing) - x[j, nx - 1]
            dy = row_y_rest - y[j, nx - 1]
            if z is not None:
                dz = -z[j, nx - 1]
            spring += _spring_energy(dx, dy, dz, 0, linear, stiffness, rest_length,
                                     tension_stiffness, spacing)
    for i in range(nx):  # the springs from the top row to the top wall anchors
        dx = (origin_x + i * spacing) - x[ny - 1, i]
        dy = (origin_y + ny * spacing) - y[ny - 1, i]
        if z is not None:
            dz = -z[ny - 1, i]
        spring += _spring_energy(dx, dy, dz, 1, linear, stiffness, rest_length,
                                 tension_stiffness, spacing)
    return kinetic, spring


@njit(**_JIT)
def leapfrog_rows(j0, j1, ny, dt, x, y, z, vx, vy, vz, inverse_mass, uniform_inverse_mass,
                  parameters, gravity, below, above_last, horizontal):
    """One leapfrog kick and drift (v += dt a(x); x += dt v) of rows j0 .. j1-1, undamped
    nonlinear springs, with each row's forces and update fused into one pass over it.

    ``below`` (3, nx) holds the forces of the springs below row j0 on entry (it is reused as the
    running buffer); ``above_last`` (3, nx) those of the springs above row j1 - 1, computed before
    the sweep moved anything (the top wall springs, or a block boundary when the lattice is swept
    as several row blocks in parallel).  ``horizontal`` (3, nx + 1) is scratch.  Every other
    spring is computed here from positions that have not moved yet, so the result does not
    depend on how the rows are split into blocks.
    """
    T = type(dt)
    zero = T(0.0)
    stiffness, rest_length = parameters.stiffness, parameters.rest_length
    tiny, estimate_first = parameters.smallest_squared_length, parameters.inverse_sqrt_estimate
    nx = x.shape[1]
    dz = zero
    tz = zero
    for j in range(j0, j1):
        _nonlinear_horizontal(j, ny, x, y, z, vx, vy, vz, parameters, None, horizontal)
        given = j + 1 == j1
        for i in range(nx):
            if given:
                tx = above_last[0, i]
                ty = above_last[1, i]
                if z is not None:
                    tz = above_last[2, i]
            else:
                dx = x[j + 1, i] - x[j, i]
                dy = y[j + 1, i] - y[j, i]
                if z is not None:
                    dz = z[j + 1, i] - z[j, i]
                f, _ = _spring_factor(dx, dy, dz, zero, zero, zero, stiffness, rest_length, None,
                                      tiny, estimate_first)
                tx = f * dx
                ty = f * dy
                if z is not None:
                    tz = f * dz
            if uniform_inverse_mass is not None:
                w = uniform_inverse_mass
            else:
                w = inverse_mass[j, i]
            ax = (horizontal[0, i + 1] - horizontal[0, i] + tx - below[0, i]) * w
            ay = (horizontal[1, i + 1] - horizontal[1, i] + ty - below[1, i]) * w
            if gravity is not None:
                ax += gravity[0]
                ay += gravity[1]
            u = vx[j, i] + dt * ax
            v = vy[j, i] + dt * ay
            vx[j, i] = u
            vy[j, i] = v
            x[j, i] += dt * u
            y[j, i] += dt * v
            below[0, i] = tx
            below[1, i] = ty
            if z is not None:
                az = (horizontal[2, i + 1] - horizontal[2, i] + tz - below[2, i]) * w
                if gravity is not None:
                    az += gravity[2]
                s = vz[j, i] + dt * az
                vz[j, i] = s
                z[j, i] += dt * s
                below[2, i] = tz
