"""The films of a machine on three or more supports with the loads that follow the flows, compiled.

`ForwardChain.bearing_states` evaluates every bearing, shifts the static loads by the journals' positions
(`rotor.load_shift.LoadShift`), and evaluates again, `STEPS` times, each film turned by its load's change of lean
(corrected first for what a rigid turn leaves out, `lean_corrected`: session 68).
In numpy that is ~9 small table evaluations, rotations and solves per call: ~3.7 ms, most of a fit on the fan
(session 45). Here the same steps run point by point in one compiled loop over the bearings' stacked slices
(`tables.scaled.SliceStack`, `value_at`); a point the loaded slices do not serve is reported with the bearing and
Sommerfeld number it missed, so that its owner loads those slices and runs the loop again
(`ForwardChain._compiled_states`).

A shifted load that would take a film off the tables' Sommerfeld grid is held at the grid's edge: at its top
(S 13.4) the journal sits within a few percent of the clearance from the centre and the film's K and C hardly depend
on the load any more. The fan with a fourth sleeve bearing in place of its roller support (`bench flows
--extra-bearing`, 416 N on that bearing flooded, S 8.3) sheds that load when a bearing beside it starves: at the
search box's edge the shift asked for S 106, and the identification stopped (session 45).
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict

import numba
import numpy as np

from ..tables import dimensionless as _dimensionless
from ..tables.scaled import value_at


_packed: OrderedDict = OrderedDict()
_lock = threading.Lock()
_KEPT = 32


def packed_stacks(stacks, angles, turns=None) -> "PackedStacks":
    """The `PackedStacks` of these stacks, table angles and turn errors (`forward.turn.TurnError` per bearing, or
    None), kept (a diagnosis's ~200 chains of one machine share their bearings' stacks: packing each chain's anew
    was 1.7 s of the fan's diagnosis, session 45)."""
    turns = tuple(turns) if turns is not None else (None,) * len(stacks)
    key = (tuple(id(st) for st in stacks), tuple(float(a) for a in angles), tuple(id(t) for t in turns))
    with _lock:
        hit = _packed.get(key)
        if hit is not None and all(a is b for a, b in zip(hit.stacks, stacks)) and all(
                a is b for a, b in zip(hit.turns, turns)):
            _packed.move_to_end(key)
            return hit
    packed = PackedStacks(stacks, angles, turns)  # it holds the stacks: their ids cannot be reused meanwhile
    with _lock:
        _packed[key] = packed
        while len(_packed) > _KEPT:
            _packed.popitem(last=False)
    return packed


class PackedStacks:
    """The `SliceStack`s of a machine's bearings, padded into common arrays for `states_kernel`, with each
    bearing's table angle (its film frame's lean, 0 when vertical), its turn error (`forward.turn`: the correction of
    a film whose load leans off its table's line; none: `turn_count` 0) and the stacks they were packed from."""

    def __init__(self, stacks, angles, turns=None):
        self.stacks = tuple(stacks)
        self.turns = tuple(turns) if turns is not None else (None,) * len(self.stacks)
        self.turn_ratio, self.turn_errors, self.turn_count = turn_arrays(self.turns)
        n = len(self.stacks)
        n_nodes = max(st.nodes.size for st in self.stacks)
        n_ratio = max(st.ratio.size for st in self.stacks)
        m_max = max(max(c.shape[2] for c in st.coef) for st in self.stacks)
        self.nodes = np.ones((n, n_nodes))
        self.log_nodes = np.zeros((n, n_nodes))
        self.n_nodes = np.zeros(n, np.int64)
        self.mask = np.zeros((n, n_nodes), np.bool_)
        self.log_qbar = np.zeros((n, n_nodes))
        self.ratio = np.zeros((n, n_ratio))
        self.n_ratio = np.zeros(n, np.int64)
        self.split = np.full(n, -1, np.int64)
        self.below = np.zeros((n, n_nodes, 4, m_max, 10))
        self.above = np.zeros((n, n_nodes, 4, m_max, 10))
        self.m_below = np.zeros(n, np.int64)
        self.m_above = np.zeros(n, np.int64)
        self.scalars = np.zeros((n, 5))  # s0, c0, scale0, w0, omega
        for k, st in enumerate(self.stacks):
            a, r = st.nodes.size, st.ratio.size
            self.nodes[k, :a], self.log_nodes[k, :a], self.n_nodes[k] = st.nodes, st.log_nodes, a
            self.mask[k, :a], self.log_qbar[k, :a] = st.mask, st.log_qbar
            self.ratio[k, :r], self.n_ratio[k] = st.ratio, r
            below = st.coef[0]
            self.below[k, :a, :, :below.shape[2]] = below
            self.m_below[k] = below.shape[2]
            if len(st.coef) > 1:
                above = st.coef[1]
                self.above[k, :a, :, :above.shape[2]] = above
                self.m_above[k] = above.shape[2]
                self.split[k] = st.pieces[0].stop - 1
            self.scalars[k] = (st.s0, st.c0, st.scale0, st.w0, st.omega)
        self.angles = np.asarray(angles, dtype=float)


def turn_arrays(turns):
    """Each bearing's turn error (`forward.turn.TurnError`, or None) padded into the kernel's arrays: the flows'
    ratios (N, R), the errors at the measured leans (N, R, 4, 10) and each bearing's count of ratios (0: none)."""
    from .turn import TURN_LEANS_DEG

    n = len(turns)
    r = max([t.ratio.size for t in turns if t is not None], default=2)
    ratio, errors = np.ones((n, r)), np.zeros((n, r, len(TURN_LEANS_DEG), 10))
    count = np.zeros(n, np.int64)
    for k, t in enumerate(turns):
        if t is not None:
            m = t.ratio.size
            ratio[k, :m], errors[k, :m], count[k] = t.ratio, t.errors, m
    return ratio, errors, count


# The largest lean the correction follows (rad): past it the film is the correction's at this lean, turned further
# rigidly (the budget says a fit there is not to be trusted, `budget.TURN_SAID_DEG`)
LEAN_LIMIT = math.radians(20.0)
# The leans the errors are measured at (`forward.turn.TURN_LEANS_DEG`: -outer, -inner, +inner, +outer), in radians
_INNER, _OUTER = math.radians(3.0), math.radians(8.0)


@numba.njit(cache=True, nogil=True)
def _at_lean(e, a):
    """The error at lean `a` from the measured ones `e` (4: at -8, -3, 3, 8 deg): zero at none, linear between the
    measured leans, and past the outer ones on the slope between the last two."""
    if a >= 0.0:
        inner, outer = e[2], e[3]
    else:
        inner, outer = e[1], e[0]
        a = -a
    if a <= _INNER:
        return inner * a / _INNER
    return inner + (outer - inner) * (a - _INNER) / (_OUTER - _INNER)


@numba.njit(cache=True, nogil=True)
def lean_corrected(v, lean, clearance, ratio, errors, count):
    """The table's ten values `v` (in its frame; `v[10]`: the flow over Q_T) of a film whose load leans `lean` (rad)
    off the table's line, corrected in place for what the rigid turn leaves out (`forward.turn.TurnError`: its errors
    at the measured leans, `_at_lean`, between its measured flows, held at their ends; K's and C's parts scaled by
    their own Frobenius norms, the position's by the clearance)."""
    if count < 2 or lean == 0.0:
        return
    a = min(max(lean, -LEAN_LIMIT), LEAN_LIMIT)
    r = v[10]
    if r <= ratio[0]:
        j, w = 0, 0.0
    elif r >= ratio[count - 1]:
        j, w = count - 2, 1.0
    else:
        j = min(max(np.searchsorted(ratio[:count], r, side="right") - 1, 0), count - 2)
        w = (r - ratio[j]) / (ratio[j + 1] - ratio[j])
    nk = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3])
    nc = math.sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7])
    e = np.empty(4)
    for i in range(10):
        for m in range(4):
            e[m] = (1.0 - w) * errors[j, m, i] + w * errors[j + 1, m, i]
        v[i] += (nk if i < 4 else (nc if i < 8 else clearance)) * _at_lean(e, a)


