"""Compiled rasterising kernels of the movie renderer (numba, pure functions over arrays).

Every kernel draws into ``frame``, an (height, width, 3) uint8 RGB image, in pixel coordinates
(x to the right, y downwards, pixel centres at integer + 0.5).

* ``upscale_nearest``: a (rows, columns, 3) field image into a rectangle of the frame (nearest
  neighbour: one lattice site stays a sharp block, like the paper's pictures);
* ``draw_segments``: thick line segments (springs), each with its own colour;
* ``draw_discs``: filled discs (particles), each with its own colour and radius, in the order
  given (later ones on top: painter's order for 3-D views).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def upscale_nearest(frame: np.ndarray, image: np.ndarray, x0: int, y0: int, width: int,
                    height: int) -> None:
    """Draw ``image`` (rows, columns, 3) scaled to ``width`` x ``height`` pixels at (x0, y0)."""
    rows, columns = image.shape[0], image.shape[1]
    column_of = np.empty(width, dtype=np.int64)
    for x in range(width):
        column_of[x] = min(columns - 1, (x * columns) // width)
    for y in range(height):
        row = min(rows - 1, (y * rows) // height)
        out_row = frame[y0 + y]
        source = image[row]
        for x in range(width):
            c = column_of[x]
            out_row[x0 + x, 0] = source[c, 0]
            out_row[x0 + x, 1] = source[c, 1]
            out_row[x0 + x, 2] = source[c, 2]


@njit(cache=True, nogil=True)
def draw_segments(frame: np.ndarray, xa: np.ndarray, ya: np.ndarray, xb: np.ndarray,
                  yb: np.ndarray, colours: np.ndarray, half_width: float) -> None:
    """Segments from (xa, ya) to (xb, yb) (pixels), ``half_width`` pixels either side of the
    centre line, colours (n, 3) uint8; clipped to the frame."""
    height, width = frame.shape[0], frame.shape[1]
    for k in range(xa.shape[0]):
        ax, ay, bx, by = xa[k], ya[k], xb[k], yb[k]
        dx, dy = bx - ax, by - ay
        length_squared = dx * dx + dy * dy
        left = int(max(0.0, min(ax, bx) - half_width - 1))
        right = int(min(width - 1.0, max(ax, bx) + half_width + 1))
        top = int(max(0.0, min(ay, by) - half_width - 1))
        bottom = int(min(height - 1.0, max(ay, by) + half_width + 1))
        limit = half_width * half_width
        r, g, b = colours[k, 0], colours[k, 1], colours[k, 2]
        for y in range(top, bottom + 1):
            py = y + 0.5 - ay
            for x in range(left, right + 1):
                px = x + 0.5 - ax
                t = 0.0
                if length_squared > 0.0:
                    t = min(1.0, max(0.0, (px * dx + py * dy) / length_squared))
                ex, ey = px - t * dx, py - t * dy
                if ex * ex + ey * ey <= limit:
                    frame[y, x, 0] = r
                    frame[y, x, 1] = g
                    frame[y, x, 2] = b


@njit(cache=True, nogil=True)
def draw_discs(frame: np.ndarray, cx: np.ndarray, cy: np.ndarray, radii: np.ndarray,
               colours: np.ndarray, order: np.ndarray) -> None:
    """Filled discs at (cx, cy) (pixels) with ``radii`` (pixels) and colours (n, 3) uint8, drawn
    in ``order`` (indices); a one-pixel dark rim keeps touching discs apart."""
    height, width = frame.shape[0], frame.shape[1]
    for n in range(order.shape[0]):
        k = order[n]
        radius = radii[k]
        left = int(max(0.0, cx[k] - radius - 1))
        right = int(min(width - 1.0, cx[k] + radius + 1))
        top = int(max(0.0, cy[k] - radius - 1))
        bottom = int(min(height - 1.0, cy[k] + radius + 1))
        outer = radius * radius
        inner = max(0.0, radius - 1.0) ** 2
        for y in range(top, bottom + 1):
            py = y + 0.5 - cy[k]
            for x in range(left, right + 1):
                px = x + 0.5 - cx[k]
                distance = px * px + py * py
                if distance <= inner:
                    frame[y, x, 0] = colours[k, 0]
                    frame[y, x, 1] = colours[k, 1]
                    frame[y, x, 2] = colours[k, 2]
                elif distance <= outer:
                    frame[y, x, 0] = colours[k, 0] // 3
                    frame[y, x, 1] = colours[k, 1] // 3
                    frame[y, x, 2] = colours[k, 2] // 3


@njit(cache=True, nogil=True)
def field_to_frame(frame: np.ndarray, values: np.ndarray, rows: int, columns: int, low: float,
                   high: float, table: np.ndarray, x0: int, y0: int, width: int,
                   height: int) -> None:
    """Colour-map a lattice's per-particle ``values`` ((rows * columns,), row 0 at the bottom)
    linearly from [low, high] onto ``table`` (256, 3) uint8 (saturating) and draw it scaled to
    ``width`` x ``height`` pixels at (x0, y0), nearest neighbour, the top lattice row first."""
    factor = 255.0 / (high - low)
    colours = np.empty((rows, columns, 3), dtype=np.uint8)
    for j in range(rows):
        for i in range(columns):
            index = (values[j * columns + i] - low) * factor + 0.5
            if index < 0.0:
                index = 0.0
            elif index > 255.0:
                index = 255.0
            k = int(index)
            target = colours[rows - 1 - j, i]
            target[0] = table[k, 0]
            target[1] = table[k, 1]
            target[2] = table[k, 2]
    upscale_nearest(frame, colours, x0, y0, width, height)
