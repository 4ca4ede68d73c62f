"""Dimensionless coefficient tables over (Sommerfeld number S, supply ratio r = Q / Q_T): one per geometry.

Why: a film of a given shape (L/D, the groove's place and size relative to R and L, the mesh) has
equilibrium position, stiffness and damping that depend on the operating point only through two
numbers (Reynolds' equation is linear in the pressure scale mu*Omega*(R/c)^2, and the p-theta
complementarity, Eq. 6, is scale-free):
- the Sommerfeld number S = mu * N * L * D / W * (R / c)^2 (N = Omega / 2 pi in rev/s, W = |load|), and
- the dimensionless supply qbar = Q / (Omega * R * c * L) (Eq. 4's source over the Couette flow scale),
in the dimensionless values
    eps = e / c,   Kbar = K * c / W,   Cbar = C * c * Omega / W.
So a viscosity, clearance, speed or load change moves a bearing along S and along qbar, and costs
no film solve once the table holds that S. The supply axis is r = qbar / qbar_T(S), qbar_T the
flooded threshold (SPEC §2's Q_T made dimensionless), so Q_T's kink stays on the node line r = 1
for every S (tables.py explains why each side of Q_T gets its own spline).

A slice is one S: qbar_T(S) and the ten values on the r grid (`tables.table_flows` with Q_T = 1),
solved by `sweep_supply` on a reference bearing (the bearing's own geometry with `REF_VISCOSITY`,
`REF_CLEARANCE_RATIO` * R, speed `REF_OMEGA` and the load that gives S), warm-started along r, in
two parts (r <= 1 and r > 1) that two processes can solve at once.
Slices sit on a grid in ln S (`sommerfeld_nodes`, finer at low S where the film is stiff and the
values curve fastest), and a query interpolates the 4 nearest slices with a cubic Lagrange
polynomial in ln S; since the r-spline of a weighted sum of slices is the weighted sum of their
r-splines (same knots, same end conditions), a dimensional view of the table is simply a
`CoefficientTable` over the weighted node values. qbar_T is interpolated in ln qbar_T.

The on-disk cache of slices and the parallel build live in `cache.py`; this module is the arithmetic.
"""

from __future__ import annotations

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
from .supply import DEFAULT_POINTS, DEFAULT_SPAN, CoefficientTable, table_flows

# The reference operating point a slice is solved at (any values give the same dimensionless numbers;
# fixed so a slice file does not depend on which bearing asked for it first).
REF_VISCOSITY = 0.1  # Pa*s
REF_CLEARANCE_RATIO = 2.5e-3  # c / R
REF_OMEGA = 2.0 * math.pi * 50.0  # rad/s

# The ln S grid (see `sommerfeld_nodes`): steps of `COARSE_STEP` from the anchor S_ANCHOR, down to
# about `FINE_BELOW`, then `FINE_STEP` below it, over S_RANGE. Chosen by measurement (slices every
# 0.0375 in ln S, the cubic through every 2nd/4th/8th one checked at the others, error in K relative to
# max|K| over r = 0.25-2; docs/notes/dimensionless-tables.md, "ln S step"): above S ~ 0.1 the error is
# small except at r > 1.5, where the film's own roughness in S (cells switching) dominates and halving
# H gains far less than the cubic's 16x; below S ~ 0.1 (eps > 0.75) the cubic's error is spread over all r
# and a finer step pays. Hence the coarse step above FINE_BELOW and the fine one below. The accuracy this
# gives over the range: BENCHMARKS.md, "Dimensionless tables".
COARSE_STEP = 0.15
FINE_STEP = 0.075
FINE_BELOW = 0.12
S_RANGE = (0.0255, 12.6)  # covers viscosity x0.5-2, clearance x0.8-1.5, 5-150 Hz on the paper's machine
# The grid is anchored at the paper machine's operating point (75 Hz, S = 1.90843 and 1.90837 for its
# two bearings), and a query within SNAP_LN of a node in ln S is served by that slice alone: the other
# three slices of the cubic would change it by about SNAP_LN * |dv / d ln S|, and |dv / d ln S| <=
# 1.0 x max|v| for K and C, 0.26 for eps (measured over the whole range), so by <= 5e-5 relative, less
# than the spline's error in r. So a cold start at the nominal point solves one slice, not four.
S_ANCHOR = 1.9084
SNAP_LN = 5e-5
# A slice's equilibria balance the load to SLICE_TOL (relative; find_equilibrium's default is 1e-9).
# Measured at S = 0.05 / 1.91 / 8.0: the values move by <= 4e-7 of their column's max (the table's own
# error against direct solves: median 4e-5, max 9e-4), and 125 of 141 equilibria take one Newton step
# instead of two (39 at 1e-9; the sweep's predicted start is ~4e-5 c off: the position is rough at that
# level as cells switch, so a better predictor does not help).
SLICE_TOL = 1e-7

