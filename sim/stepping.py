"""Numba step loops of the four integrators: explicit Euler, Heun, velocity Verlet, classic RK4.

Each ``*_steps`` function advances a state by ``n`` steps of size ``dt`` entirely in compiled code
(no Python between steps) and returns the energy dissipated by dashpots and drag over those steps
(J), integrated with the integrator's own quadrature so that kinetic + potential + dissipated is
conserved to the integrator's order.

Every force evaluation is one sweep over the rows (``sim.kernels.row_accelerations``) with the
integrator's update of each row fused in right after that row's forces are known: a row that has
been swept is never read again by the same sweep, so it may be overwritten in place.  Velocity
Verlet also drifts each row just before its forces are needed.  One sweep thus touches each array
once, which is what makes the step fast on large lattices.

Arrays: ``position``, ``velocity`` and the work arrays are C-contiguous ``(dim, ny, nx)`` float
arrays (m, m/s, m/s^2).  ``out_of_plane`` is None for planar scenes (dim == 2) and True for
dim == 3; ``dashpot``, ``drag``, ``gravity`` are None when the scene has none of them, which
selects compiled code without those terms (see ``sim.kernels``).  ``parameters`` is a
``sim.kernels.SpringParameters`` record.  Precision: the arrays, ``dt`` and every parameter are
all float64 or all float32, and so is the arithmetic; dissipated energy sums in float64.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sim.kernels import leapfrog_rows, row_accelerations, vertical_springs

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def _components(out_of_plane, array):
    """(x, y, z) component fields of a (dim, ny, nx) array; z is None for planar scenes."""
    if out_of_plane is None:
        return array[0], array[1], None
    return array[0], array[1], array[2]


@njit(**_JIT)
def accelerations(
    linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass, parameters,
    dashpot, drag, gravity, acceleration,
):
    """Write the acceleration of every particle into ``acceleration``; return dissipated power (W)."""
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    dim, ny, nx = position.shape
    below = np.empty((3, nx), position.dtype)
    above = np.empty((3, nx), position.dtype)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    power = vertical_springs(0, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, below)
    for j in range(ny):
        power += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear, parameters,
                                   dashpot, drag, gravity, below, above, horizontal, row,
                                   uniform_inverse_mass)
        for c in range(dim):
            for i in range(nx):
                acceleration[c, j, i] = row[c, i]
        below, above = above, below
    return power


@njit(**_JIT)
def euler_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot,
    drag, gravity,
):
    """Explicit Euler: x += dt v(t); v += dt a(t).  First order; no work array needed."""
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    dim, ny, nx = position.shape
    below = np.empty((3, nx), position.dtype)
    above = np.empty((3, nx), position.dtype)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    dissipated = 0.0
    for _ in range(n):
        power = vertical_springs(0, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, below)
        for j in range(ny):
            power += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear, parameters,
                                       dashpot, drag, gravity, below, above, horizontal, row,
                                       uniform_inverse_mass)
            for c in range(dim):
                for i in range(nx):
                    position[c, j, i] += dt * velocity[c, j, i]
                    velocity[c, j, i] += dt * row[c, i]
            below, above = above, below
        dissipated += dt * power
    return dissipated


@njit(**_JIT)
def heun_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot,
    drag, gravity, first_acceleration, stage_position, stage_velocity,
):
    """Heun's predictor-corrector (explicit trapezoid): Euler predictor, trapezoidal corrector.

    The two sweeps run as a wavefront: the corrector works on row j - 1 right after the predictor
    has finished row j, so each step reads and writes the state once while it is in cache.  The
    work arrays are ring buffers of at least 2 rows, (dim, 2, nx); row j is kept at j % rows.
    """
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    xs, ys, zs = _components(out_of_plane, stage_position)
    vxs, vys, vzs = _components(out_of_plane, stage_velocity)
    dim, ny, nx = position.shape
    ring = stage_position.shape[1]  # rows kept of the stage arrays (a ring buffer, >= 2)
    vertical = np.empty((2, 2, 3, nx), position.dtype)  # (sweep, below/above, component, column)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    for _ in range(n):
        power = 0.0
        power_stage = 0.0
        for t in range(ny + 1):
            j = t  # predictor on (x, v): store a(x, v) and the Euler prediction
            if j < ny:
                below = vertical[0, j % 2]
                above = vertical[0, (j + 1) % 2]
                if j == 0:
                    power += vertical_springs(0, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot,
                                              below)
                power += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear,
                                           parameters, dashpot, drag, gravity, below, above,
                                           horizontal, row, uniform_inverse_mass)
                slot = j % ring
                for c in range(dim):
                    for i in range(nx):
                        first_acceleration[c, slot, i] = row[c, i]
                        stage_position[c, slot, i] = position[c, j, i] + dt * velocity[c, j, i]
                        stage_velocity[c, slot, i] = velocity[c, j, i] + dt * row[c, i]
            j = t - 1  # corrector on the prediction: trapezoid of the two slopes
            if j >= 0:
                below = vertical[1, j % 2]
                above = vertical[1, (j + 1) % 2]
                if j == 0:
                    power_stage += vertical_springs(0, ny, xs, ys, zs, vxs, vys, vzs, linear,
                                                    parameters, dashpot, below)
                power_stage += row_accelerations(j, ny, xs, ys, zs, vxs, vys, vzs, inverse_mass,
                                                 linear, parameters, dashpot, drag, gravity,
                                                 below, above, horizontal, row, uniform_inverse_mass)
                slot = j % ring
                for c in range(dim):
                    for i in range(nx):
                        position[c, j, i] += half * (velocity[c, j, i] + stage_velocity[c, slot, i])
                        velocity[c, j, i] += half * (first_acceleration[c, slot, i] + row[c, i])
        dissipated += half * (power + power_stage)
    return dissipated


@njit(**_JIT)
def _verlet_drift(j, dt, position, velocity, acceleration, predicted_velocity, damped):
    """Half kick and drift of row j (and the predicted velocity v + dt a when damped)."""
    dim, ny, nx = position.shape
    half = type(dt)(0.5) * dt
    for c in range(dim):
        for i in range(nx):
            if damped:
                predicted_velocity[c, j, i] = velocity[c, j, i] + dt * acceleration[c, j, i]
            v = velocity[c, j, i] + half * acceleration[c, j, i]
            velocity[c, j, i] = v
            position[c, j, i] += dt * v


@njit(**_JIT)
def verlet_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot,
    drag, gravity, acceleration, previous_power, predicted_velocity,
):
    """Velocity Verlet: half kick, drift, new forces, half kick.  Second order, symplectic.

    ``acceleration`` must hold a(x, v) of the current state on entry (``previous_power`` the
    power that went with it) and holds the new one on exit, so a step costs one force sweep.

    Without damping, consecutive steps run as leapfrog (kick by a full dt, drift) on the
    half-step velocities, each sweep updating a row in place once its forces are known; the first
    sweep drifts each row just before it is needed and the last one kicks by half a step to bring
    the velocities back to whole steps.  That is algebraically velocity Verlet and reads and
    writes only positions and velocities in the steps between.
    With velocity-dependent forces (damping), every step is a full velocity-Verlet step whose new
    forces use the predicted velocity v + dt a, which keeps it explicit and second order.
    Returns (dissipated, power).
    """
    damped = dashpot is not None or drag is not None
    x, y, z = _components(out_of_plane, position)
    if damped:
        vx, vy, vz = _components(out_of_plane, predicted_velocity)
    else:
        vx, vy, vz = _components(out_of_plane, velocity)
    dim, ny, nx = position.shape
    below = np.empty((3, nx), position.dtype)
    above = np.empty((3, nx), position.dtype)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    power = previous_power
    for step in range(n):
        first = step == 0 or damped
        last = step == n - 1 or damped
        if first:
            _verlet_drift(0, dt, position, velocity, acceleration, predicted_velocity, damped)
        new_power = vertical_springs(0, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, below)
        for j in range(ny):
            if first and j + 1 < ny:
                _verlet_drift(j + 1, dt, position, velocity, acceleration, predicted_velocity,
                              damped)
            new_power += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear,
                                           parameters, dashpot, drag, gravity, below, above,
                                           horizontal, row, uniform_inverse_mass)
            if last:
                for c in range(dim):
                    for i in range(nx):
                        acceleration[c, j, i] = row[c, i]
                        velocity[c, j, i] += half * row[c, i]
            else:  # leapfrog: v(t + dt/2) = v(t - dt/2) + dt a(t); x(t + dt) = x(t) + dt v
                for c in range(dim):
                    for i in range(nx):
                        v = velocity[c, j, i] + dt * row[c, i]
                        velocity[c, j, i] = v
                        position[c, j, i] += dt * v
            below, above = above, below
        dissipated += half * (power + new_power)
        power = new_power
    return dissipated, power


@njit(**_JIT)
def rk4_steps(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot,
    drag, gravity, stage_position, stage_velocity, sum_position, sum_velocity,
):
    """Classic fourth-order Runge-Kutta on (x, v).

    The four stages run as a wavefront over the rows: at sweep position t, stage s works on row
    t - s, which needs rows t - s and t - s + 1 of its input, finished one iteration earlier by
    stage s - 1.  Each stage overwrites the stage state of a row with the next stage's input once
    it no longer needs it, and the last stage writes the new (x, v) of rows every stage has left
    behind.  So a step streams the state through the cache once instead of four times, and the
    stage arrays only need to hold 4 rows: they are ring buffers of shape (dim, 4, nx) (full
    (dim, ny, nx) arrays work too), row j being stored at index j % rows.
    """
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    xs, ys, zs = _components(out_of_plane, stage_position)
    vxs, vys, vzs = _components(out_of_plane, stage_velocity)
    dim, ny, nx = position.shape
    ring = stage_position.shape[1]  # rows kept of the stage arrays (a ring buffer, >= 4)
    vertical = np.empty((4, 2, 3, nx), position.dtype)  # (stage, below/above, component, column)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    powers = np.zeros(4)
    sixth = dt / type(dt)(6.0)
    third = dt / type(dt)(3.0)
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    for _ in range(n):
        powers[:] = 0.0
        for t in range(ny + 3):
            for stage in range(4):
                j = t - stage
                if j < 0 or j >= ny:
                    continue
                below = vertical[stage, j % 2]
                above = vertical[stage, (j + 1) % 2]
                if stage == 0:
                    if j == 0:
                        powers[0] += vertical_springs(0, ny, x, y, z, vx, vy, vz, linear,
                                                      parameters, dashpot, below)
                    powers[0] += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear,
                                                   parameters, dashpot, drag, gravity, below,
                                                   above, horizontal, row, uniform_inverse_mass)
                    slot = j % ring
                    for c in range(dim):
                        for i in range(nx):
                            v = velocity[c, j, i]
                            sum_position[c, slot, i] = position[c, j, i] + sixth * v
                            sum_velocity[c, slot, i] = v + sixth * row[c, i]
                            stage_position[c, slot, i] = position[c, j, i] + half * v
                            stage_velocity[c, slot, i] = v + half * row[c, i]
                    continue
                if j == 0:
                    powers[stage] += vertical_springs(0, ny, xs, ys, zs, vxs, vys, vzs, linear,
                                                      parameters, dashpot, below)
                powers[stage] += row_accelerations(j, ny, xs, ys, zs, vxs, vys, vzs, inverse_mass,
                                                   linear, parameters, dashpot, drag, gravity,
                                                   below, above, horizontal, row, uniform_inverse_mass)
                slot = j % ring
                if stage < 3:
                    step_to_next = half if stage == 1 else dt
                    for c in range(dim):
                        for i in range(nx):
                            stage_v = stage_velocity[c, slot, i]
                            sum_position[c, slot, i] += third * stage_v
                            sum_velocity[c, slot, i] += third * row[c, i]
                            stage_position[c, slot, i] = position[c, j, i] + step_to_next * stage_v
                            stage_velocity[c, slot, i] = velocity[c, j, i] + step_to_next * row[c, i]
                else:
                    for c in range(dim):
                        for i in range(nx):
                            position[c, j, i] = (
                                sum_position[c, slot, i] + sixth * stage_velocity[c, slot, i]
                            )
                            velocity[c, j, i] = sum_velocity[c, slot, i] + sixth * row[c, i]
        dissipated += sixth * (powers[0] + 2.0 * powers[1] + 2.0 * powers[2] + powers[3])
    return dissipated


@njit(**_JIT)
def verlet_open(dt, position, velocity, acceleration):
    """Velocity Verlet state (x, v, a) -> leapfrog state: v += dt/2 a; x += dt v (in place)."""
    half = type(dt)(0.5) * dt
    flat_position = position.reshape(-1)
    flat_velocity = velocity.reshape(-1)
    flat_acceleration = acceleration.reshape(-1)
    for k in range(flat_position.size):
        v = flat_velocity[k] + half * flat_acceleration[k]
        flat_velocity[k] = v
        flat_position[k] += dt * v


@njit(**_JIT)
def verlet_close(dt, velocity, acceleration):
    """Leapfrog half-step velocity -> whole step: v += dt/2 a, with a = a(x) just computed."""
    half = type(dt)(0.5) * dt
    flat_velocity = velocity.reshape(-1)
    flat_acceleration = acceleration.reshape(-1)
    for k in range(flat_velocity.size):
        flat_velocity[k] += half * flat_acceleration[k]


@njit(**_JIT)
def leapfrog_steps(n, dt, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
                   parameters, gravity, block_starts, boundary, below, horizontal):
    """n leapfrog steps (kick by dt, drift by dt) of undamped nonlinear springs, in row blocks.

    Rows ``block_starts[b] .. block_starts[b + 1] - 1`` form block b.  Each step first computes
    the springs across every block boundary (and the wall springs at the bottom and top) from the
    unmoved positions into ``boundary`` (blocks + 1, 3, nx), then sweeps the blocks independently
    (``leapfrog_rows``); ``below`` (blocks, 3, nx) and ``horizontal`` (blocks, 3, nx + 1) are
    per-block scratch.  This one runs the blocks one after the other on the calling thread;
    ``leapfrog_steps_parallel`` runs them on numba's threads and computes the same numbers.
    """
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    ny = position.shape[1]
    blocks = block_starts.size - 1
    for _ in range(n):
        for b in range(blocks + 1):
            vertical_springs(block_starts[b], ny, x, y, z, vx, vy, vz, False, parameters, None,
                             boundary[b])
        for b in range(blocks):
            below[b, :, :] = boundary[b]
            leapfrog_rows(block_starts[b], block_starts[b + 1], ny, dt, x, y, z, vx, vy, vz,
                          inverse_mass, uniform_inverse_mass, parameters, gravity, below[b],
                          boundary[b + 1], horizontal[b])


@njit(parallel=True, **_JIT)
def leapfrog_steps_parallel(n, dt, out_of_plane, position, velocity, inverse_mass,
                            uniform_inverse_mass, parameters, gravity, block_starts, boundary,
                            below, horizontal):
    """``leapfrog_steps`` with the boundary springs and the row blocks spread over numba's
    threads (``prange``; ``numba.set_num_threads`` sets how many).  The loop bodies are
    functions of their own: numba's parallel transformation of the inlined 3-D body read stale
    out-of-plane components (runs differed from one thread and blew up)."""
    blocks = block_starts.size - 1
    for _ in range(n):
        for b in prange(blocks + 1):
            _boundary_springs(b, out_of_plane, position, velocity, parameters, block_starts,
                              boundary)
        for b in prange(blocks):
            _leapfrog_block(b, dt, out_of_plane, position, velocity, inverse_mass,
                            uniform_inverse_mass, parameters, gravity, block_starts, boundary,
                            below, horizontal)


@njit(**_JIT)
def _boundary_springs(b, out_of_plane, position, velocity, parameters, block_starts, boundary):
    """The springs below row block_starts[b] into boundary[b] (a function of its own, so that
    numba's parallel transformation leaves its body alone)."""
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    vertical_springs(block_starts[b], position.shape[1], x, y, z, vx, vy, vz, False, parameters,
                     None, boundary[b])


@njit(**_JIT)
def _leapfrog_block(b, dt, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
                    parameters, gravity, block_starts, boundary, below, horizontal):
    """Leapfrog kick and drift of row block b (``leapfrog_steps``)."""
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    below[b, :, :] = boundary[b]
    leapfrog_rows(block_starts[b], block_starts[b + 1], position.shape[1], dt, x, y, z, vx, vy,
                  vz, inverse_mass, uniform_inverse_mass, parameters, gravity, below[b],
                  boundary[b + 1], horizontal[b])


# --- row-block parallel step loops (threads > 1) -----------------------------------------------
#
# The one-thread loops above fuse every stage into one wavefront sweep; a wavefront cannot be cut
# into independent row blocks without halo rows recomputed at every block edge, which is what
# ``rk4_steps_blocks`` and ``heun_steps_blocks`` at the end of this module do.  The loops below
# (the other integrators, and RK4 and Heun on lattices too thin for halos) run each force
# evaluation as one phase over all row blocks in parallel (``prange`` over blocks,
# ``numba.set_num_threads`` sets how many threads): a phase reads only arrays that no
# block writes during it and writes only its own rows, so the blocks need no synchronisation
# inside a phase.  Stage states therefore live in full (dim, ny, nx) arrays.  Per particle the
# arithmetic is the same expressions as the one-thread loops, so positions and velocities agree
# with one thread to round-off (usually bitwise); the dissipated energy is summed block by block
# and differs in the last bits.  ``block_starts`` (blocks + 1,) int64: block b is rows
# block_starts[b] .. block_starts[b + 1] - 1.


@njit(**_JIT)
def _force_rows(j0, j1, linear, out_of_plane, position, force_velocity, inverse_mass,
                uniform_inverse_mass, parameters, dashpot, drag, gravity, acceleration, kick,
                velocity):
    """Accelerations (m/s^2) of rows j0 .. j1-1 of the state (``position``, ``force_velocity``)
    into the full array ``acceleration``; with ``kick`` not None also ``velocity += kick * a``
    for those rows.  Returns the dissipated power (W) of the springs in and above those rows and
    below row j0 only when j0 == 0 (each spring's power counted by exactly one block).

    The parallel loops call only such functions of whole arrays from their ``prange`` bodies:
    numba's parallel transformation of bodies that use the unpacked (x, y, z) components read
    stale out-of-plane components in 3-D."""
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, force_velocity)
    dim, ny, nx = acceleration.shape
    below = np.empty((3, nx), x.dtype)
    above = np.empty((3, nx), x.dtype)
    horizontal = np.empty((3, nx + 1), x.dtype)
    row = np.empty((3, nx), x.dtype)
    power = vertical_springs(j0, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot, below)
    if j0 > 0:
        power = 0.0
    for j in range(j0, j1):
        power += row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear, parameters,
                                   dashpot, drag, gravity, below, above, horizontal, row,
                                   uniform_inverse_mass)
        for c in range(dim):
            for i in range(nx):
                acceleration[c, j, i] = row[c, i]
                if kick is not None:
                    velocity[c, j, i] += kick * row[c, i]
        below, above = above, below
    return power


