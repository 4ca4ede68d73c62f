"""Roughness of the equilibrium and coefficients along a fine supply sweep (the Q staircase).

Roughness of a quantity y(Q) sampled every 1 ml/min: the largest deviation from a local cubic fit
over 31 samples (Savitzky-Golay), relative to the largest |entry| of the same matrix (K or C) or to
|y| (eccentricity, attitude), ignoring the 15 samples at each end.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.signal import savgol_filter

from .linearize import finite_difference_coefficients
from .sweep import sweep_supply


def roughness(y: np.ndarray, scale: np.ndarray, window: int = 31) -> float:
    smooth = savgol_filter(y, window, 3)
    h = window // 2
    return float(np.max(np.abs(y - smooth)[h:-h] / scale[h:-h]))


def supply_roughness(bearing, omega, load, q_min, q_max, step, progress=None, secant_amplitude=None) -> dict:
    """Roughness (relative, see module doc) of eccentricity, attitude, K and C over q_min..q_max (m^3/s).

    With `secant_amplitude` (m) the coefficients are the secant ones over +-amplitude (central
    differences of re-solved films, velocity step amplitude * Omega) instead of the fixed-pattern
    tangent: coefficients averaged over a vibration of that size.
    """
    flows = np.arange(q_min, q_max + 0.5 * step, step)
    kw = {} if progress is None else {"progress": progress}
    keep: list = []
    s = sweep_supply(bearing, omega, load, flows, keep=keep, **kw)
    if secant_amplitude is not None:
        fd = [finite_difference_coefficients(bearing, omega, e.position, e.feed, step=secant_amplitude,
                                             velocity_step=secant_amplitude * omega, warm=e.film) for e in keep]
        s = dataclasses.replace(s, K=np.array([c.K for c in fd]), C=np.array([c.C for c in fd]))
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