_NAMES = ("Kxx", "Kxy", "Kyx", "Kyy", "Cxx", "Cxy", "Cyx", "Cyy", "eps_x", "eps_y")


def sommerfeld_nodes(s_range=S_RANGE, coarse: float = COARSE_STEP, fine: float = FINE_STEP,
                     fine_below: float = FINE_BELOW, anchor: float = S_ANCHOR) -> np.ndarray:
    """The S values of the slices, ascending: ln S = ln anchor + k * coarse down to the node nearest
    `fine_below`, and below that steps of `fine`; a node at or beyond each end of `s_range`."""
    lo, hi = (math.log(float(v) / anchor) for v in s_range)
    if not (lo < hi and coarse > 0 and fine > 0):
        raise InputError(f"Sommerfeld range {s_range!r} and steps {coarse!r}, {fine!r}: expected lo < hi, steps > 0")
    split = math.log(fine_below / anchor)
    k_split = round(split / coarse)
    split = k_split * coarse  # fine grid starts on a coarse node
    top = max(math.ceil(hi / coarse), k_split)
    up = np.arange(k_split, top + 1) * coarse
    up = up[up >= min(split, lo)]
    if lo < split:
        j = math.ceil((split - lo) / fine)
        down = split - np.arange(j, 0, -1) * fine
        ln_s = np.concatenate([down, up])
    else:
        k_lo = math.floor(lo / coarse)
        ln_s = np.arange(k_lo, top + 1) * coarse
    # One node at a time through the C library's exp, not numpy's: numpy's vectorized exp takes another code path on
    # another CPU, and on an AMD EPYC (session 66) two of the 54 nodes came out one ulp off, and a slice is keyed
    # by its node's value (every slice at those nodes was solved again on a fresh clone there).
    return np.array([anchor * math.exp(float(v)) for v in ln_s])


def sommerfeld_number(bearing: Bearing, load, omega: float, *, viscosity: float | None = None,
                      clearance: float | None = None) -> float:
    """S = mu * N * L * D / W * (R / c)^2, N = Omega / 2 pi (rev/s), W = |load| (SPEC §7); `viscosity` and
    `clearance` (Pa s, m) instead of the bearing's."""
    w = float(np.hypot(*np.asarray(load, dtype=float)))
    if not (math.isfinite(w) and w > 0.0):
        raise InputError(f"bearing load {load!r}: expected a non-zero finite load (N)")
    n = omega / (2.0 * math.pi)
    mu = bearing.viscosity if viscosity is None else viscosity
    c = bearing.clearance if clearance is None else clearance
    return mu * n * bearing.length * bearing.diameter / w * (bearing.radius / c) ** 2


def flow_scale(bearing: Bearing, omega: float, clearance: float | None = None) -> float:
    """Omega * R * c * L (m^3/s): qbar = Q / flow_scale; `clearance` (m) instead of the bearing's."""
    return omega * bearing.radius * (bearing.clearance if clearance is None else clearance) * bearing.length


def geometry_values(bearing: Bearing) -> dict:
    """What decides a dimensionless table (its cache key): the shape of the film, not its scale.

    radius and length, the groove's angle, its circumferential length over R and its axial width
    over L, and the mesh; every further groove the same way (`other_grooves`: [angle, length / R, width / L]
    each, only when there are any, so a one-groove bearing's key is what it always was). Not: viscosity and
    clearance (they only move S and qbar), the rotor node and the display name."""
    out = {"radius": float(bearing.radius), "length": float(bearing.length),
           "groove_angle": float(bearing.groove_angle),
           "groove_length_over_radius": float(bearing.groove_length / bearing.radius),
           "groove_width_over_length": float(bearing.groove_width / bearing.length),
           "n_circumferential": int(bearing.n_circumferential), "n_axial": int(bearing.n_axial),
           "groove_refinement": int(bearing.groove_refinement)}
    others = getattr(bearing, "other_grooves", None) or ()
    if others:
        out["other_grooves"] = [[float(g.angle), float(g.length / bearing.radius), float(g.width / bearing.length)]
                                for g in others]
    return out


