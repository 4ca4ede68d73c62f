"""Roughness of the equilibrium and coefficients along a fine supply sweep (the Q staircase).

Roughness of a quantity y(Q) sampled every 1 ml/min: the largest deviation from a local cubic fit
over 31 samples (Savitzky-Golay), relative to the largest |entry| of the same matrix (K or C) or to
|y| (eccentricity, attitude), ignoring the 15 samples at each end. A step of height s in the middle
of a window shows as ~0.5 s; a smooth trend, however steep, as ~0 -- so it measures the jumps and
the noise, not the trend.

One thing in the sweep is not noise: Q_T, where the groove starts to pressurize, is a change of
regime with a genuine kink in K(Q) and C(Q) (on every mesh; on 100 x 100 the slope of Kyy changes
sign within 1 ml/min), which a cubic across it cannot follow. So besides the plain figure
("K_max", "C_max") each method also reports the roughness with the fits split at Q_T
("split_at_threshold": no fit spans the kink) and outside the transition band Q_T - 5 .. Q_T + 25
ml/min ("outside_threshold_band"), where the groove pressurizes and its full-film zone spreads (on
the uniform 100-column mesh one column at a time, from ~0.7 ml/min below Q_T to ~Q_T + 25 ml/min).

Two windows. Above Q_T the groove's pressurized zone spreads, and the slope of K(Q) and C(Q) ramps
from its starved value to about 3x over ~10 ml/min (the same on 100, 200 and 400 columns). A cubic
over 31 samples cannot follow that ramp: even the 400 x 100 uniform mesh, which has no staircase
there, deviates from it. So the roughness is also measured over 15 samples (SHORT_WINDOW,
+-7 ml/min), which follows the ramp and still shows a step of height s as ~0.5 s; with the fits split
at Q_T and over the whole sweep, band included ("short_window"). Both windows on the 400 x 100 mesh:
BENCHMARKS "Smoothness in the supply flow".

One sweep of exact equilibria is computed; the coefficients of every requested method are then
evaluated at the same equilibria, so the methods are compared on identical journal positions.
"""

from __future__ import annotations

import time
from itertools import pairwise

import numpy as np
from scipy.signal import savgol_filter

from .equilibrium import flooded_threshold
from .linearize import finite_difference_coefficients
from .smoothed import DEFAULT_SMOOTHING, smoothed_coefficients
from .subcell import subcell_coefficients
from .sweep import sweep_supply
from ..units import MLMIN_PER_M3S

WINDOW = 31
SHORT_WINDOW = 15
THRESHOLD_BAND = (-5 / MLMIN_PER_M3S, 25 / MLMIN_PER_M3S)  # m^3/s around Q_T where the groove pressurizes
METHODS = ("fixed-pattern", "smoothed", "subcell")


def deviation(y: np.ndarray, scale: np.ndarray, window: int = WINDOW, breaks: np.ndarray | None = None
              ) -> np.ndarray:
    """|y - local cubic fit| / scale per sample; with `breaks` (bool, True where a new segment
    starts) no fit spans two segments. The window's first and last half-width are set to 0."""
    starts = [0] + ([] if breaks is None else list(np.flatnonzero(breaks))) + [y.size]
    out = np.zeros(y.size)
    for a, b in pairwise(starts):
        if b - a >= window:
            out[a:b] = np.abs(y[a:b] - savgol_filter(y[a:b], window, 3))
    h = window // 2
    out[:h] = out[-h:] = 0.0
    return out / scale


def roughness(y: np.ndarray, scale: np.ndarray, window: int = WINDOW) -> float:
    return float(deviation(y, scale, window).max())