@numba.njit(cache=True, nogil=True)
def lean_corrected_rows(rows, lean, clearance, ratio, errors, count):
    """`lean_corrected` for each row of `rows` (M, 11) with its own lean and clearance (M,)."""
    for p in range(rows.shape[0]):
        lean_corrected(rows[p], lean[p], clearance[p], ratio, errors, count)


def shifted_states(packed: PackedStacks, q, f, c, lf, k_s, reference, loads, steps: int, target=None):
    """K (M, N, 4), C (M, N, 4), positions (M, N, 2) in the machine's frame, each bearing's load factor over the
    flooded load (M, N), the loads (M, N, 2), which points were served (M,) and, for the others, the bearing and
    the Sommerfeld number whose slices were missing (M, 2; NaN when served), for M points of N flows (m^3/s),
    viscosity factors, clearances and load factors (each (M, N)): `LoadShift.shifted` `steps` times from the
    flooded `loads` (N, 2), the journals' flooded positions `reference` (N, 2; or (M, N, 2), each point's: a moved
    bearing's flooded place less its move) and the shaft's condensed stiffness `k_s` (2N, 2N). `target` (M, N, 2): the
    loads the films would carry held where the flooded statics put them (default `loads`; an effect's static load
    change added, `Effect.static_load_change`): the equilibrium W - target + K_s (p(W) - p0) = 0."""
    q, f, c, lf = (np.ascontiguousarray(a, dtype=float) for a in (q, f, c, lf))
    m, n = q.shape
    ref = np.empty((m, n, 2))  # every point's (numpy's broadcast_to costs ~7 us a call)
    ref[:] = reference
    out = np.empty((m, n, 10))
    factors = np.empty((m, n))
    loads_out = np.empty((m, n, 2))
    served = np.zeros(m, np.bool_)
    missed = np.full((m, 2), np.nan)  # (bearing, S) of the evaluation a point was not served at
    loads = np.ascontiguousarray(loads, dtype=float)
    held = np.empty((m, n, 2))
    held[:] = loads if target is None else target
    lean0 = np.arctan2(loads[:, 0], -loads[:, 1])
    states_kernel(q, f, c, lf, packed.nodes, packed.log_nodes, packed.n_nodes, packed.mask, packed.log_qbar,
                  packed.ratio, packed.n_ratio, packed.split, packed.below, packed.m_below, packed.above,
                  packed.m_above, packed.scalars, packed.angles, _dimensionless.SNAP_LN,
                  np.ascontiguousarray(k_s, dtype=float), ref, loads, held, lean0,
                  int(steps), packed.turn_ratio, packed.turn_errors, packed.turn_count, out,
                  factors, loads_out, served, missed)
    return out, factors, loads_out, served, missed


