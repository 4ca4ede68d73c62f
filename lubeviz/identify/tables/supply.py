"""Coefficient tables over the supply flow (SPEC §5): each bearing's K(Q), C(Q) at a fixed load and speed.

For a given load, speed and oil a bearing's coefficients depend on its own supply flow only, so the
whole identification needs just one table per bearing: equilibria on a grid of flows spanning
`span` x Q_T (default 10-300 %), interpolated with a cubic spline per entry (C2-smooth between kinks,
so a Newton search and its finite-difference Jacobian see smooth functions). The tables the
identification uses are views of the dimensionless tables over (S, Q / Q_T) (`dimensionless.py`,
cached by `cache.py`), on this module's grid in Q / Q_T; `build_table` / `bearing_table` solve a
table directly (tests, accuracy measurements).

The grid follows what the coefficients do (measured on the paper's bearings, 100 x 100, sub-cell K, C):
- Q_T is a change of regime (the groove starts to pressurize: Kyy turns from falling to rising), so
  Q_T is a node and each side gets its own spline: one spline across it cannot follow the kink.
- Just above Q_T the slope of K, C ramps up steeply as the groove pressurizes (BENCHMARKS "Smoothness in
  the supply flow"). On the uniform mesh the ramp came in kinks at mesh-dependent flows and a coarse
  spline rang around them. `DENSE_BAND` around Q_T gets a uniform step `DENSE_STEP`; with the groove's
  columns refined (film.mesh.refined_split) the ramp is smooth, so the step DENSE_STEP suffices there.
- Elsewhere the coefficients are smooth: a grid uniform in s = sqrt(Q / Q_T), about twice as dense
  below Q_T as above.
Measured: the current grid, BENCHMARKS "Coefficient tables: accuracy against direct solves"; the choice of
the grid, docs/notes/dimensionless-tables.md ("Ratio grid"); the kinks, the ramp's slope and the earlier
grids, docs/notes/identification-history.md.
`lubeviz bench identify --accuracy` and the tests measure the error against direct solves
(`lubeviz.identify.tables.accuracy`); `lubeviz bench table` over the whole operating range.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline

from ...errors import InputError
from ...film.equilibrium import flooded_threshold
from ...film.sweep import sweep_supply
from ...model.bearing import Bearing
from ...progress import ProgressFn, silent
from ...rotor.statics import bearing_static_loads
from ...units import MLMIN_PER_M3S

DEFAULT_SPAN = (0.1, 3.0)
# The grid is `points` nodes over BASE_BOTTOM-BASE_TOP x Q_T, the identification's box at the declared machine, and
# beyond it further nodes, where an effect takes a bearing's Q_T away from the declared one (session 55; a table
# that ended at 0.25 and 2 Q_T held the film at its end, without a word):
# - above BASE_TOP at FAR_STEP x the grid's last step in s = sqrt(Q / Q_T): an oil thicker than declared lowers
#   Q_T, and a flow of 1.8 Q_T at the declared oil is 2.2 Q_T at oil x1.27 (the fan's bearing B: K and C 6 % off at
#   2.16 Q_T, 15 % at 2.5). The film is flooded there and smooth in the supply.
# - below BASE_BOTTOM at LOW_STEP x its first step: a worn bearing's Q_T grows faster than its clearance, and a flow
#   of 0.34 Q_T at the declared clearance is 0.14 Q_T at x1.44 (the fan's bearing B: K 16 %, C 38 % off).
# The nodes over BASE_BOTTOM-BASE_TOP are those of a table over just that span.
BASE_BOTTOM, BASE_TOP = 0.25, 2.0
FAR_STEP = 3.0
LOW_STEP = 1.5
# The band where the groove pressurizes, relative to Q_T, and its step (1.1 ml/min at Q_T =
# 545 ml/min): 28 of the default points; the other 112 on the sqrt(Q) grid outside it. Chosen by
# measurement (fb, phi vs direct solves, bearing 1 at 75 Hz, all midpoints; accuracy.py; max below
# Q_T - 5 ml/min / across the band / above Q_T + 25): across the band this step is as good as a finer
# one, a coarser one over a wider band is not; fewer points than the default lose outside the band (above
# it the max sits just past it and is partly the film's own roughness). Figures:
# docs/notes/dimensionless-tables.md ("Ratio grid"). Fewer points keep the dimensionless tables' slices
# (dimensionless.py) cheap.
DENSE_BAND = (-0.005, 0.05)
DENSE_STEP = 0.002
DEFAULT_POINTS = 140


@dataclass(frozen=True)
class CoefficientTable:
    """K, C (N/m, N*s/m) and journal position (m) of one bearing at flows `q` (m^3/s), ascending."""

    bearing: int  # 0-based index in the machine
    omega: float
    q_threshold: float
    q: np.ndarray
    K: np.ndarray  # (n, 2, 2)
    C: np.ndarray  # (n, 2, 2)
    position: np.ndarray  # (n, 2)
    seconds: float = 0.0
    key: str = ""
    _splines: tuple = field(default=(), repr=False, compare=False)

    def __post_init__(self):
        if self.q.ndim != 1 or self.q.size < 4 or np.any(np.diff(self.q) <= 0):
            raise InputError("a coefficient table needs at least 4 strictly increasing flows")
        values = np.concatenate([self.K.reshape(-1, 4), self.C.reshape(-1, 4), self.position], axis=1)
        k = int(np.argmin(np.abs(self.q - self.q_threshold)))
        if abs(self.q[k] / self.q_threshold - 1) < 1e-9 and 3 <= k <= self.q.size - 4:
            splines = (CubicSpline(self.q[:k + 1], values[:k + 1], axis=0),
                       CubicSpline(self.q[k:], values[k:], axis=0))
        else:  # no node at Q_T: one spline (tables built by hand, e.g. in tests)
            splines = (CubicSpline(self.q, values, axis=0),)
        object.__setattr__(self, "_splines", splines)

    def _eval(self, q: np.ndarray, nu: int = 0) -> np.ndarray:
        if len(self._splines) == 1:
            return self._splines[0](q, nu)
        below = self._splines[0](np.minimum(q, self.q_threshold), nu)
        above = self._splines[1](np.maximum(q, self.q_threshold), nu)
        return np.where((q <= self.q_threshold)[..., None], below, above)

    @property
    def q_min(self) -> float:
        return float(self.q[0])

    @property
    def q_max(self) -> float:
        return float(self.q[-1])

    def _values(self, q):
        q = np.asarray(q, dtype=float)
        if np.any(~np.isfinite(q)) or np.any(q < self.q_min * (1 - 1e-9)) or np.any(q > self.q_max * (1 + 1e-9)):
            raise InputError(f"supply flow outside the table of bearing {self.bearing + 1}: "
                             f"{self.q_min * MLMIN_PER_M3S:.1f}-{self.q_max * MLMIN_PER_M3S:.1f} ml/min")
        return self._eval(q)

    def coefficients(self, q):
        """Interpolated (K, C) at flow(s) q (m^3/s): shapes q.shape + (2, 2)."""
        v = self._values(q)
        return v[..., 0:4].reshape(v.shape[:-1] + (2, 2)), v[..., 4:8].reshape(v.shape[:-1] + (2, 2))

    def coefficient_derivatives(self, q):
        """dK/dq, dC/dq of the spline at flow(s) q (per m^3/s)."""
        self._values(q)  # range check
        v = self._eval(np.asarray(q, dtype=float), 1)
        return v[..., 0:4].reshape(v.shape[:-1] + (2, 2)), v[..., 4:8].reshape(v.shape[:-1] + (2, 2))

    def journal_position(self, q):
        return self._values(q)[..., 8:10]

    def eccentricity_ratio(self, q, clearance: float):
        return np.hypot(*np.moveaxis(self.journal_position(q), -1, 0)) / clearance


def table_flows(q_threshold: float, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS) -> np.ndarray:
    """`points` flows (m^3/s) over the span's part within BASE_BOTTOM-BASE_TOP x Q_T: uniform steps of `DENSE_STEP`
    x Q_T across `DENSE_BAND` around Q_T (Q_T itself a node), and a grid uniform in s = sqrt(Q / Q_T) over the
    rest; a span reaching past BASE_TOP continues at FAR_STEP x the last step in s to its end, one reaching below
    BASE_BOTTOM at LOW_STEP x the first step down to its start (the span's ends are nodes).

    The dense band is used when the span holds it and it takes at most half the points; otherwise
    (coarse tables, e.g. in tests) the sqrt grid covers everything, still with a node at Q_T.
    """
    lo, hi = span
    if not (0 < lo < hi and points >= 8):
        raise InputError(f"table span {span!r} and points {points!r}: expected 0 < lo < hi and >= 8 points")
    if lo < BASE_BOTTOM < hi or lo < BASE_TOP < hi:
        base = table_flows(1.0, (max(lo, BASE_BOTTOM), min(hi, BASE_TOP)), points)
        parts = [base]
        if hi > BASE_TOP:
            parts.append(_continued(base[-2], base[-1], hi, FAR_STEP))
        if lo < BASE_BOTTOM:
            parts.insert(0, _continued(base[1], base[0], lo, LOW_STEP)[::-1])
        return q_threshold * np.concatenate(parts)
    a, b = math.sqrt(lo), math.sqrt(hi)
    if not a < 1.0 < b:
        return q_threshold * np.linspace(a, b, points) ** 2
    m_below = int(round(-DENSE_BAND[0] / DENSE_STEP))
    m_above = int(round(DENSE_BAND[1] / DENSE_STEP))
    band = 1.0 + DENSE_STEP * np.arange(-m_below, m_above + 1)
    if band.size <= points // 2 and lo < band[0] and band[-1] < hi:
        s_lo, s_hi = math.sqrt(band[0]), math.sqrt(band[-1])
        outside = points - band.size  # nodes strictly outside the band
        n_below = min(max(int(round((s_lo - a) / (s_lo - a + b - s_hi) * outside)), 1), outside - 1)
        s_below = np.linspace(a, s_lo, n_below + 1)[:-1]
        s_above = np.linspace(s_hi, b, outside - n_below + 1)[1:]
        return q_threshold * np.concatenate([s_below**2, band, s_above**2])
    n_below = min(max(int(round((1.0 - a) / (b - a) * (points - 1))), 3), points - 4)
    s = np.concatenate([np.linspace(a, 1.0, n_below + 1), np.linspace(1.0, b, points - n_below)[1:]])
    return q_threshold * s**2


def _continued(inner: float, edge: float, end: float, step: float) -> np.ndarray:
    """Nodes from the grid's `edge` (excluded) to `end` (included), uniform in sqrt, at `step` x the grid's step
    there (sqrt(edge) - sqrt(inner)) or just under it."""
    a, b = math.sqrt(inner), math.sqrt(edge)
    n = max(1, int(math.ceil((math.sqrt(end) - b) / (step * (b - a)) - 1e-9)))
    return np.linspace(b, math.sqrt(end), n + 1)[1:] ** 2


def build_table(machine, bearing: int, omega: float | None = None, *, span=DEFAULT_SPAN,
                points: int = DEFAULT_POINTS, progress: ProgressFn = silent) -> CoefficientTable:
    """Equilibria and coefficients of `machine.bearings[bearing]` over the flow span (direct solves)."""
    t0 = time.perf_counter()
    omega = 2 * math.pi * machine.operating_speed if omega is None else float(omega)
    if not 0 <= bearing < len(machine.bearings):
        raise InputError(f"bearing index {bearing}; the machine has {len(machine.bearings)} bearings")
    load = bearing_static_loads(machine)[bearing]
    table = bearing_table(machine.bearings[bearing], load, omega, index=bearing, span=span, points=points,
                          progress=progress)
    return dataclasses.replace(table, seconds=time.perf_counter() - t0)


def bearing_table(bearing: Bearing, load, omega: float, *, index: int = 0, span=DEFAULT_SPAN,
                  points: int = DEFAULT_POINTS, progress: ProgressFn = silent) -> CoefficientTable:
    """The table of one bearing under a given static `load` (N, on the journal) at `omega` (rad/s).

    What `build_table` does once the machine has given the load; needs only picklable inputs, so
    worker processes (`lubeviz.identify.tables.cache`) call it directly. `index` only labels the table.
    """
    t0 = time.perf_counter()
    q_t, _ = flooded_threshold(bearing, omega, load)
    flows = table_flows(q_t, span, points)
    sweep = sweep_supply(bearing, omega, load, flows, progress=progress)
    return CoefficientTable(bearing=index, omega=float(omega), q_threshold=q_t, q=flows, K=sweep.K, C=sweep.C,
                            position=sweep.position, seconds=time.perf_counter() - t0)