@njit(parallel=True, **_JIT)
def accelerations_parallel(
    linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass, parameters,
    dashpot, drag, gravity, acceleration, block_starts,
):
    """``accelerations`` with the row blocks on numba's threads; returns the dissipated power (W)."""
    blocks = block_starts.size - 1
    powers = np.zeros(blocks)
    for b in prange(blocks):
        powers[b] = _force_rows(block_starts[b], block_starts[b + 1], linear, out_of_plane,
                                position, velocity, inverse_mass, uniform_inverse_mass,
                                parameters, dashpot, drag, gravity, acceleration, None, velocity)
    return powers.sum()


@njit(parallel=True, **_JIT)
def euler_steps_parallel(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, acceleration, block_starts,
):
    """``euler_steps`` in two phases per step: accelerations of all row blocks in parallel into
    ``acceleration`` (dim, ny, nx), then x += dt v; v += dt a over the blocks in parallel."""
    dim, ny, nx = position.shape
    blocks = block_starts.size - 1
    powers = np.zeros(blocks)
    dissipated = 0.0
    for _ in range(n):
        for b in prange(blocks):
            powers[b] = _force_rows(block_starts[b], block_starts[b + 1], linear, out_of_plane,
                                    position, velocity, inverse_mass, uniform_inverse_mass,
                                    parameters, dashpot, drag, gravity, acceleration, None,
                                    velocity)
        for b in prange(blocks):
            for c in range(dim):
                for j in range(block_starts[b], block_starts[b + 1]):
                    for i in range(nx):
                        position[c, j, i] += dt * velocity[c, j, i]
                        velocity[c, j, i] += dt * acceleration[c, j, i]
        dissipated += dt * powers.sum()
    return dissipated