def reference_bearing(geometry: dict) -> Bearing:
    """The bearing a slice is solved on: the geometry with the reference oil and clearance."""
    from ...model.bearing import Groove

    r, length = geometry["radius"], geometry["length"]
    others = [Groove(a, lr * r, wl * length) for a, lr, wl in geometry.get("other_grooves", ())]
    return Bearing(radius=r, length=length, clearance=REF_CLEARANCE_RATIO * r, viscosity=REF_VISCOSITY,
                   groove_angle=geometry["groove_angle"], groove_length=geometry["groove_length_over_radius"] * r,
                   groove_width=geometry["groove_width_over_length"] * length,
                   n_circumferential=geometry["n_circumferential"], n_axial=geometry["n_axial"],
                   groove_refinement=geometry["groove_refinement"], other_grooves=others)


def _check_load(load) -> np.ndarray:
    load = np.asarray(load, dtype=float)
    if load.shape != (2,) or not np.all(np.isfinite(load)):
        raise InputError(f"bearing load {load!r}: expected two finite numbers [Wx, Wy] (N)")
    w = float(np.hypot(*load))
    # The film is not rotation-invariant (the groove has a place), so the tables hold loads along -Y only.
    if not (w > 0.0 and load[1] < 0.0 and abs(load[0]) <= 1e-9 * w):
        raise InputError(f"bearing load {load.tolist()} N: the dimensionless tables hold vertical loads "
                         "(along -Y, gravity) only")
    return load


@dataclass(frozen=True)
class Slice:
    """One Sommerfeld number: qbar_T and, at each supply ratio r, Kbar (4), Cbar (4), eps (2) in `values`."""

    sommerfeld: float
    q_threshold: float  # qbar_T = Q_T / (Omega R c L)
    ratio: np.ndarray  # r = qbar / qbar_T, ascending, with a node at 1
    values: np.ndarray  # (n, 10): Kxx Kxy Kyx Kyy (x c/W), Cxx Cxy Cyx Cyy (x c Omega/W), eps_x, eps_y
    seconds: float = 0.0

    def __post_init__(self):
        n = self.ratio.shape[0] if self.ratio.ndim == 1 else -1
        if n < 4 or self.values.shape != (n, 10):
            raise InputError(f"slice at S = {self.sommerfeld:g}: ratio {self.ratio.shape} and values "
                             f"{self.values.shape} do not match (expected (n,) and (n, 10))")


def ratio_grid(span=DEFAULT_SPAN, points: int = DEFAULT_POINTS) -> np.ndarray:
    """The supply ratios of a slice: `tables.table_flows` for Q_T = 1 (node at r = 1, dense just around it)."""
    return table_flows(1.0, span, points)


PARTS = ("below", "above")


def _reference_point(geometry: dict, sommerfeld: float):
    b = reference_bearing(geometry)
    omega = REF_OMEGA
    w = b.viscosity * omega / (2.0 * math.pi) * b.length * b.diameter / sommerfeld * (b.radius / b.clearance) ** 2
    return b, omega, np.array([0.0, -w]), w


def slice_threshold(geometry: dict, sommerfeld: float):
    """The slice's flooded equilibrium on the reference bearing: (Q_T in m^3/s, the Equilibrium)."""
    b, omega, load, _w = _reference_point(geometry, sommerfeld)
    return flooded_threshold(b, omega, load)


def build_slice_part(geometry: dict, sommerfeld: float, part: str, *, span=DEFAULT_SPAN,
                     points: int = DEFAULT_POINTS, progress: ProgressFn = silent, threshold=None) -> dict:
    """Half a slice, so two processes can share one: Q_T, then the sweep over the ratios <= 1
    ("below", from the lowest up, each warm-started from the last) or > 1 ("above": from r = 1 up, started
    at the flooded equilibrium, which is the film at Q = Q_T; its solve at r = 1 only starts the sweep and is
    not kept). `threshold`: `slice_threshold`'s result when the caller has it (the same deterministic
    computation, so a slice does not depend on who solved it). Returns plain arrays (`join_slice`)."""
    if part not in PARTS:
        raise InputError(f"slice part {part!r}; expected one of {PARTS}")
    t0 = time.perf_counter()
    b, omega, load, w = _reference_point(geometry, sommerfeld)
    q_t, flooded = slice_threshold(geometry, sommerfeld) if threshold is None else threshold
    ratio = ratio_grid(span, points)
    k = int(np.argmin(np.abs(ratio - 1.0)))
    if abs(ratio[k] - 1.0) > 1e-12:  # no node at Q_T (a span that does not hold it): one part holds all
        k = ratio.size - 1
    sel = ratio[:k + 1] if part == "below" else ratio[k:]
    skip = 0 if part == "below" else 1
    if sel.size <= skip:
        return {"q_threshold": q_t / flow_scale(b, omega), "values": np.empty((0, 10)), "seconds": 0.0}

    def report(done, total, label=""):
        if done > skip:
            progress(done - skip, sel.size - skip, f"Q/Q_T = {sel[done - 1]:.3f}")

    sweep = sweep_supply(b, omega, load, sel * q_t, progress=report, tol=SLICE_TOL,
                         start=flooded if part == "above" else None)
    c = b.clearance
    values = np.concatenate([sweep.K.reshape(-1, 4) * (c / w), sweep.C.reshape(-1, 4) * (c * omega / w),
                             sweep.position / c], axis=1)
    return {"q_threshold": q_t / flow_scale(b, omega), "values": values[skip:],
            "seconds": time.perf_counter() - t0}