def coefficient_roughness(K: np.ndarray, C: np.ndarray, breaks: np.ndarray | None = None,
                          keep: np.ndarray | None = None, window: int = WINDOW) -> dict:
    """Roughness of each entry of K and C (arrays (n, 2, 2) along the sweep) and the worst of each.

    `breaks`: see `deviation`; `keep` (bool): the samples whose deviation counts (default all);
    `window`: samples per local cubic fit."""
    k_scale = np.abs(K).reshape(-1, 4).max(axis=1)
    c_scale = np.abs(C).reshape(-1, 4).max(axis=1)
    keep = np.ones(K.shape[0], bool) if keep is None else keep
    out = {}
    names = ("xx", "xy", "yx", "yy")
    for k, n in enumerate(names):
        out[f"K{n}"] = float(deviation(K[:, k // 2, k % 2], k_scale, window, breaks)[keep].max())
        out[f"C{n}"] = float(deviation(C[:, k // 2, k % 2], c_scale, window, breaks)[keep].max())
    out["K_max"] = max(out[f"K{n}"] for n in names)
    out["C_max"] = max(out[f"C{n}"] for n in names)
    return out


def _summary(K, C, breaks, outside) -> dict:
    split = coefficient_roughness(K, C, breaks)
    band = coefficient_roughness(K, C, breaks, outside)
    short = coefficient_roughness(K, C, breaks, window=SHORT_WINDOW)
    inside = coefficient_roughness(K, C, breaks, ~outside, window=SHORT_WINDOW)
    return coefficient_roughness(K, C) | {
        "split_at_threshold": {"K_max": split["K_max"], "C_max": split["C_max"]},
        "outside_threshold_band": {"K_max": band["K_max"], "C_max": band["C_max"]},
        "short_window": {"window": SHORT_WINDOW, "K_max": short["K_max"], "C_max": short["C_max"],
                         "band_K_max": inside["K_max"], "band_C_max": inside["C_max"]},
    }


def supply_roughness(bearing, omega, load, q_min, q_max, step, progress=None, secant_amplitude=None,
                     methods=METHODS, smoothing: float = DEFAULT_SMOOTHING) -> dict:
    """Roughness (relative, see module doc) of eccentricity, attitude, K and C over q_min..q_max (m^3/s).

    `methods`: coefficient methods to measure, among "fixed-pattern" (tangent of the exact film),
    "smoothed" (tangent of the film with Eq. 6 smoothed to P (1 - theta) = `smoothing`, see
    smoothed.py) and "subcell" (the fronts placed inside the cells, subcell.py). With
    `secant_amplitude` (m) the secant coefficients over +-amplitude (central differences of
    re-solved films, velocity step amplitude * Omega) are measured too, as "secant".
    Returns {"samples", "q_threshold_mlmin", "eccentricity", "attitude", "equilibria_seconds",
    <method>: {Kxx..., K_max, C_max, split_at_threshold, outside_threshold_band, seconds}}.
    """
    flows = np.arange(q_min, q_max + 0.5 * step, step)
    kw = {} if progress is None else {"progress": progress}
    keep: list = []
    s = sweep_supply(bearing, omega, load, flows, keep=keep, coefficients="fixed-pattern", **kw)
    q_t, _ = flooded_threshold(bearing, omega, load)
    breaks = np.zeros(flows.size, bool)
    breaks[1:] = (flows[1:] >= q_t) & (flows[:-1] < q_t)
    outside = (flows < q_t + THRESHOLD_BAND[0]) | (flows > q_t + THRESHOLD_BAND[1])
    eps = s.eccentricity_ratio
    att = np.arctan2(s.position[:, 0], -s.position[:, 1])
    out = {"samples": int(flows.size), "q_threshold_mlmin": q_t * MLMIN_PER_M3S,
           "eccentricity": roughness(eps, eps), "attitude": roughness(att, att),
           "eccentricity_split_at_threshold": float(deviation(eps, eps, breaks=breaks).max()),
           "attitude_split_at_threshold": float(deviation(att, att, breaks=breaks).max()),
           "equilibria_seconds": s.seconds}
    for method in methods:
        t0 = time.perf_counter()
        if method == "fixed-pattern":
            K, C = s.K, s.C
        elif method == "smoothed":
            coefs = [smoothed_coefficients(e.film, smoothing) for e in keep]
            K, C = np.array([c.K for c in coefs]), np.array([c.C for c in coefs])
        elif method == "subcell":
            coefs = [subcell_coefficients(e.film) for e in keep]
            K, C = np.array([c.K for c in coefs]), np.array([c.C for c in coefs])
        else:
            raise ValueError(f"unknown coefficient method {method!r}; expected one of {METHODS}")
        out[method] = _summary(K, C, breaks, outside) | {"seconds": time.perf_counter() - t0}
        if method == "smoothed":
            out[method]["smoothing"] = smoothing
    if secant_amplitude is not None:
        t0 = time.perf_counter()
        fd = [finite_difference_coefficients(bearing, omega, e.position, e.feed, step=secant_amplitude,
                                             velocity_step=secant_amplitude * omega, warm=e.film) for e in keep]
        out["secant"] = (_summary(np.array([c.K for c in fd]), np.array([c.C for c in fd]), breaks, outside)
                         | {"seconds": time.perf_counter() - t0, "amplitude_m": secant_amplitude})
    return out