@numba.njit(cache=True, nogil=True)
def _turn(v, angle, out):
    """K, C (row-major 2 x 2) and position of `v` turned by `angle` about the bearing's centre, into `out`."""
    co, si = math.cos(angle), math.sin(angle)
    for b in (0, 4):
        k00, k01, k10, k11 = v[b], v[b + 1], v[b + 2], v[b + 3]
        # R K R^T, R = [[co, -si], [si, co]]
        a00, a01 = co * k00 - si * k10, co * k01 - si * k11
        a10, a11 = si * k00 + co * k10, si * k01 + co * k11
        out[b] = a00 * co - a01 * si
        out[b + 1] = a00 * si + a01 * co
        out[b + 2] = a10 * co - a11 * si
        out[b + 3] = a10 * si + a11 * co
    x, y = v[8], v[9]
    out[8] = co * x - si * y
    out[9] = si * x + co * y


@numba.njit(cache=True, nogil=True)
def _bearing(k, q, f, c, lf, nodes, log_nodes, n_nodes, mask, log_qbar, ratio, n_ratio, split, below, m_below, above,
             m_above, scalars, snap_ln, v) -> bool:
    a, r = n_nodes[k], n_ratio[k]
    return value_at(q, f, c, lf, scalars[k, 0], scalars[k, 1], scalars[k, 2], scalars[k, 3], scalars[k, 4],
                    nodes[k, :a], log_nodes[k, :a], mask[k, :a], log_qbar[k, :a], ratio[k, :r], split[k], below[k],
                    m_below[k], above[k], m_above[k], snap_ln, v)


@numba.njit(cache=True, nogil=True)
def _sommerfeld(k, f, c, lf, scalars):
    """S of bearing k at a viscosity factor, clearance and load factor (`value_at`'s)."""
    if not (f > 0.0 and c > 0.0 and lf > 0.0):
        return np.nan
    return scalars[k, 0] * f / lf * (scalars[k, 1] / c) ** 2