def join_slice(sommerfeld: float, below: dict, above: dict, *, span=DEFAULT_SPAN,
               points: int = DEFAULT_POINTS) -> Slice:
    """The slice from its two parts (`build_slice_part`)."""
    if below["q_threshold"] != above["q_threshold"]:
        raise InputError(f"slice parts at S = {sommerfeld:g} disagree on Q_T")
    return Slice(sommerfeld=float(sommerfeld), q_threshold=float(below["q_threshold"]),
                 ratio=ratio_grid(span, points), values=np.concatenate([below["values"], above["values"]]),
                 seconds=float(below["seconds"] + above["seconds"]))


def build_slice(geometry: dict, sommerfeld: float, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS,
                progress: ProgressFn = silent) -> Slice:
    """Solve one slice on the reference bearing at load W(S): its two parts one after the other (the
    same computation the parallel build runs in two processes, so both give identical slices)."""
    threshold = slice_threshold(geometry, sommerfeld)  # once for both parts
    below = build_slice_part(geometry, sommerfeld, "below", span=span, points=points, progress=progress,
                             threshold=threshold)
    n = below["values"].shape[0]
    above = build_slice_part(geometry, sommerfeld, "above", span=span, points=points, threshold=threshold,
                             progress=lambda done, total, label="": progress(n + done, n + total, label))
    return join_slice(sommerfeld, below, above, span=span, points=points)


def lagrange_weights(nodes: np.ndarray, x: float) -> np.ndarray:
    """Weights w_i with sum_i w_i f(nodes_i) = the polynomial through the nodes, at x."""
    w = np.ones(nodes.size)
    for i in range(nodes.size):
        for j in range(nodes.size):
            if i != j:
                w[i] *= (x - nodes[j]) / (nodes[i] - nodes[j])
    return w


