"""The compiled pass of the blow-up check's distance test: how far the farthest coordinate of a
state is from its rest value (``sim.runtime.blowup.largest_displacement``), in one pass over the
positions without the temporaries of the numpy expression (9 ms on 682x383 in float64)."""

from __future__ import annotations

from numba import njit

_JIT = dict(cache=True, nogil=True, fastmath=True, error_model="numpy")


@njit(**_JIT)
def farthest_from_rest(position, origin_x, origin_y, spacing):
    """The largest distance (m) of a coordinate of ``position`` (dim, ny, nx) from its rest
    value (particle (i, j) rests at (origin_x + i spacing, origin_y + j spacing, 0)), in one pass
    without temporaries."""
    dim, ny, nx = position.shape
    farthest = 0.0
    for j in range(ny):
        rest_y = origin_y + j * spacing
        for i in range(nx):
            farthest = max(farthest, abs(position[0, j, i] - (origin_x + i * spacing)))
            farthest = max(farthest, abs(position[1, j, i] - rest_y))
            if dim == 3:
                farthest = max(farthest, abs(position[2, j, i]))
    return farthest