@njit(parallel=True, **_JIT)
def verlet_steps_parallel(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, acceleration, previous_power, predicted_velocity,
    block_starts,
):
    """Velocity Verlet steps (damped scenes and linearised springs) in two phases per step: half
    kick and drift of every row (and the predicted velocity v + dt a when damped), then the new
    accelerations and the second half kick, each phase over the row blocks in parallel.
    ``acceleration`` holds a(x, v) on entry and on exit, as for ``verlet_steps``.
    Returns (dissipated, power)."""
    damped = dashpot is not None or drag is not None
    force_velocity = predicted_velocity if damped else velocity
    blocks = block_starts.size - 1
    powers = np.zeros(blocks)
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    power = previous_power
    for _ in range(n):
        for b in prange(blocks):
            for j in range(block_starts[b], block_starts[b + 1]):
                _verlet_drift(j, dt, position, velocity, acceleration, predicted_velocity, damped)
        for b in prange(blocks):
            powers[b] = _force_rows(block_starts[b], block_starts[b + 1], linear, out_of_plane,
                                    position, force_velocity, inverse_mass, uniform_inverse_mass,
                                    parameters, dashpot, drag, gravity, acceleration, half,
                                    velocity)
        new_power = powers.sum()
        dissipated += half * (power + new_power)
        power = new_power
    return dissipated, power