@numba.njit(cache=True, nogil=True)
def _within_grid(k, f, c, lf, factor, scalars, nodes, n_nodes):
    """The shifted load's factor with the film's Sommerfeld number kept on the tables' grid (`within_grid`)."""
    if not (f > 0.0 and c > 0.0 and lf > 0.0 and factor > 0.0):
        return factor
    s = scalars[k, 0] * f / (lf * factor) * (scalars[k, 1] / c) ** 2
    top, bottom = nodes[k, n_nodes[k] - 1] * (1.0 - 1e-9), nodes[k, 0] * (1.0 + 1e-9)
    if s > top:
        return factor * s / top
    if s < bottom:
        return factor * s / bottom
    return factor


@numba.njit(cache=True, nogil=True)
def states_kernel(q, f, c, lf, nodes, log_nodes, n_nodes, mask, log_qbar, ratio, n_ratio, split, below, m_below,
                  above, m_above, scalars, angles, snap_ln, k_s, reference, loads, target, lean0, steps, turn_ratio,
                  turn_errors, turn_count, out, factors, loads_out, served, missed):
    """`shifted_states` point by point."""
    m, n = q.shape
    v = np.empty(11)
    a = np.empty((2 * n, 2 * n))
    rhs = np.empty(2 * n)
    w = np.empty((n, 2))
    for p in range(m):
        ok = True
        for k in range(n):
            if not _bearing(k, q[p, k], f[p, k], c[p, k], lf[p, k], nodes, log_nodes, n_nodes, mask, log_qbar, ratio,
                            n_ratio, split, below, m_below, above, m_above, scalars, snap_ln, v):
                ok = False
                missed[p, 0] = k
                missed[p, 1] = _sommerfeld(k, f[p, k], c[p, k], lf[p, k], scalars)
                break
            _turn(v, angles[k], out[p, k])
        if not ok:
            continue
        for k in range(n):
            w[k, 0] = loads[k, 0]
            w[k, 1] = loads[k, 1]
            factors[p, k] = 1.0
        for step in range(steps):
            # (I + K_s K_f^-1) dW = -(K_s dp + W - W0), W0 the target
            for i in range(2 * n):
                for j in range(2 * n):
                    a[i, j] = 1.0 if i == j else 0.0
            for k in range(n):
                k00, k01, k10, k11 = out[p, k, 0], out[p, k, 1], out[p, k, 2], out[p, k, 3]
                det = k00 * k11 - k01 * k10
                i00, i01, i10, i11 = k11 / det, -k01 / det, -k10 / det, k00 / det
                for i in range(2 * n):
                    s0, s1 = k_s[i, 2 * k], k_s[i, 2 * k + 1]
                    a[i, 2 * k] += s0 * i00 + s1 * i10
                    a[i, 2 * k + 1] += s0 * i01 + s1 * i11
            for i in range(2 * n):
                acc = w[i // 2, i % 2] - target[p, i // 2, i % 2]
                for k in range(n):
                    acc += k_s[i, 2 * k] * (out[p, k, 8] - reference[p, k, 0])
                    acc += k_s[i, 2 * k + 1] * (out[p, k, 9] - reference[p, k, 1])
                rhs[i] = -acc
            dw = np.linalg.solve(a, rhs)
            for k in range(n):
                w[k, 0] += dw[2 * k]
                w[k, 1] += dw[2 * k + 1]
            for k in range(n):
                w0 = math.hypot(loads[k, 0], loads[k, 1])
                factors[p, k] = _within_grid(k, f[p, k], c[p, k], lf[p, k], math.hypot(w[k, 0], w[k, 1]) / w0,
                                             scalars, nodes, n_nodes)
                lean = math.atan2(w[k, 0], -w[k, 1]) - lean0[k]
                lean = (lean + math.pi) % (2.0 * math.pi) - math.pi
                if not _bearing(k, q[p, k], f[p, k], c[p, k], lf[p, k] * factors[p, k], nodes, log_nodes, n_nodes,
                                mask, log_qbar, ratio, n_ratio, split, below, m_below, above, m_above, scalars,
                                snap_ln, v):
                    ok = False
                    missed[p, 0] = k
                    missed[p, 1] = _sommerfeld(k, f[p, k], c[p, k], lf[p, k] * factors[p, k], scalars)
                    break
                lean_corrected(v, lean, c[p, k], turn_ratio[k], turn_errors[k], turn_count[k])
                _turn(v, angles[k] + lean, out[p, k])
            if not ok:
                break
        if ok:
            for k in range(n):
                loads_out[p, k, 0] = w[k, 0]
                loads_out[p, k, 1] = w[k, 1]
            served[p] = True
