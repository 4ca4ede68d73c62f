"""Roughness of the equilibrium and coefficients along a fine supply sweep (the Q staircase).

Roughness of a quantity y(Q) sampled every 1 ml/min: the largest deviation from a local cubic fit
over 31 samples (Savitzky-Golay), relative to the largest |entry| of the same matrix (K or C) or to
|y| (eccentricity, attitude), ignoring the 15 samples at each end.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

from .sweep import sweep_supply


def roughness(y: np.ndarray, scale: np.ndarray, window: int = 31) -> float:
    smooth = savgol_filter(y, window, 3)
    h = window // 2
    return float(np.max(np.abs(y - smooth)[h:-h] / scale[h:-h]))


def supply_roughness(bearing, omega, load, q_min, q_max, step, progress=None) -> dict:
    """Roughness (relative, see module doc) of eccentricity, attitude, K and C over q_min..q_max (m^3/s)."""
    flows = np.arange(q_min, q_max + 0.5 * step, step)
    kw = {} if progress is None else {"progress": progress}
    s = sweep_supply(bearing, omega, load, flows, **kw)
    eps = s.eccentricity_ratio
    att = np.arctan2(s.position[:, 0], -s.position[:, 1])
    k_scale = np.abs(s.K).reshape(-1, 4).max(axis=1)
    c_scale = np.abs(s.C).reshape(-1, 4).max(axis=1)
    out = {"samples": int(flows.size), "eccentricity": roughness(eps, eps), "attitude": roughness(att, att)}
    names = ("xx", "xy", "yx", "yy")
    for k, n in enumerate(names):
        out[f"K{n}"] = roughness(s.K[:, k // 2, k % 2], k_scale)
        out[f"C{n}"] = roughness(s.C[:, k // 2, k % 2], c_scale)
    out["K_max"] = max(out[f"K{n}"] for n in names)
    out["C_max"] = max(out[f"C{n}"] for n in names)
    out["seconds"] = s.seconds
    return out