@njit(**_JIT)
def _stage_rows(kind, j0, j1, ny, dt, linear, out_of_plane, position, velocity, inverse_mass,
                uniform_inverse_mass, parameters, dashpot, drag, gravity, source_position,
                source_velocity, target_position, target_velocity, sum_position, sum_velocity):
    """One stage of RK4 (``kind`` 0..3) or Heun (``kind`` 4: predictor, 5: corrector) on rows
    j0 .. j1-1: the forces of the stage input (``source_*``, full arrays) and the fused update,
    the same expressions as ``rk4_steps`` and ``heun_steps``.  Writes the next stage's input into
    ``target_*`` (Heun's predictor keeps a(x, v) in ``sum_velocity``), the running RK4 sums into
    ``sum_*``, and the new state into ``position``/``velocity`` at the last stage.  Reads
    ``position``/``velocity`` of its own rows only, except as the input of stages 0 and 4.
    Returns the dissipated power (W) as ``_force_rows`` counts it."""
    xs, ys, zs = _components(out_of_plane, source_position)
    vxs, vys, vzs = _components(out_of_plane, source_velocity)
    dim, _, nx = position.shape
    below = np.empty((3, nx), position.dtype)
    above = np.empty((3, nx), position.dtype)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    sixth = dt / type(dt)(6.0)
    third = dt / type(dt)(3.0)
    half = type(dt)(0.5) * dt
    power = vertical_springs(j0, ny, xs, ys, zs, vxs, vys, vzs, linear, parameters, dashpot, below)
    if j0 > 0:
        power = 0.0
    for j in range(j0, j1):
        power += row_accelerations(j, ny, xs, ys, zs, vxs, vys, vzs, inverse_mass, linear,
                                   parameters, dashpot, drag, gravity, below, above, horizontal,
                                   row, uniform_inverse_mass)
        below, above = above, below
        if kind == 0:
            for c in range(dim):
                for i in range(nx):
                    v = velocity[c, j, i]
                    sum_position[c, j, i] = position[c, j, i] + sixth * v
                    sum_velocity[c, j, i] = v + sixth * row[c, i]
                    target_position[c, j, i] = position[c, j, i] + half * v
                    target_velocity[c, j, i] = v + half * row[c, i]
        elif kind == 1 or kind == 2:
            step_to_next = half if kind == 1 else dt
            for c in range(dim):
                for i in range(nx):
                    stage_v = source_velocity[c, j, i]
                    sum_position[c, j, i] += third * stage_v
                    sum_velocity[c, j, i] += third * row[c, i]
                    target_position[c, j, i] = position[c, j, i] + step_to_next * stage_v
                    target_velocity[c, j, i] = velocity[c, j, i] + step_to_next * row[c, i]
        elif kind == 3:
            for c in range(dim):
                for i in range(nx):
                    position[c, j, i] = sum_position[c, j, i] + sixth * source_velocity[c, j, i]
                    velocity[c, j, i] = sum_velocity[c, j, i] + sixth * row[c, i]
        elif kind == 4:
            for c in range(dim):
                for i in range(nx):
                    sum_velocity[c, j, i] = row[c, i]
                    target_position[c, j, i] = position[c, j, i] + dt * velocity[c, j, i]
                    target_velocity[c, j, i] = velocity[c, j, i] + dt * row[c, i]
        else:
            for c in range(dim):
                for i in range(nx):
                    position[c, j, i] += half * (velocity[c, j, i] + source_velocity[c, j, i])
                    velocity[c, j, i] += half * (sum_velocity[c, j, i] + row[c, i])
    return power


