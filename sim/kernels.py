"""Numba kernels: the force law of the lattice and the integrator updates.

Everything here is a pure function over arrays and scalars, compiled with ``@njit(cache=True)``.
The Python layer (``sim.integrators``, ``sim.simulation``) orchestrates them.

Layout (chosen for speed, see the README's benchmark section):

* a field over the lattice is a C-contiguous ``(ny, nx)`` float64 array, one per component:
  ``x, y`` (and ``z`` for out-of-plane motion), ``vx, vy, vz``, accelerations ``ax, ay, az``;
* particle ``(row j, column i)`` rests at ``(origin_x + i*spacing, origin_y + j*spacing)``; the wall
  anchors sit one spacing outside the lattice on all four sides and never move, so they are not stored;
* each spring is computed once per sweep: horizontal springs of a row go into a row buffer of
  ``nx + 1`` forces, vertical springs between two rows into a buffer of ``nx`` forces that is reused
  by the next row.

Specialisation: the optional terms are passed as ``None`` when a scene does not have them
(``z``/``vz``/``az`` for a planar scene, ``dashpot``, ``drag``, ``gravity``).  Numba compiles one
machine-code version per combination of argument types and prunes the ``is None`` branches at
compile time, so an undamped planar scene runs a kernel that contains no damping, drag, gravity or
out-of-plane arithmetic at all.

Units: any consistent set (the presets use metres, kilograms and seconds).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")

# Below this length a spring has no defined direction; its force is taken as zero instead of NaN.
_SMALLEST_LENGTH = 1e-12


@njit(**_JIT)
def _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot):
    """Force factor of one spring (and its dashpot) and the power the dashpot dissipates.

    (dx, dy, dz) = r_second - r_first and (dvx, dvy, dvz) the same for velocities; the force on the
    first end is factor * (dx, dy, dz).  ``dashpot`` is None for an undamped scene.
    """
    squared = max(dx * dx + dy * dy + dz * dz, _SMALLEST_LENGTH * _SMALLEST_LENGTH)
    length = np.sqrt(squared)
    factor = stiffness * (length - rest_length) / length
    power = 0.0
    if dashpot is not None:
        rate = dx * dvx + dy * dvy + dz * dvz
        damping_factor = dashpot * rate / squared
        factor += damping_factor
        power = damping_factor * rate
    return factor, power


@njit(**_JIT)
def nonlinear_accelerations(
    x, y, z, vx, vy, vz, inverse_mass, stiffness, rest_length, spacing, origin_x, origin_y,
    dashpot, drag, gravity, ax, ay, az,
):
    """Accelerations of every particle under the full (geometrically nonlinear) spring law.

    Spring force on end i from end j: F = k (|r_j - r_i| - L) (r_j - r_i) / |r_j - r_i|; a dashpot
    beside each spring adds c ((v_j - v_i) . e) e; drag adds -drag * v; gravity adds g.
    Arrays are (ny, nx); ``z, vz, az`` are None for planar scenes; ``dashpot``, ``drag`` (floats)
    and ``gravity`` (float array of 3) are None when absent.  Writes ax, ay (, az) and returns the
    power dissipated by dashpots and drag (W), 0.0 for an undamped scene.
    A spring squeezed to zero length exerts no force (instead of a NaN).
    """
    ny, nx = x.shape
    power = 0.0
    # force on the lower end of the vertical springs below / above the current row: (nx,)
    below_x = np.empty(nx)
    below_y = np.empty(nx)
    below_z = np.zeros(nx)
    above_x = np.empty(nx)
    above_y = np.empty(nx)
    above_z = np.zeros(nx)
    # force on the left end of the horizontal springs of the current row: (nx + 1,)
    row_x = np.empty(nx + 1)
    row_y = np.empty(nx + 1)
    row_z = np.zeros(nx + 1)
    dz = 0.0
    dvx = 0.0
    dvy = 0.0
    dvz = 0.0

    # vertical springs from the bottom wall anchors (at y = origin_y - spacing) to row 0
    for i in range(nx):
        dx = x[0, i] - (origin_x + i * spacing)
        dy = y[0, i] - (origin_y - spacing)
        if z is not None:
            dz = z[0, i]
        if dashpot is not None:
            dvx = vx[0, i]
            dvy = vy[0, i]
            if vz is not None:
                dvz = vz[0, i]
        f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot)
        power += p
        below_x[i] = f * dx
        below_y[i] = f * dy
        if z is not None:
            below_z[i] = f * dz

    for j in range(ny):
        # vertical springs between row j and row j + 1 (or the top wall anchors for the last row)
        if j < ny - 1:
            for i in range(nx):
                dx = x[j + 1, i] - x[j, i]
                dy = y[j + 1, i] - y[j, i]
                if z is not None:
                    dz = z[j + 1, i] - z[j, i]
                if dashpot is not None:
                    dvx = vx[j + 1, i] - vx[j, i]
                    dvy = vy[j + 1, i] - vy[j, i]
                    if vz is not None:
                        dvz = vz[j + 1, i] - vz[j, i]
                f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot)
                power += p
                above_x[i] = f * dx
                above_y[i] = f * dy
                if z is not None:
                    above_z[i] = f * dz
        else:
            top = origin_y + ny * spacing
            for i in range(nx):
                dx = (origin_x + i * spacing) - x[j, i]
                dy = top - y[j, i]
                if z is not None:
                    dz = -z[j, i]
                if dashpot is not None:
                    dvx = -vx[j, i]
                    dvy = -vy[j, i]
                    if vz is not None:
                        dvz = -vz[j, i]
                f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot)
                power += p
                above_x[i] = f * dx
                above_y[i] = f * dy
                if z is not None:
                    above_z[i] = f * dz

        # horizontal springs of row j: spring i joins particle i-1 (or the left wall) to particle i
        row_y_rest = origin_y + j * spacing
        dx = x[j, 0] - (origin_x - spacing)
        dy = y[j, 0] - row_y_rest
        if z is not None:
            dz = z[j, 0]
        if dashpot is not None:
            dvx = vx[j, 0]
            dvy = vy[j, 0]
            if vz is not None:
                dvz = vz[j, 0]
        f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot)
        power += p
        row_x[0] = f * dx
        row_y[0] = f * dy
        if z is not None:
            row_z[0] = f * dz
        for i in range(1, nx):
            dx = x[j, i] - x[j, i - 1]
            dy = y[j, i] - y[j, i - 1]
            if z is not None:
                dz = z[j, i] - z[j, i - 1]
            if dashpot is not None:
                dvx = vx[j, i] - vx[j, i - 1]
                dvy = vy[j, i] - vy[j, i - 1]
                if vz is not None:
                    dvz = vz[j, i] - vz[j, i - 1]
            f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot)
            power += p
            row_x[i] = f * dx
            row_y[i] = f * dy
            if z is not None:
                row_z[i] = f * dz
        dx = (origin_x + nx * spacing) - x[j, nx - 1]
        dy = row_y_rest - y[j, nx - 1]
        if z is not None:
            dz = -z[j, nx - 1]
        if dashpot is not None:
            dvx = -vx[j, nx - 1]
            dvy = -vy[j, nx - 1]
            if vz is not None:
                dvz = -vz[j, nx - 1]
        f, p = _spring_factor(dx, dy, dz, dvx, dvy, dvz, stiffness, rest_length, dashpot)
        power += p
        row_x[nx] = f * dx
        row_y[nx] = f * dy
        if z is not None:
            row_z[nx] = f * dz

        power += _sum_forces(
            j, row_x, row_y, row_z, above_x, above_y, above_z, below_x, below_y, below_z,
            vx, vy, vz, inverse_mass, drag, gravity, ax, ay, az,
        )
        below_x, above_x = above_x, below_x
        below_y, above_y = above_y, below_y
        below_z, above_z = above_z, below_z
    return power


@njit(**_JIT)
def _sum_forces(
    j, row_x, row_y, row_z, above_x, above_y, above_z, below_x, below_y, below_z,
    vx, vy, vz, inverse_mass, drag, gravity, ax, ay, az,
):
    """Net spring force (+ drag, gravity) on every particle of row j, divided by mass into a.

    Returns the power dissipated by drag in this row.
    """
    nx = row_x.shape[0] - 1
    power = 0.0
    for i in range(nx):
        w = inverse_mass[j, i]
        fx = row_x[i + 1] - row_x[i] + above_x[i] - below_x[i]
        fy = row_y[i + 1] - row_y[i] + above_y[i] - below_y[i]
        if drag is not None:
            fx -= drag * vx[j, i]
            fy -= drag * vy[j, i]
            power += drag * (vx[j, i] * vx[j, i] + vy[j, i] * vy[j, i])
        if gravity is not None:
            ax[j, i] = fx * w + gravity[0]
            ay[j, i] = fy * w + gravity[1]
        else:
            ax[j, i] = fx * w
            ay[j, i] = fy * w
        if az is not None:
            fz = row_z[i + 1] - row_z[i] + above_z[i] - below_z[i]
            if drag is not None:
                fz -= drag * vz[j, i]
                power += drag * vz[j, i] * vz[j, i]
            if gravity is not None:
                az[j, i] = fz * w + gravity[2]
            else:
                az[j, i] = fz * w
    return power


@njit(**_JIT)
def linear_accelerations(
    x, y, z, vx, vy, vz, inverse_mass, stiffness, tension_stiffness, spacing, origin_x, origin_y,
    dashpot, drag, gravity, ax, ay, az,
):
    """Accelerations under the springs linearised about the rest lattice.

    Along a spring the stiffness is k, across it T/a (``tension_stiffness``, the pre-tension
    T = k (a - L) divided by the spacing a); a dashpot acts on the along-spring relative velocity.
    Same arguments, optional terms and return value as ``nonlinear_accelerations``.
    """
    ny, nx = x.shape
    k_along = stiffness
    k_across = tension_stiffness
    power = 0.0
    below_x = np.empty(nx)
    below_y = np.empty(nx)
    below_z = np.empty(nx)
    above_x = np.empty(nx)
    above_y = np.empty(nx)
    above_z = np.empty(nx)
    row_x = np.empty(nx + 1)
    row_y = np.empty(nx + 1)
    row_z = np.empty(nx + 1)

    # displacement differences: a vertical spring stretches by dy - spacing, shears by dx (and dz)
    for i in range(nx):
        shear_x = x[0, i] - (origin_x + i * spacing)
        stretch = y[0, i] - origin_y
        below_x[i] = k_across * shear_x
        below_y[i] = k_along * stretch
        below_z[i] = 0.0
        if z is not None:
            below_z[i] = k_across * z[0, i]
        if dashpot is not None:
            below_y[i] += dashpot * vy[0, i]
            power += dashpot * vy[0, i] * vy[0, i]

    for j in range(ny):
        if j < ny - 1:
            for i in range(nx):
                above_x[i] = k_across * (x[j + 1, i] - x[j, i])
                above_y[i] = k_along * (y[j + 1, i] - y[j, i] - spacing)
                above_z[i] = 0.0
                if z is not None:
                    above_z[i] = k_across * (z[j + 1, i] - z[j, i])
                if dashpot is not None:
                    relative = vy[j + 1, i] - vy[j, i]
                    above_y[i] += dashpot * relative
                    power += dashpot * relative * relative
        else:
            top = origin_y + ny * spacing
            for i in range(nx):
                above_x[i] = k_across * ((origin_x + i * spacing) - x[j, i])
                above_y[i] = k_along * (top - y[j, i] - spacing)
                above_z[i] = 0.0
                if z is not None:
                    above_z[i] = -k_across * z[j, i]
                if dashpot is not None:
                    above_y[i] -= dashpot * vy[j, i]
                    power += dashpot * vy[j, i] * vy[j, i]

        row_y_rest = origin_y + j * spacing
        for i in range(nx + 1):
            if i == 0:
                stretch = x[j, 0] - origin_x
                shear_y = y[j, 0] - row_y_rest
                shear_z = 0.0
                if z is not None:
                    shear_z = z[j, 0]
            elif i == nx:
                stretch = (origin_x + nx * spacing) - x[j, nx - 1] - spacing
                shear_y = row_y_rest - y[j, nx - 1]
                shear_z = 0.0
                if z is not None:
                    shear_z = -z[j, nx - 1]
            else:
                stretch = x[j, i] - x[j, i - 1] - spacing
                shear_y = y[j, i] - y[j, i - 1]
                shear_z = 0.0
                if z is not None:
                    shear_z = z[j, i] - z[j, i - 1]
            row_x[i] = k_along * stretch
            row_y[i] = k_across * shear_y
            row_z[i] = k_across * shear_z
            if dashpot is not None:
                right = 0.0
                left = 0.0
                if i < nx:
                    right = vx[j, i]
                if i > 0:
                    left = vx[j, i - 1]
                row_x[i] += dashpot * (right - left)
                power += dashpot * (right - left) * (right - left)

        power += _sum_forces(
            j, row_x, row_y, row_z, above_x, above_y, above_z, below_x, below_y, below_z,
            vx, vy, vz, inverse_mass, drag, gravity, ax, ay, az,
        )
        below_x, above_x = above_x, below_x
        below_y, above_y = above_y, below_y
        below_z, above_z = above_z, below_z
    return power


# --- element-wise updates used by the integrators ------------------------------------------------


@njit(**_JIT)
def add_scaled(out, base, scale, direction):
    """out = base + scale * direction (all (ny, nx); out may alias base)."""
    ny, nx = out.shape
    for j in range(ny):
        for i in range(nx):
            out[j, i] = base[j, i] + scale * direction[j, i]


@njit(**_JIT)
def add_two_scaled(out, base, scale_a, direction_a, scale_b, direction_b):
    """out = base + scale_a * direction_a + scale_b * direction_b (out may alias base)."""
    ny, nx = out.shape
    for j in range(ny):
        for i in range(nx):
            out[j, i] = base[j, i] + scale_a * direction_a[j, i] + scale_b * direction_b[j, i]


@njit(**_JIT)
def verlet_drift(position, velocity, acceleration, dt):
    """First half of a velocity-Verlet step: v += dt/2 a; x += dt v (in place)."""
    ny, nx = position.shape
    half = 0.5 * dt
    for j in range(ny):
        for i in range(nx):
            v = velocity[j, i] + half * acceleration[j, i]
            velocity[j, i] = v
            position[j, i] += dt * v


# --- observables ----------------------------------------------------------------------------------


@njit(**_JIT)
def nonlinear_spring_lengths(x, y, z, spacing, origin_x, origin_y, horizontal, vertical):
    """Length of every spring: horizontal (ny, nx + 1) and vertical (ny + 1, nx), written in place."""
    ny, nx = x.shape
    for j in range(ny):
        row_y_rest = origin_y + j * spacing
        for i in range(nx + 1):
            if i == 0:
                dx = x[j, 0] - (origin_x - spacing)
                dy = y[j, 0] - row_y_rest
                dz = 0.0
                if z is not None:
                    dz = z[j, 0]
            elif i == nx:
                dx = (origin_x + nx * spacing) - x[j, nx - 1]
                dy = row_y_rest - y[j, nx - 1]
                dz = 0.0
                if z is not None:
                    dz = -z[j, nx - 1]
            else:
                dx = x[j, i] - x[j, i - 1]
                dy = y[j, i] - y[j, i - 1]
                dz = 0.0
                if z is not None:
                    dz = z[j, i] - z[j, i - 1]
            horizontal[j, i] = np.sqrt(dx * dx + dy * dy + dz * dz)
    for j in range(ny + 1):
        for i in range(nx):
            column_x_rest = origin_x + i * spacing
            if j == 0:
                dx = x[0, i] - column_x_rest
                dy = y[0, i] - (origin_y - spacing)
                dz = 0.0
                if z is not None:
                    dz = z[0, i]
            elif j == ny:
                dx = column_x_rest - x[ny - 1, i]
                dy = (origin_y + ny * spacing) - y[ny - 1, i]
                dz = 0.0
                if z is not None:
                    dz = -z[ny - 1, i]
            else:
                dx = x[j, i] - x[j - 1, i]
                dy = y[j, i] - y[j - 1, i]
                dz = 0.0
                if z is not None:
                    dz = z[j, i] - z[j - 1, i]
            vertical[j, i] = np.sqrt(dx * dx + dy * dy + dz * dz)
