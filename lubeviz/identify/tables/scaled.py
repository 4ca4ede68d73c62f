"""A bearing's view at changed viscosity, clearance or static load from the slices in memory, without fitting a spline.

An effect fit with the oil or the static loads free (a diagnosis's nuisance fits, issue 36) asks each bearing for a
new view at every evaluation and every Jacobian column: thousands per diagnosis. `dimensional_table` fits two cubic
splines over the supply ratio for each (~1 ms, 60 % of a three-bearing diagnosis's time in session 44). It need not:

- a cubic spline with not-a-knot ends is linear in its data for fixed knots, and a view's values are the Lagrange
  combination, in ln S, of its four slices' values on one ratio grid: the view's spline is the same combination of
  the slices' splines, so each slice's spline coefficients are fitted once (`ratio_coefficients`) and combined;
- the dimensional table is the dimensionless one with the ratio scaled by Q_T and each column by W/c, W/(c Omega) or c:
  an affine change of the abscissa and a scaling of the ordinate, which map a cubic spline's piecewise coefficients
  onto the dimensional spline's (`ScaledTable`).

The numbers are `dimensional_table`'s up to rounding (tests/identify/test_cache.py compares them).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline, PPoly

from ...errors import InputError
from ...model.bearing import Bearing
from . import dimensionless as _dimensionless
from .dimensionless import DimensionlessTable, Slice, sommerfeld_number
from .supply import CoefficientTable

_KEPT = 512  # slices whose spline coefficients are kept (~45 kB each)
_coefficients: OrderedDict = OrderedDict()
_lock = threading.Lock()


def _pieces(ratio: np.ndarray) -> tuple[slice, ...]:
    """The rows of each spline piece: split at r = 1 as `CoefficientTable` splits at Q_T (one piece when the grid
    has no node there with three rows either side)."""
    k = int(np.argmin(np.abs(ratio - 1.0)))
    if abs(ratio[k] - 1.0) < 1e-9 and 3 <= k <= ratio.size - 4:
        return slice(0, k + 1), slice(k, ratio.size)
    return (slice(0, ratio.size),)


def ratio_coefficients(s: Slice) -> tuple[np.ndarray, ...]:
    """The piecewise-cubic coefficients (4, m, 10) over the ratio of each of `s`'s spline pieces (kept per slice)."""
    key = id(s)
    with _lock:
        hit = _coefficients.get(key)
        if hit is not None and hit[0] is s:
            _coefficients.move_to_end(key)
            return hit[1]
    out = tuple(CubicSpline(s.ratio[p], s.values[p], axis=0).c for p in _pieces(s.ratio))
    with _lock:
        _coefficients[key] = (s, out)  # the slice itself is kept with them: its id cannot be reused meanwhile
        while len(_coefficients) > _KEPT:
            _coefficients.popitem(last=False)
    return out


@dataclass(frozen=True)
class ScaledTable(CoefficientTable):
    """A `CoefficientTable` whose splines are given (`_splines`, built by `scaled_view`), not fitted."""

    def __post_init__(self):
        if not self._splines:
            super().__post_init__()


def _stencil(table: DimensionlessTable, bearing: Bearing, load, omega: float, factor: float, clearance: float):
    """(slices, Lagrange weights, dimensional Q_T, column scales, load W) of the view at viscosity x `factor` and radial
    clearance `clearance`, or None when a slice it needs is not loaded or S is off the grid."""
    if not (float(clearance) > 0 and float(factor) > 0):
        return None
    try:
        s = sommerfeld_number(bearing, load, omega, viscosity=bearing.viscosity * float(factor), clearance=clearance)
        w = float(np.hypot(*_dimensionless._check_load(load)))
    except InputError:
        return None
    lo, hi = table.s_range
    if not lo <= s <= hi:
        return None
    idx = _dimensionless.stencil(table.nodes, s)
    if any(int(i) not in table.slices for i in idx):
        return None
    parts = [table.slices[int(i)] for i in idx]
    if any(not np.array_equal(p.ratio, parts[0].ratio) for p in parts[1:]):
        return None
    weights = _dimensionless.lagrange_weights(np.log(table.nodes[idx]), math.log(s)) if len(idx) > 1 else [1.0]
    c = float(clearance)
    q_t = math.exp(sum(wi * math.log(p.q_threshold) for wi, p in zip(weights, parts)))
    q_t *= _dimensionless.flow_scale(bearing, omega, c)
    return parts, weights, q_t, np.repeat([w / c, w / (c * omega), c], [4, 4, 2]), w