@njit(parallel=True, **_JIT)
def rk4_steps_parallel(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, stage_position, stage_velocity, next_position,
    next_velocity, sum_position, sum_velocity, block_starts,
):
    """``rk4_steps`` with each of the four stages one parallel phase over the row blocks.

    The work arrays are full (dim, ny, nx) arrays: stage inputs alternate between
    (``stage_*``) and (``next_*``) so that no phase overwrites what another block still reads."""
    ny = position.shape[1]
    blocks = block_starts.size - 1
    powers = np.zeros((4, blocks))
    sixth = dt / type(dt)(6.0)
    dissipated = 0.0
    for _ in range(n):
        for stage in range(4):
            source_p, source_v = stage_position, stage_velocity  # stages 1 and 3
            target_p, target_v = next_position, next_velocity
            if stage == 0:
                source_p, source_v = position, velocity
                target_p, target_v = stage_position, stage_velocity
            elif stage == 2:
                source_p, source_v = next_position, next_velocity
                target_p, target_v = stage_position, stage_velocity
            for b in prange(blocks):
                powers[stage, b] = _stage_rows(
                    stage, block_starts[b], block_starts[b + 1], ny, dt, linear, out_of_plane,
                    position, velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot,
                    drag, gravity, source_p, source_v, target_p, target_v, sum_position,
                    sum_velocity,
                )
        p = powers.sum(axis=1)
        dissipated += sixth * (p[0] + 2.0 * p[1] + 2.0 * p[2] + p[3])
    return dissipated


