"""Colour maps for the web view: spring strain (diverging) and scalar fields (sequential).

All functions take float arrays and return uint8 RGB arrays of shape (..., 3).
"""

from __future__ import annotations

import numpy as np

COMPRESSED = np.array([40, 110, 230], dtype=np.float32)
"""Blue: a spring shorter than its rest length."""
RELAXED = np.array([170, 170, 170], dtype=np.float32)
"""Grey: a spring at its rest length."""
STRETCHED = np.array([230, 60, 40], dtype=np.float32)
"""Red: a spring longer than its rest length."""
SELECTED = (255, 30, 30)
PARTICLE = (60, 60, 70)
ANCHOR = (120, 90, 60)


def strain_colors(strains: np.ndarray, full_scale: float = 0.05) -> np.ndarray:
    """(n,) strains -> (n, 3) uint8: blue compressed, grey relaxed, red stretched.

    ``full_scale`` is the strain magnitude shown at full colour.
    """
    amount = np.clip(np.asarray(strains, dtype=np.float32) / full_scale, -1.0, 1.0)[:, None]
    stretched = RELAXED + (STRETCHED - RELAXED) * np.maximum(amount, 0.0)
    compressed = RELAXED + (COMPRESSED - RELAXED) * np.maximum(-amount, 0.0)
    return np.where(amount >= 0, stretched, compressed).astype(np.uint8)


def _build_lookup(name: str = "inferno", size: int = 256) -> np.ndarray:
    try:
        from matplotlib import colormaps

        table = colormaps[name](np.linspace(0.0, 1.0, size))[:, :3]
    except Exception:  # matplotlib missing: a plain dark-to-yellow ramp
        ramp = np.linspace(0.0, 1.0, size)
        table = np.stack([ramp, ramp**2, 0.3 * (1 - ramp)], axis=1)
    return (table * 255).astype(np.uint8)


FIELD_LOOKUP = _build_lookup("inferno")
"""(256, 3) uint8 sequential colour table for magnitudes (dark = still, bright = moving)."""
SIGNED_LOOKUP = _build_lookup("RdBu_r")
"""(256, 3) uint8 diverging colour table for signed quantities."""


def field_colors(values: np.ndarray, full_scale: float, signed: bool = False) -> np.ndarray:
    """(n,) values -> (n, 3) uint8 through a colour table; ``full_scale`` maps to the top."""
    scale = full_scale if full_scale > 0 else 1.0
    if signed:
        fraction = 0.5 + 0.5 * np.asarray(values, dtype=np.float32) / scale
        table = SIGNED_LOOKUP
    else:
        fraction = np.abs(np.asarray(values, dtype=np.float32)) / scale
        table = FIELD_LOOKUP
    index = np.clip(fraction * (len(table) - 1), 0, len(table) - 1).astype(np.intp)
    return table[index]
