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

import numba
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

    def values(self, q, factor, clearance, load_factor, *, ratio: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """K (4), C (4) and journal position (2) per point (SI; flows clipped to each point's span, as a view
        clips), for 1-D arrays of one length; and which points the loaded slices serve (the others' rows are
        undefined: their owner makes their views, which load the slices). A compiled loop (`_values_kernel`):
        numpy's per-call overhead was most of a fit on three bearings whose loads follow the flows. `ratio`: an
        eleventh value, the flow over the point's Q_T (clipped to the slices' grid)."""
        q, f, c, lf = (np.ascontiguousarray(a, dtype=float) for a in (q, factor, clearance, load_factor))
        out = np.empty(q.shape + (11 if ratio else 10,))
        served = np.zeros(q.shape, dtype=np.bool_)
        below = self.coef[0]
        above = self.coef[1] if len(self.coef) > 1 else self.coef[0][:, :, :0, :]
        _values_kernel(q, f, c, lf, self.s0, self.c0, self.scale0, self.w0, self.omega, self.nodes, self.log_nodes,
                       self.mask, self.log_qbar, self.ratio, self.pieces[0].stop - 1 if len(self.pieces) > 1 else -1,
                       below, above, _dimensionless.SNAP_LN, out, served)
        return out, served


@numba.njit(cache=True, nogil=True)
def _values_kernel(q, f, c, lf, s0, c0, scale0, w0, omega, nodes, log_nodes, mask, log_qbar, ratio, split,
                   below, above, snap_ln, out, served):
    """`SliceStack.values` point by point (`value_at`)."""
    for p in range(q.size):
        served[p] = value_at(q[p], f[p], c[p], lf[p], s0, c0, scale0, w0, omega, nodes, log_nodes, mask, log_qbar,
                             ratio, split, below, below.shape[2], above, above.shape[2], snap_ln, out[p])


@numba.njit(cache=True, nogil=True)
def value_at(q, f, c, lf, s0, c0, scale0, w0, omega, nodes, log_nodes, mask, log_qbar, ratio, split, below, m_below,
             above, m_above, snap_ln, out) -> bool:
    """One bearing's K (4), C (4) and journal position (2) into `out` at one point (flow, viscosity factor, clearance,
    load factor), False when the loaded slices do not serve it: S from the changes, `dimensionless.stencil`'s four
    nodes (or the node alone within `snap_ln`), their Lagrange weights in ln S, Q_T, the ratio clipped to the grid,
    the spline piece below or above r = 1 (`split`: the row of r = 1, -1 for one piece; `m_below`, `m_above`: their
    pieces' counts), the combined cubic, the SI scales. The arrays may be padded past `nodes`' and `ratio`'s own
    lengths' needs (a machine's bearings packed together: `forward.shifted`)."""
    n_nodes = nodes.size
    idx = np.empty(4, np.int64)
    wt = np.empty(4)
    if not (f > 0.0 and c > 0.0 and lf > 0.0):
        return False
    s = s0 * f / lf * (c0 / c) ** 2
    if not (np.isfinite(s) and nodes[0] * (1 - 1e-12) <= s <= nodes[n_nodes - 1] * (1 + 1e-12)):
        return False
    ls = np.log(s)
    k = np.searchsorted(nodes, s, side="right") - 1
    near = min(max(k, 0), n_nodes - 1)
    if near + 1 < n_nodes and abs(log_nodes[near + 1] - ls) < abs(log_nodes[near] - ls):
        near += 1
    if abs(log_nodes[near] - ls) <= snap_ln:
        for a in range(4):
            idx[a] = near
            wt[a] = 1.0 if a == 0 else 0.0
    else:
        first = min(max(k - 1, 0), n_nodes - 4)
        for a in range(4):
            idx[a] = first + a
        for a in range(4):
            wt[a] = 1.0
            for b in range(4):
                if a != b:
                    wt[a] *= (ls - log_nodes[idx[b]]) / (log_nodes[idx[a]] - log_nodes[idx[b]])
    for a in range(4):
        if not mask[idx[a]]:
            return False
    lq = 0.0
    for a in range(4):
        lq += wt[a] * log_qbar[idx[a]]
    q_t = np.exp(lq) * scale0 * (c / c0)
    r = min(max(q / q_t, ratio[0]), ratio[ratio.size - 1])
    if out.size > 10:  # room for the flow's ratio to Q_T (clipped to the grid): the lean's correction reads it
        out[10] = r
    if split < 0 or r > 1.0:
        coef = below if split < 0 else above
        m = m_below if split < 0 else m_above
        x0 = 0 if split < 0 else split
        rr = r
    else:
        coef = below
        m = m_below
        x0 = 0
        rr = min(r, 1.0)
    i = min(max(np.searchsorted(ratio[x0:x0 + m + 1], rr, side="right") - 1, 0), m - 1)
    d = rr - ratio[x0 + i]
    wl = w0 * lf
    for v in range(10):
        c3 = 0.0
        c2 = 0.0
        c1 = 0.0
        c0v = 0.0
        for a in range(4):
            c3 += wt[a] * coef[idx[a], 0, i, v]
            c2 += wt[a] * coef[idx[a], 1, i, v]
            c1 += wt[a] * coef[idx[a], 2, i, v]
            c0v += wt[a] * coef[idx[a], 3, i, v]
        val = ((c3 * d + c2) * d + c1) * d + c0v
        if v < 4:
            val *= wl / c
        elif v < 8:
            val *= wl / (c * omega)
        else:
            val *= c
        out[v] = val
    return True


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