@njit(parallel=True, **_JIT)
def heun_steps_parallel(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, first_acceleration, stage_position, stage_velocity,
    block_starts,
):
    """``heun_steps`` with the predictor and the corrector each one parallel phase over the row
    blocks; the work arrays are full (dim, ny, nx) arrays."""
    ny = position.shape[1]
    blocks = block_starts.size - 1
    powers = np.zeros((2, blocks))
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    for _ in range(n):
        for b in prange(blocks):
            powers[0, b] = _stage_rows(
                4, block_starts[b], block_starts[b + 1], ny, dt, linear, out_of_plane, position,
                velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot, drag, gravity,
                position, velocity, stage_position, stage_velocity, stage_position,
                first_acceleration,
            )
        for b in prange(blocks):
            powers[1, b] = _stage_rows(
                5, block_starts[b], block_starts[b + 1], ny, dt, linear, out_of_plane, position,
                velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot, drag, gravity,
                stage_position, stage_velocity, stage_position, stage_velocity, stage_position,
                first_acceleration,
            )
        p = powers.sum(axis=1)
        dissipated += half * (p[0] + p[1])
    return dissipated


# --- RK4 as a wavefront per row block, with halo rows ------------------------------------------


RK4_HALO = 3
"""Rows beyond its own that a block's RK4 wavefront recomputes on each side (stage s on 3 - s)."""
RK4_RING = 8
"""Rows kept by a block's ring-buffer stage arrays (the wavefront needs 5 alive at once)."""


@njit(**_JIT)
def _deferred_slot(j, j0, j1, ny, halo):
    """Slot (0 .. 2 halo + 1) in a block's deferred rows of row j, or -1: the new state of the
    halo + 1 rows at each inner block edge is written after all blocks are done, since the
    neighbouring block's halo reads them."""
    if j0 > 0 and j < j0 + halo + 1:
        return j - j0
    if j1 < ny and j >= j1 - halo - 1:
        return halo + 1 + j - (j1 - halo - 1)
    return -1