def stencil(nodes: np.ndarray, sommerfeld: float, order: int = 4) -> np.ndarray:
    """Indices of the `order` nodes around S (the two on each side when there are, one-sided at the ends);
    the node alone when S is within SNAP_LN of it."""
    lo, hi = float(nodes[0]), float(nodes[-1])
    if not (math.isfinite(sommerfeld) and lo * (1 - 1e-12) <= sommerfeld <= hi * (1 + 1e-12)):
        raise InputError(f"Sommerfeld number {sommerfeld:.4g} outside the dimensionless table's range "
                         f"{lo:.4g}-{hi:.4g} (viscosity, clearance, speed or load out of range)")
    near = int(np.argmin(np.abs(np.log(nodes / sommerfeld))))
    if abs(math.log(nodes[near] / sommerfeld)) <= SNAP_LN:
        return np.array([near])  # on a node (see SNAP_LN)
    k = int(np.searchsorted(nodes, sommerfeld, side="right")) - 1  # nodes[k] <= S < nodes[k+1]
    first = min(max(k - order // 2 + 1, 0), nodes.size - order)
    return np.arange(first, first + order)


@dataclass(frozen=True)
class Combination:
    """The dimensionless values at one S: qbar_T and the node values on the r grid (weighted slices)."""

    sommerfeld: float
    q_threshold: float
    ratio: np.ndarray
    values: np.ndarray  # (n, 10)
    indices: tuple[int, ...]


def combine(nodes: np.ndarray, slices: dict, sommerfeld: float) -> Combination:
    """Cubic Lagrange interpolation in ln S of the 4 slices around S (`slices`: node index -> Slice);
    one slice when S is on a node."""
    idx = stencil(nodes, sommerfeld)
    missing = [int(i) for i in idx if int(i) not in slices]
    if missing:
        raise InputError(f"slices {missing} needed at S = {sommerfeld:.4g} are not loaded")
    w = lagrange_weights(np.log(nodes[idx]), math.log(sommerfeld))
    parts = [slices[int(i)] for i in idx]
    ratio = parts[0].ratio
    if any(p.ratio.shape != ratio.shape or not np.array_equal(p.ratio, ratio) for p in parts):
        raise InputError("slices with different supply-ratio grids cannot be combined")
    values = sum(wi * p.values for wi, p in zip(w, parts))
    q_t = math.exp(sum(wi * math.log(p.q_threshold) for wi, p in zip(w, parts)))
    return Combination(sommerfeld=float(sommerfeld), q_threshold=q_t, ratio=ratio, values=values,
                       indices=tuple(int(i) for i in idx))


def dimensional_table(combo: Combination, bearing: Bearing, load, omega: float, *, index: int = 0,
                      key: str = "", seconds: float = 0.0, clearance: float | None = None) -> CoefficientTable:
    """The `CoefficientTable` (SI) of `bearing` under `load` at `omega` from the dimensionless values;
    `clearance` (m) instead of the bearing's."""
    load = _check_load(load)
    w = float(np.hypot(*load))
    c = bearing.clearance if clearance is None else float(clearance)
    q_t = combo.q_threshold * flow_scale(bearing, omega, c)
    v = combo.values
    return CoefficientTable(bearing=index, omega=float(omega), q_threshold=q_t, q=combo.ratio * q_t,
                            K=v[:, 0:4].reshape(-1, 2, 2) * (w / c), C=v[:, 4:8].reshape(-1, 2, 2) * (w / (c * omega)),
                            position=v[:, 8:10] * c, seconds=seconds, key=key)


@dataclass(frozen=True)
class DimensionlessTable:
    """Slices of one geometry at `nodes` (S values); `slices` maps node index -> Slice (those loaded).

    `evaluate` gives the dimensionless values at many (S, r) points; `view` (cache.py) the
    dimensional table of one bearing."""

    geometry: dict
    nodes: np.ndarray
    slices: dict = field(default_factory=dict)
    span: tuple = DEFAULT_SPAN
    points: int = DEFAULT_POINTS

    @property
    def s_range(self) -> tuple[float, float]:
        return float(self.nodes[0]), float(self.nodes[-1])

    def needed(self, sommerfeld) -> list[int]:
        """Node indices the queries at S values `sommerfeld` need (sorted, unique)."""
        s = np.atleast_1d(np.asarray(sommerfeld, dtype=float))
        return sorted({int(i) for x in s for i in stencil(self.nodes, float(x))})

    def combination(self, sommerfeld: float) -> Combination:
        return combine(self.nodes, self.slices, float(sommerfeld))

    def q_threshold(self, sommerfeld) -> np.ndarray:
        """qbar_T at S value(s)."""
        s = np.asarray(sommerfeld, dtype=float)
        return np.vectorize(lambda x: self.combination(x).q_threshold)(s)

    def evaluate(self, sommerfeld, ratio) -> np.ndarray:
        """Dimensionless values (..., 10) at broadcast (S, r): r-spline per side of r = 1 of each of
        the 4 slices around S, then the cubic in ln S. Columns as `Slice.values`."""
        s, r = np.broadcast_arrays(np.asarray(sommerfeld, dtype=float), np.asarray(ratio, dtype=float))
        lo, hi = self.span
        if np.any(~np.isfinite(r)) or np.any(r < lo * (1 - 1e-9)) or np.any(r > hi * (1 + 1e-9)):
            raise InputError(f"supply ratio outside the table's span {lo:g}-{hi:g} of Q_T")
        out = np.empty(s.shape + (10,))
        flat_s, flat_r, flat_out = s.ravel(), r.ravel(), out.reshape(-1, 10)
        for value in np.unique(flat_s):
            sel = flat_s == value
            combo = self.combination(float(value))
            flat_out[sel] = _spline_eval(combo.ratio, combo.values, flat_r[sel])
        return out


def _spline_eval(ratio: np.ndarray, values: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The per-side cubic splines of CoefficientTable (node at r = 1), evaluated at r."""
    k = int(np.argmin(np.abs(ratio - 1.0)))
    if abs(ratio[k] - 1.0) < 1e-12 and 3 <= k <= ratio.size - 4:
        below = CubicSpline(ratio[:k + 1], values[:k + 1], axis=0)(np.minimum(r, 1.0))
        above = CubicSpline(ratio[k:], values[k:], axis=0)(np.maximum(r, 1.0))
        return np.where((r <= 1.0)[:, None], below, above)
    return CubicSpline(ratio, values, axis=0)(r)
