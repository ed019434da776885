"""Where a lattice under gravity comes to rest: how far its sagged equilibrium reaches beyond its
rest positions, so that the camera fit (``app.web.view.camera_fit``) and a phone's colour bar
under the lattice (``app.web.colour_bar.bar_pose``) leave room for it."""

from __future__ import annotations

import numpy as np

from sim.model.lattice import Model
from sim.theory.modes import static_offset


def sag(model: Model) -> tuple[float, float, float, float]:
    """(left, right, down, up) metres (each >= 0) by which the lattice's equilibrium under
    gravity reaches beyond its rest positions in the plane (the linearised sag,
    ``sim.theory.modes.static_offset``, at most the lattice's own size); zeros without gravity."""
    if not model.has_gravity:
        return 0.0, 0.0, 0.0, 0.0
    try:
        offset = static_offset(model)
    except (ValueError, np.linalg.LinAlgError):  # a ModelError: no small sag to solve
        return 0.0, 0.0, 0.0, 0.0
    if not np.all(np.isfinite(offset)):
        return 0.0, 0.0, 0.0, 0.0
    size = max(model.nx, model.ny) * model.spacing
    x, y = offset[0], offset[1] if model.dim > 1 else np.zeros(1)
    return tuple(min(size, max(0.0, float(value))) for value in (
        -x.min(), x.max(), -y.min(), y.max()))