@njit(**_JIT)
def _rk4_block(
    j0, j1, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, stage_position, stage_velocity, sum_position,
    sum_velocity, deferred_position, deferred_velocity, powers,
):
    """One RK4 step of rows j0 .. j1-1 as the wavefront of ``rk4_steps``, extended by halo rows.

    Stage s runs on rows j0 - 3 + s .. j1 + 2 - s (clipped to the lattice), so the last stage has
    its inputs for the block's own rows without waiting for another block; the stage arrays are
    this block's ring buffers (dim, RK4_RING, nx).  ``position``/``velocity`` are read, never
    written, within 4 rows of an inner block edge: those rows' new state goes to
    ``deferred_*`` (dim, 8, nx) (``_deferred_slot``).  ``powers`` (4,) receives each stage's
    dissipated power (W) of the springs of the block's own rows.
    """
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    xs, ys, zs = _components(out_of_plane, stage_position)
    vxs, vys, vzs = _components(out_of_plane, stage_velocity)
    dim, ny, nx = position.shape
    ring = stage_position.shape[1]
    vertical = np.empty((4, 2, 3, nx), position.dtype)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    sixth = dt / type(dt)(6.0)
    third = dt / type(dt)(3.0)
    half = type(dt)(0.5) * dt
    powers[:] = 0.0
    for t in range(max(j0 - RK4_HALO, 0), j1 + 3):
        for stage in range(4):
            j = t - stage
            first = max(j0 - RK4_HALO + stage, 0)
            if j < first or j >= min(j1 + RK4_HALO - stage, ny):
                continue
            own = j >= j0 and j < j1
            below = vertical[stage, j % 2]
            above = vertical[stage, (j + 1) % 2]
            slot = j % ring
            if stage == 0:
                if j == first:
                    p = vertical_springs(j, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot,
                                         below)
                    if j == 0:
                        powers[0] += p
                p = row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear,
                                      parameters, dashpot, drag, gravity, below, above,
                                      horizontal, row, uniform_inverse_mass)
                if own:
                    powers[0] += p
                for c in range(dim):
                    for i in range(nx):
                        v = velocity[c, j, i]
                        sum_position[c, slot, i] = position[c, j, i] + sixth * v
                        sum_velocity[c, slot, i] = v + sixth * row[c, i]
                        stage_position[c, slot, i] = position[c, j, i] + half * v
                        stage_velocity[c, slot, i] = v + half * row[c, i]
                continue
            if j == first:
                p = vertical_springs(j, ny, xs, ys, zs, vxs, vys, vzs, linear, parameters,
                                     dashpot, below)
                if j == 0:
                    powers[stage] += p
            p = row_accelerations(j, ny, xs, ys, zs, vxs, vys, vzs, inverse_mass, linear,
                                  parameters, dashpot, drag, gravity, below, above, horizontal,
                                  row, uniform_inverse_mass)
            if own:
                powers[stage] += p
            if stage < 3:
                step_to_next = half if stage == 1 else dt
                for c in range(dim):
                    for i in range(nx):
                        stage_v = stage_velocity[c, slot, i]
                        sum_position[c, slot, i] += third * stage_v
                        sum_velocity[c, slot, i] += third * row[c, i]
                        stage_position[c, slot, i] = position[c, j, i] + step_to_next * stage_v
                        stage_velocity[c, slot, i] = velocity[c, j, i] + step_to_next * row[c, i]
            else:
                deferred = _deferred_slot(j, j0, j1, ny, RK4_HALO)
                if deferred < 0:
                    for c in range(dim):
                        for i in range(nx):
                            position[c, j, i] = (
                                sum_position[c, slot, i] + sixth * stage_velocity[c, slot, i]
                            )
                            velocity[c, j, i] = sum_velocity[c, slot, i] + sixth * row[c, i]
                else:
                    for c in range(dim):
                        for i in range(nx):
                            deferred_position[c, deferred, i] = (
                                sum_position[c, slot, i] + sixth * stage_velocity[c, slot, i]
                            )
                            deferred_velocity[c, deferred, i] = (
                                sum_velocity[c, slot, i] + sixth * row[c, i]
                            )


@njit(**_JIT)
def _write_deferred(j0, j1, halo, position, velocity, deferred_position, deferred_velocity):
    """Copy a block's deferred rows (``_deferred_slot``) into the state."""
    dim, ny, nx = position.shape
    for j in range(j0, j1):
        slot = _deferred_slot(j, j0, j1, ny, halo)
        if slot >= 0:
            for c in range(dim):
                for i in range(nx):
                    position[c, j, i] = deferred_position[c, slot, i]
                    velocity[c, j, i] = deferred_velocity[c, slot, i]


@njit(parallel=True, **_JIT)
def rk4_steps_blocks(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, stage_position, stage_velocity, sum_position,
    sum_velocity, deferred_position, deferred_velocity, block_starts,
):
    """``rk4_steps`` with each row block's wavefront on one of numba's threads (``_rk4_block``).

    Work arrays per block: ``stage_*``, ``sum_*`` (blocks, dim, RK4_RING, nx), ``deferred_*``
    (blocks, dim, 8, nx).  Blocks need at least 8 rows.  Each step is one parallel sweep plus
    the copy of the deferred edge rows."""
    blocks = block_starts.size - 1
    powers = np.zeros((blocks, 4))
    sixth = dt / type(dt)(6.0)
    dissipated = 0.0
    for _ in range(n):
        for b in prange(blocks):
            _rk4_block(block_starts[b], block_starts[b + 1], dt, linear, out_of_plane, position,
                       velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot, drag,
                       gravity, stage_position[b], stage_velocity[b], sum_position[b],
                       sum_velocity[b], deferred_position[b], deferred_velocity[b], powers[b])
        for b in prange(blocks):
            _write_deferred(block_starts[b], block_starts[b + 1], RK4_HALO, position, velocity,
                            deferred_position[b], deferred_velocity[b])
        p = powers.sum(axis=0)
        dissipated += sixth * (p[0] + 2.0 * p[1] + 2.0 * p[2] + p[3])
    return dissipated