class SliceStack:
    """The spline coefficients of the slices `table` holds, stacked over its Sommerfeld nodes, for the values of one
    bearing at many (flow, viscosity factor, clearance, load factor) points at once (`values`): a fit's Jacobian
    asks for one changed bearing per column, each a view's worth of Python otherwise. Rebuilt by its owner when
    the table has loaded more slices (`covers`)."""

    def __init__(self, table: DimensionlessTable, bearing: Bearing, load, omega: float):
        self.loaded = frozenset(int(i) for i in table.slices)
        parts = {i: table.slices[i] for i in self.loaded}
        first = next(iter(parts.values()))
        self.ratio = first.ratio
        if any(not np.array_equal(p.ratio, self.ratio) for p in parts.values()):
            raise InputError("slices with different supply-ratio grids cannot be combined")
        self.nodes = np.asarray(table.nodes, dtype=float)
        self.log_nodes = np.log(self.nodes)
        self.pieces = _pieces(self.ratio)
        self.mask = np.zeros(self.nodes.size, dtype=bool)
        self.mask[list(self.loaded)] = True
        self.log_qbar = np.zeros(self.nodes.size)
        self.coef = [np.zeros((self.nodes.size, 4, rows.stop - rows.start - 1, 10)) for rows in self.pieces]
        for i, p in parts.items():
            self.log_qbar[i] = math.log(p.q_threshold)
            for j, c in enumerate(ratio_coefficients(p)):
                self.coef[j][i] = c
        load = _dimensionless._check_load(load)
        self.s0 = sommerfeld_number(bearing, load, omega)
        self.w0 = float(np.hypot(*load))
        self.c0 = float(bearing.clearance)
        self.scale0 = _dimensionless.flow_scale(bearing, omega)
        self.omega = float(omega)

    def covers(self, table: DimensionlessTable) -> bool:
        return self.loaded == frozenset(int(i) for i in table.slices)

    def _stencils(self, s: np.ndarray):
        """Node indices (n, 4) and Lagrange weights in ln S (n, 4) per point (`dimensionless.stencil`'s choice,
        the node alone with weight 1 when S is on it), and whether each point's slices are loaded."""
        n_nodes, ls = self.nodes.size, np.log(s)
        inside = (s >= self.nodes[0] * (1 - 1e-12)) & (s <= self.nodes[-1] * (1 + 1e-12))
        k = np.searchsorted(self.nodes, s, side="right") - 1
        first = np.clip(k - 1, 0, n_nodes - 4)
        idx = first[:, None] + np.arange(4)
        x = self.log_nodes[idx]
        w = np.ones(idx.shape)
        for i in range(4):
            for j in range(4):
                if i != j:
                    w[:, i] *= (ls - x[:, j]) / (x[:, i] - x[:, j])
        near = np.argmin(np.abs(self.log_nodes[None, :] - ls[:, None]), axis=1)
        snap = np.abs(self.log_nodes[near] - ls) <= _dimensionless.SNAP_LN
        idx[snap] = near[snap, None]
        w[snap] = (1.0, 0.0, 0.0, 0.0)
        return idx, w, inside & np.all(self.mask[idx], axis=1)

    def values(self, q, factor, clearance, load_factor) -> tuple[np.ndarray, np.ndarray]:
        """K (4), C (4) and journal position (2) per point (SI; flows clipped to each point's span, as a view
        clips), for 1-D arrays of one length; and which points the loaded slices serve (the others' rows are
        undefined: their owner makes their views, which load the slices)."""
        q, f, c, lf = (np.asarray(a, dtype=float) for a in (q, factor, clearance, load_factor))
        with np.errstate(all="ignore"):
            s = self.s0 * f / lf * (self.c0 / c) ** 2
            ok = np.isfinite(s) & (s > 0) & (f > 0) & (c > 0) & (lf > 0)
            s = np.where(ok, s, self.nodes[0])
        idx, w, served = self._stencils(s)
        served &= ok
        q_t = np.exp(np.sum(w * self.log_qbar[idx], axis=1)) * self.scale0 * (c / self.c0)
        r = np.clip(q / q_t, self.ratio[0], self.ratio[-1])
        out = np.empty(q.shape + (10,))
        for j, rows in enumerate(self.pieces):
            xs = self.ratio[rows]
            rr = r if len(self.pieces) == 1 else np.minimum(r, 1.0) if j == 0 else np.maximum(r, 1.0)
            i = np.clip(np.searchsorted(xs, rr, side="right") - 1, 0, xs.size - 2)
            coef = np.einsum("na,nakv->nkv", w, self.coef[j][idx, :, i[:, None], :])
            d = (rr - xs[i])[:, None]
            v = ((coef[:, 0] * d + coef[:, 1]) * d + coef[:, 2]) * d + coef[:, 3]
            take = np.ones(q.shape, dtype=bool) if len(self.pieces) == 1 else (r <= 1.0) if j == 0 else (r > 1.0)
            out[take] = v[take]
        w_load = self.w0 * lf
        column = np.stack([w_load / c] * 4 + [w_load / (c * self.omega)] * 4 + [c] * 2, axis=1)
        return out * column, served


def scaled_view(table: DimensionlessTable, bearing: Bearing, load, omega: float, factor: float, clearance: float,
                *, index: int = 0) -> CoefficientTable | None:
    """The view of `bearing` with its viscosity x `factor` and radial clearance `clearance` (m) from the slices
    `table` holds in memory (`cache.bearing_view`'s numbers, without copying the bearing, reading the slices' files,
    computing the view's key or fitting a spline), or None when a slice it needs is not loaded or S is off the grid
    (then `bearing_view` loads or builds it, or says why not). Its `key` is empty."""
    ready = _stencil(table, bearing, load, omega, factor, clearance)
    if ready is None:
        return None
    parts, weights, q_t, column, w = ready
    ratio, c = parts[0].ratio, float(clearance)
    power = q_t ** -np.arange(3, -1, -1, dtype=float)  # (r - r_i)^p = (q - q_i)^p / Q_T^p
    splines = []
    for j, rows in enumerate(_pieces(ratio)):
        coef = sum(wi * ratio_coefficients(p)[j] for wi, p in zip(weights, parts))
        splines.append(PPoly.construct_fast(coef * power[:, None, None] * column, ratio[rows] * q_t))
    v = sum(wi * p.values for wi, p in zip(weights, parts))
    return ScaledTable(bearing=index, omega=float(omega), q_threshold=q_t, q=ratio * q_t,
                       K=v[:, 0:4].reshape(-1, 2, 2) * (w / c), C=v[:, 4:8].reshape(-1, 2, 2) * (w / (c * omega)),
                       position=v[:, 8:10] * c, _splines=tuple(splines))
