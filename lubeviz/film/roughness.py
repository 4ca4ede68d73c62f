"""Roughness of the equilibrium and coefficients along a fine supply sweep (the Q staircase).

Roughness of a quantity y(Q) sampled every 1 ml/min: the largest deviation from a local cubic fit
over 31 samples (Savitzky-Golay), relative to the largest |entry| of the same matrix (K or C) or to
|y| (eccentricity, attitude), ignoring the 15 samples at each end.

One sweep of exact equilibria is computed; the coefficients of every requested method are then
evaluated at the same equilibria, so the methods are compared on identical journal positions.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.signal import savgol_filter

from .linearize import finite_difference_coefficients
from .smoothed import DEFAULT_SMOOTHING, smoothed_coefficients
from .sweep import sweep_supply


def roughness(y: np.ndarray, scale: np.ndarray, window: int = 31) -> float:
    smooth = savgol_filter(y, window, 3)
    h = window // 2
    return float(np.max(np.abs(y - smooth)[h:-h] / scale[h:-h]))


def coefficient_roughness(K: np.ndarray, C: np.ndarray) -> dict:
    """Roughness of each entry of K and C (arrays (n, 2, 2) along the sweep) and the worst of each."""
    k_scale = np.abs(K).reshape(-1, 4).max(axis=1)
    c_scale = np.abs(C).reshape(-1, 4).max(axis=1)
    out = {}
    names = ("xx", "xy", "yx", "yy")
    for k, n in enumerate(names):
        out[f"K{n}"] = roughness(K[:, k // 2, k % 2], k_scale)
        out[f"C{n}"] = roughness(C[:, k // 2, k % 2], c_scale)
    out["K_max"] = max(out[f"K{n}"] for n in names)
    out["C_max"] = max(out[f"C{n}"] for n in names)
    return out


def supply_roughness(bearing, omega, load, q_min, q_max, step, progress=None, secant_amplitude=None,
                     methods=("fixed-pattern", "smoothed"), smoothing: float = DEFAULT_SMOOTHING) -> dict:
    """Roughness (relative, see module doc) of eccentricity, attitude, K and C over q_min..q_max (m^3/s).

    `methods`: coefficient methods to measure, among "fixed-pattern" (tangent of the exact film),
    "smoothed" (tangent of the film with Eq. 6 smoothed to P (1 - theta) = `smoothing`, see
    smoothed.py). With `secant_amplitude` (m) the secant coefficients over +-amplitude (central
    differences of re-solved films, velocity step amplitude * Omega) are measured too, as "secant":
    coefficients averaged over a vibration of that size.
    Returns {"samples", "eccentricity", "attitude", "equilibria_seconds", <method>: {Kxx..., K_max,
    C_max, seconds}}.
    """
    flows = np.arange(q_min, q_max + 0.5 * step, step)
    kw = {} if progress is None else {"progress": progress}
    keep: list = []
    s = sweep_supply(bearing, omega, load, flows, keep=keep, **kw)
    eps = s.eccentricity_ratio
    att = np.arctan2(s.position[:, 0], -s.position[:, 1])
    out = {"samples": int(flows.size), "eccentricity": roughness(eps, eps), "attitude": roughness(att, att),
           "equilibria_seconds": s.seconds}
    for method in methods:
        t0 = time.perf_counter()
        if method == "fixed-pattern":
            K, C = s.K, s.C
        elif method == "smoothed":
            coefs = [smoothed_coefficients(e.film, smoothing) for e in keep]
            K, C = np.array([c.K for c in coefs]), np.array([c.C for c in coefs])
        else:
            raise ValueError(f"unknown coefficient method {method!r}; expected 'fixed-pattern' or 'smoothed'")
        out[method] = coefficient_roughness(K, C) | {"seconds": time.perf_counter() - t0}
        if method == "smoothed":
            out[method]["smoothing"] = smoothing
    if secant_amplitude is not None:
        t0 = time.perf_counter()
        fd = [finite_difference_coefficients(bearing, omega, e.position, e.feed, step=secant_amplitude,
                                             velocity_step=secant_amplitude * omega, warm=e.film) for e in keep]
        out["secant"] = (coefficient_roughness(np.array([c.K for c in fd]), np.array([c.C for c in fd]))
                         | {"seconds": time.perf_counter() - t0, "amplitude_m": secant_amplitude})
    return out