HEUN_HALO = 1
"""Rows beyond its own that a block's Heun wavefront predicts on each side."""


@njit(**_JIT)
def _heun_block(
    j0, j1, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, first_acceleration, stage_position, stage_velocity,
    deferred_position, deferred_velocity, powers,
):
    """One Heun step of rows j0 .. j1-1 as the wavefront of ``heun_steps``, the predictor also run
    on one halo row on each side (the same scheme as ``_rk4_block``).  Work arrays are this
    block's ring buffers (dim, RK4_RING, nx); ``deferred_*`` (dim, 4, nx); ``powers`` (2,)."""
    x, y, z = _components(out_of_plane, position)
    vx, vy, vz = _components(out_of_plane, velocity)
    xs, ys, zs = _components(out_of_plane, stage_position)
    vxs, vys, vzs = _components(out_of_plane, stage_velocity)
    dim, ny, nx = position.shape
    ring = stage_position.shape[1]
    vertical = np.empty((2, 2, 3, nx), position.dtype)
    horizontal = np.empty((3, nx + 1), position.dtype)
    row = np.empty((3, nx), position.dtype)
    half = type(dt)(0.5) * dt
    powers[:] = 0.0
    for t in range(max(j0 - HEUN_HALO, 0), j1 + HEUN_HALO):
        for sweep in range(2):
            j = t - sweep
            first = max(j0 - HEUN_HALO + sweep, 0)
            if j < first or j >= min(j1 + HEUN_HALO - sweep, ny):
                continue
            own = j >= j0 and j < j1
            below = vertical[sweep, j % 2]
            above = vertical[sweep, (j + 1) % 2]
            slot = j % ring
            if sweep == 0:  # predictor on (x, v)
                if j == first:
                    p = vertical_springs(j, ny, x, y, z, vx, vy, vz, linear, parameters, dashpot,
                                         below)
                    if j == 0:
                        powers[0] += p
                p = row_accelerations(j, ny, x, y, z, vx, vy, vz, inverse_mass, linear,
                                      parameters, dashpot, drag, gravity, below, above,
                                      horizontal, row, uniform_inverse_mass)
                if own:
                    powers[0] += p
                for c in range(dim):
                    for i in range(nx):
                        first_acceleration[c, slot, i] = row[c, i]
                        stage_position[c, slot, i] = position[c, j, i] + dt * velocity[c, j, i]
                        stage_velocity[c, slot, i] = velocity[c, j, i] + dt * row[c, i]
                continue
            if j == first:  # corrector on the prediction
                p = vertical_springs(j, ny, xs, ys, zs, vxs, vys, vzs, linear, parameters,
                                     dashpot, below)
                if j == 0:
                    powers[1] += p
            p = row_accelerations(j, ny, xs, ys, zs, vxs, vys, vzs, inverse_mass, linear,
                                  parameters, dashpot, drag, gravity, below, above, horizontal,
                                  row, uniform_inverse_mass)
            if own:
                powers[1] += p
            deferred = _deferred_slot(j, j0, j1, ny, HEUN_HALO)
            if deferred < 0:
                for c in range(dim):
                    for i in range(nx):
                        position[c, j, i] += half * (velocity[c, j, i] + stage_velocity[c, slot, i])
                        velocity[c, j, i] += half * (first_acceleration[c, slot, i] + row[c, i])
            else:
                for c in range(dim):
                    for i in range(nx):
                        deferred_position[c, deferred, i] = position[c, j, i] + half * (
                            velocity[c, j, i] + stage_velocity[c, slot, i]
                        )
                        deferred_velocity[c, deferred, i] = velocity[c, j, i] + half * (
                            first_acceleration[c, slot, i] + row[c, i]
                        )


@njit(parallel=True, **_JIT)
def heun_steps_blocks(
    n, dt, linear, out_of_plane, position, velocity, inverse_mass, uniform_inverse_mass,
    parameters, dashpot, drag, gravity, first_acceleration, stage_position, stage_velocity,
    deferred_position, deferred_velocity, block_starts,
):
    """``heun_steps`` with each row block's wavefront on one of numba's threads (``_heun_block``).

    Work arrays per block: ``first_acceleration``, ``stage_*`` (blocks, dim, RK4_RING, nx),
    ``deferred_*`` (blocks, dim, 4, nx).  Blocks need at least 4 rows."""
    blocks = block_starts.size - 1
    powers = np.zeros((blocks, 2))
    half = type(dt)(0.5) * dt
    dissipated = 0.0
    for _ in range(n):
        for b in prange(blocks):
            _heun_block(block_starts[b], block_starts[b + 1], dt, linear, out_of_plane, position,
                        velocity, inverse_mass, uniform_inverse_mass, parameters, dashpot, drag,
                        gravity, first_acceleration[b], stage_position[b], stage_velocity[b],
                        deferred_position[b], deferred_velocity[b], powers[b])
        for b in prange(blocks):
            _write_deferred(block_starts[b], block_starts[b + 1], HEUN_HALO, position, velocity,
                            deferred_position[b], deferred_velocity[b])
        p = powers.sum(axis=0)
        dissipated += half * (p[0] + p[1])
    return dissipated
