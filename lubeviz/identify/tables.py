"""Coefficient tables over the supply flow (SPEC §5): each bearing's K(Q), C(Q) at a fixed load and speed.

For a given load, speed and oil a bearing's coefficients depend on its own supply flow only, so the
whole identification needs just one table per bearing: equilibria on a grid of flows spanning
`span` x Q_T (default 25-200 %), each warm-started from its neighbour, interpolated with a cubic
spline per entry (C2-smooth, so a Newton search and its finite-difference Jacobian see smooth
functions). The coefficients turn sharply at Q_T itself (the groove starts to pressurize: Kyy falls
towards Q_T and rises above it), so the grid has a node exactly at Q_T and each side gets its own
spline: one spline across the kink left a 0.75 % error in fb at any density, two bring it below a
tenth of the noise floor from ~41 points (measured, `lubeviz.identify.accuracy`). `lubeviz bench`
and the tests measure the interpolation error against direct solves.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline

from ..errors import InputError
from ..film.equilibrium import flooded_threshold
from ..film.sweep import sweep_supply
from ..model.bearing import Bearing
from ..progress import ProgressFn, silent
from ..rotor.statics import bearing_static_loads

DEFAULT_SPAN = (0.25, 2.0)
DEFAULT_POINTS = 71


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
                             f"{self.q_min * 6e7:.1f}-{self.q_max * 6e7:.1f} ml/min")
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
    """Flows of a table: denser where the coefficients change fastest (near and below Q_T).

    A grid uniform in s = sqrt(Q / Q_T), split at s = 1 so Q_T itself is a node (when inside the span),
    puts about twice as many points below Q_T as above.
    """
    lo, hi = span
    if not (0 < lo < hi and points >= 8):
        raise InputError(f"table span {span!r} and points {points!r}: expected 0 < lo < hi and >= 8 points")
    a, b = math.sqrt(lo), math.sqrt(hi)
    if not a < 1.0 < b:
        return q_threshold * np.linspace(a, b, points) ** 2
    n_below = min(max(int(round((1.0 - a) / (b - a) * (points - 1))), 3), points - 4)
    s = np.concatenate([np.linspace(a, 1.0, n_below + 1), np.linspace(1.0, b, points - n_below)[1:]])
    return q_threshold * s**2


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
    worker processes (`lubeviz.identify.cache`) call it directly. `index` only labels the table.
    """
    t0 = time.perf_counter()
    q_t, _ = flooded_threshold(bearing, omega, load)
    flows = table_flows(q_t, span, points)
    sweep = sweep_supply(bearing, omega, load, flows, progress=progress)
    return CoefficientTable(bearing=index, omega=float(omega), q_threshold=q_t, q=flows, K=sweep.K, C=sweep.C,
                            position=sweep.position, seconds=time.perf_counter() - t0)
