"""The fit on a named vector: flows and free effect parameters, with a global search and honest intervals.

Residuals r = L^-1 (f_model(theta) - f_measured) over the record's features, with L L^T = the noise
covariance of the measured features (from the record itself) + the model's own uncertainty at the
operating point (`budget.model_covariance`), so chi^2 = |r|^2 tests "the model explains the record" at a
stated level (`level`, default 1 %) against noise *and* model, not noise alone.

1. Global search: the cost on a coarse grid over the whole flow box (25-200 % Q_T per bearing, uniform
   in sqrt(Q/Q_T), effect parameters at their start values), one batched evaluation; every grid basin
   whose cost could pass the test is refined, so a wrong root is not presented as the answer.
2. Refinement: a bounded Levenberg-Marquardt in scaled variables with central-difference Jacobians (one
   batched evaluation each); the model covariance is re-evaluated at the refined point and the fit
   repeated once (the budget depends on where the fit lands). Status from `STATUS`.
3. The answer is the best fit; the other basins that pass the test are `alternatives`.
4. Intervals (95 %): the profile likelihood of each flow (the other parameters re-fitted at each step),
   the set where chi^2 - chi^2_min <= 3.84 (times the inflation below), walked out from the optimum; a
   side that reaches the box edge is open (over Q_T the film is flooded and the features barely move).
5. When the model does not explain the record (p < level), the covariance and the profile threshold are
   inflated by chi^2/dof (Birge ratio) and a warning says so: no number is shown with an uncertainty
   smaller than what the model can support.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import stats

from ...errors import InputError
from ..forward.budget import ModelBudget, model_sensitivity, set_covariance
from ..forward.model import feature_plane, wrap_difference
from ...units import MLMIN_PER_M3S
from ..tables.supply import DEFAULT_SPAN
from .result import Z95, FitParameter, flooded_above, flow_parameter, summary  # noqa: F401 - Z95 read from here

STATUS = {
    0: "converged: the step fell below the tolerance",
    1: "converged: the cost stopped decreasing (lambda ran away at a minimum)",
    2: "stopped at the iteration limit",
    3: "the best fit lies on a bound of the search box",
}
CHI2_95_1DOF = float(stats.chi2.ppf(0.95, 1))


def flows_text(q) -> str:
    """'Q1, Q2 = 420, 600 ml/min' (any number of flows, m^3/s)."""
    q = np.asarray(q, dtype=float) * MLMIN_PER_M3S
    return (", ".join(f"Q{k + 1}" for k in range(q.size)) + " = " + ", ".join(f"{v:.0f}" for v in q) + " ml/min")


@dataclass(frozen=True)
class Fit:
    """Result of a fit. Values in SI (flows m^3/s), effect parameters in their own units."""

    names: tuple[str, ...]
    values: np.ndarray
    std: np.ndarray
    cov: np.ndarray
    chi2: float
    dof: int
    p_value: float | None
    level: float
    aic: float
    bic: float
    status: int
    at_bound: tuple[str, ...]
    evaluations: int
    iterations: int
    seconds: float
    features_names: tuple[str, ...]
    features_measured: np.ndarray
    features_model: np.ndarray
    residual: np.ndarray  # whitened by noise + model
    intervals: dict  # name -> (low, high or None); flows only
    alternatives: tuple = ()  # (values, chi2) of other basins that pass the test
    paths: tuple = ()  # flows (n, 2) per refined start, the answer's last
    inflation: float = 1.0
    warnings: tuple[str, ...] = field(default=())
    q_threshold: np.ndarray | None = None
    features_sigma: np.ndarray | None = None  # 1 sigma of each feature: noise + model budget (the fit's weights)
    params: tuple = ()  # every parameter, fitted and held (`result.FitParameter`), what every rendering reads
    flows: np.ndarray | None = None  # every bearing's flow (m^3/s) at the search's answer, fitted or held (a known
    # supply), in file order: read them through `flow_values` (a later refinement changes `values`, not these)

    @property
    def message(self) -> str:
        return STATUS[self.status]

    def flow_values(self) -> np.ndarray:
        """Every bearing's flow (m^3/s, file order): the fitted ones from `values` (whatever refined them after the
        search, e.g. the large-orbit rounds), a held one (a known supply) from `flows`."""
        out = np.array(self.flows, dtype=float) if self.flows is not None else np.zeros(self._flow_count())
        for k in range(out.size):
            if f"q{k + 1}" in self.names:
                out[k] = self.values[self.names.index(f"q{k + 1}")]
        return out

    def _flow_count(self) -> int:
        """Without `flows`: every flow is fitted, named q1, q2, ... in `names`."""
        n = 0
        while f"q{n + 1}" in self.names:
            n += 1
        return n

    def flow_stds(self) -> np.ndarray:
        """Their std (0 for a held one), from `std` like `flow_values`."""
        n = len(self.flows) if self.flows is not None else self._flow_count()
        return np.array([float(self.std[self.names.index(f"q{k + 1}")]) if f"q{k + 1}" in self.names else 0.0
                         for k in range(n)])

    @property
    def explained(self) -> bool | None:
        return None if self.p_value is None else self.p_value > self.level

    @property
    def correl(self) -> np.ndarray:
        s = np.sqrt(np.diag(self.cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.cov / np.outer(s, s)

    def value(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    def summary(self) -> dict:
        """Every parameter (fitted and held, with units), the test's statistics, the features: `result.summary`."""
        return summary(self)


class _Problem:
    """Whitened residuals of one or more chains (records of one set) against their measured features."""

    def __init__(self, parts, cov_total, free):
        self.parts = parts  # [(chain, names, measured values)]
        self.free = np.asarray(free)
        self.L = np.linalg.cholesky(cov_total)
        # whitening by L^-1 (triangular, made once): a solve with L per step cost more than the step's algebra
        self.W = np.linalg.inv(self.L)
        self.names = tuple(n for _, names, _ in parts for n in names)

    def with_free(self, free) -> "_Problem":
        new = object.__new__(_Problem)
        new.parts, new.L, new.W, new.names, new.free = self.parts, self.L, self.W, self.names, np.asarray(free)
        return new

    def residual_jacobian(self, theta):
        ds, Js = [], []
        for chain, names, fm in self.parts:
            g, J = chain.jacobian(theta, names, free=self.free)
            ds.append(wrap_difference(g - fm, names))
            Js.append(J)
        return self.W @ np.concatenate(ds), self.W @ np.concatenate(Js)

    def difference(self, thetas):
        return np.concatenate([wrap_difference(chain.features(thetas, names) - fm, names)
                               for chain, names, fm in self.parts], axis=-1)

    def cost_many(self, thetas):
        d = self.difference(thetas)
        w = self.W @ np.moveaxis(d, -1, 0).reshape(d.shape[-1], -1)
        return np.sum(w**2, axis=0).reshape(d.shape[:-1])

    def model_cov(self, theta, budget, noise):
        blocks = [model_sensitivity(chain, theta, names, budget) for chain, names, _ in self.parts]
        if len(blocks) == 1:
            return noise + blocks[0] @ blocks[0].T
        correlation = (budget or ModelBudget()).set_correlation
        return noise + set_covariance(blocks, correlation, len(self.parts[0][0].sources), len(self.parts[0][0].nodes))


# a fit stops once a step lowers chi2 by less than FIT_GAIN: the parameters are then within ~sqrt(FIT_GAIN) = 1 % of
# their standard deviation of the optimum. Without it the fits of a fan diagnosis took 65 % of their steps after
# chi2 was within 1e-4 of its end, along valleys the intervals span anyway (session 52)
FIT_GAIN = 1e-4
SCREENING_GAIN = 1e-3  # chi2: a screening fit's last step gains less (the ranking's AIC differences that matter are >= 2)
SCREENING_ITER = 40
HOPELESS = 10.0  # a screening fit whose chi2 is still this many times the test's limit (it cannot pass, nor rank
HOPELESS_GAIN = 0.01  # near one that does) stops once a step lowers it by less than this share: 55 of a fan
# diagnosis's 314 screening runs crawled to SCREENING_ITER at chi2 350-160000 (a wrong wiring mix-up, a side load at
# a node that cannot make the record), 40 % of its steps


def _lm(problem: _Problem, theta0, lo, hi, scale, max_iter=100, step_tol=1e-7, cost_tol=0.0, hopeless=None):
    """Bounded Levenberg-Marquardt on the free parameters; returns (theta, r, J, iterations, status, path).

    Stops when a step moves every free parameter by less than `step_tol` of its scale, or lowers the cost
    (chi2) by less than `cost_tol`, or (`hopeless` = (floor, share)) lowers a cost still above `floor` by less than
    `share` of it."""
    free = problem.free
    theta = theta0.copy()
    theta[free] = np.clip(theta[free], lo[free], hi[free])
    r, J = problem.residual_jacobian(theta)
    cost = r @ r
    lam = 1e-3
    nq = problem.parts[0][0].n_flows
    path = [theta[:nq].copy()]
    s = scale[free]
    status = 2
    it = 0
    for it in range(1, max_iter + 1):
        Js = J * s
        A = Js.T @ Js
        g = Js.T @ r
        while True:
            du = -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), g)
            new = theta.copy()
            new[free] = np.clip(theta[free] + du * s, lo[free], hi[free])
            taken = (new[free] - theta[free]) / s
            if np.all(np.abs(taken) < step_tol) or -(2.0 * g @ taken + taken @ A @ taken) < cost_tol:
                # the step (a damped one after rejections) would move nothing, or the linear model promises less
                # than the cost a step must gain: converged here, without evaluating it
                return theta, r, J, it, 0, np.array(path)
            r_new, J_new = problem.residual_jacobian(new)
            cost_new = r_new @ r_new
            if cost_new <= cost:
                lam = max(lam / 10.0, 1e-12)
                break
            lam *= 10.0
            if lam > 1e10:
                return theta, r, J, it, 1, np.array(path)
        moved = np.abs(new[free] - theta[free]) / s
        gain = cost - cost_new
        theta, r, J, cost = new, r_new, J_new, cost_new
        path.append(theta[:nq].copy())
        if np.all(moved < step_tol) or gain < cost_tol or (hopeless is not None and cost > hopeless[0]
                                                          and gain < hopeless[1] * cost):
            status = 0
            break
    return theta, r, J, it, status, np.array(path)


def _scales(chain) -> np.ndarray:
    lo, hi = chain.bounds()
    sc = np.array(chain.steps()) * 1e3
    sc[:chain.n_flows] = chain.q_threshold
    width = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
    return np.minimum(sc, np.where(np.isfinite(width), width, sc))


# the global search's grid: `grid` points per flow for two flows (41^2 = 1681 evaluations); for N flows as many
# points per flow as keep the grid near the same size (12 for 3 flows, 7 for 4, 5 for 5 and 6), never fewer than
# GRID_MIN: the basins it finds are refined by Levenberg-Marquardt, so the grid only has to land in each valley
GRID_MIN = 5
# CENTRES: on such a coarse grid the fan's over-fed films make valleys narrower than a step (0.2 Q_T at 1.6 Q_T: chi2
# 1.3 at the truth, 108 at the grid point nearest to it), and the search refined a wrong basin (chi2 23-160) on 5 of
# the 6 records of 100 it flagged (seed 12, session 47). The cells' centres are searched too: the grid and they
# make a body-centred lattice, its points ~0.87 of a step apart along the diagonals instead of 1.73.


def grid_size(n_flows: int, grid: int) -> int:
    """Points per flow of the global search's grid for `n_flows` flows (`grid` for one or two)."""
    if n_flows <= 2:
        return grid
    return max(GRID_MIN, int(math.floor((grid * grid) ** (1.0 / n_flows) + 1e-9)))


def _grid_starts(chain, start, lo, hi, n, flows, centres: bool = False):
    """The grid over the free `flows` (n per flow, uniform in sqrt(Q / Q_T) from `lo` to `hi`), every other
    parameter at `start`: shape (n,) * len(flows) + (P,). `centres`: the centres of its cells instead, (n - 1) per
    flow (with the grid, a body-centred lattice)."""
    qt = chain.q_threshold
    axes = []
    for k in flows:
        a, b = math.sqrt(lo[k] / qt[k]), math.sqrt(hi[k] / qt[k])
        u = np.linspace(a, b, n)
        axes.append((0.5 * (u[1:] + u[:-1]) if centres else u) ** 2 * qt[k])
    pts = np.broadcast_to(start, tuple(a.size for a in axes) + start.shape).copy()
    for k, a in zip(flows, np.meshgrid(*axes, indexing="ij")):
        pts[..., k] = a
    return pts


def _basins(cost: np.ndarray, limit: float, most: int) -> list[tuple[int, ...]]:
    """Grid local minima (against all 3^N - 1 neighbours) with cost below `limit`, best first."""
    padded = np.pad(cost, 1, constant_values=np.inf)
    is_min = np.ones_like(cost, dtype=bool)
    for shift in itertools.product((-1, 0, 1), repeat=cost.ndim):
        if any(shift):
            is_min &= cost <= padded[tuple(slice(1 + d, 1 + d + n) for d, n in zip(shift, cost.shape))]
    idx = [tuple(i) for i in np.argwhere(is_min & (cost <= limit))]
    idx.sort(key=lambda ij: cost[ij])
    return idx[:most] or [tuple(np.unravel_index(np.argmin(cost), cost.shape))]


def _search_starts(problem, chain, start, lo, hi, flows, grid: int, margin: float, most: int,
                   costs=None) -> tuple[list, list]:
    """(the global search's starts, the lattices' costs): the grid's basins (`_basins`) within `margin` of its best
    cost, the `most` best. A coarse grid (3+ flows) is searched at its cells' centres too, where a narrow valley may
    pass between its points (CENTRES). `costs`: the lattices' costs a search with the same weights made before."""
    n = grid_size(len(flows), grid)
    lattices = [_grid_starts(chain, start, lo, hi, n, flows)]
    if n < grid:
        lattices.append(_grid_starts(chain, start, lo, hi, n, flows, centres=True))
    if costs is None:
        costs = [problem.cost_many(pts) for pts in lattices]
    limit = min(float(np.min(c)) for c in costs) + margin
    found = sorted(((float(c[ij]), i, ij) for i, c in enumerate(costs) for ij in _basins(c, limit, most)
                    if c[ij] <= limit), key=lambda t: t[0])
    return [lattices[i][ij] for _, i, ij in found[:most]], costs


# SEARCH_MEMO: the global search's starts and the weights it was made with, for the last fits. A diagnosis fits each
# candidate effect with the flows; most start where they change nothing (a gain of 1, a rotation of 0, the declared
# clearance), so their search over the flows would be the plain fit's again, point for point. The key holds the
# record, the box, the settings and the model's features at the start and at the box's two corners, so a chain that
# differs anywhere there searches afresh.
SEARCH_MEMO = 32
_SEARCHES: dict = {}
_SEARCHES_LOCK = threading.Lock()  # the app fits in several threads


def _search_key(parts, noise, start, lo, hi, flows, settings, budget) -> str:
    probes = np.stack([start, start, start])
    probes[1, flows] = lo[flows]
    probes[2, flows] = hi[flows]
    terms = sorted((k, v) for k, v in budget.param.values().items() if k != "name")  # not its instance's name
    h = hashlib.sha256(repr((tuple(n for _, ns, _ in parts for n in ns), tuple(flows), settings, terms)).encode())
    for chain, names, fm in parts:
        h.update(np.ascontiguousarray(chain.features(probes, names)).tobytes())
        h.update(np.ascontiguousarray(fm).tobytes())
    for a in (noise, lo[flows], hi[flows]):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def forget_searches() -> None:
    """Drop the remembered searches (SEARCH_MEMO): a benchmark times each fit's search as a first fit makes it."""
    with _SEARCHES_LOCK:
        _SEARCHES.clear()


def _remember(key: str, value) -> None:
    with _SEARCHES_LOCK:
        while _SEARCHES and len(_SEARCHES) >= SEARCH_MEMO:
            _SEARCHES.pop(next(iter(_SEARCHES)))
        _SEARCHES[key] = value


def _given_starts(ref, start, free, hold_flows) -> np.ndarray:
    """`fit`'s `start` as rows of every parameter of the chain: its own start when None; a row of the free parameters
    only (a fit's `values`) with the held ones (a known supply) put back; the held flows (`hold_flows`) set."""
    rows = np.atleast_2d(np.array(ref.start() if start is None else start, dtype=float))
    if rows.shape[1] == free.size < ref.n_params:
        full = np.tile(ref.start(), (len(rows), 1))
        full[:, free] = rows
        rows = full
    if hold_flows is not None:
        rows[:, :ref.n_flows] = hold_flows
    return rows


def _weighted_starts(parts, noise, ref, start, box, free, flows, settings, budget, dof):
    """(the problem weighted with the model budget at `start`, the starts to refine): the global search's over the
    `flows` in `box` (none: `start` alone). The weights and the lattices' costs are remembered (SEARCH_MEMO) and taken
    from there when made before; the basins are picked afresh, with this fit's own limit (its dof)."""
    lo, hi = box
    n = sum(len(ns) for _, ns, _ in parts)
    key = _search_key(parts, noise, start, lo, hi, flows, settings, budget) if flows else None
    memo = _SEARCHES.get(key) if flows else None
    cov0 = _Problem(parts, np.eye(n), free).model_cov(start, budget, noise) if memo is None else memo[0]
    problem = _Problem(parts, cov0, free)
    if not flows:
        return problem, [start]
    grid, most, level = settings
    limit = max(stats.chi2.ppf(1 - level, max(dof, 1)) * 4.0, 25.0)
    starts, costs = _search_starts(problem, ref, start, lo, hi, flows, grid, limit, most,
                                   costs=None if memo is None else memo[1])
    if memo is None:
        _remember(key, (cov0, costs))
    return problem, starts


def _variant_starts(problem, parts, noise, ref, start, box, free, flows, settings, budget, dof) -> list:
    """The best start of the global search with one effect parameter at each of its further search values
    (`ForwardChain.search_variants`), weighted as `problem`; lattices remembered as `_weighted_starts`'s."""
    lo, hi = box
    grid, most, level = settings
    limit = max(stats.chi2.ppf(1 - level, max(dof, 1)) * 4.0, 25.0)
    key = _search_key(parts, noise, start, lo, hi, flows, settings, budget)
    out = []
    for variant in ref.search_variants(start, free):
        vkey = _search_key(parts, noise, variant, lo, hi, flows, settings, budget) + key
        memo = _SEARCHES.get(vkey)
        found, costs = _search_starts(problem, ref, variant, lo, hi, flows, grid, limit, 1,
                                      costs=None if memo is None else memo[1])
        if memo is None:
            _remember(vkey, (None, costs))
        out += found
    return out


def _refine(problem, starts, box, scale, budget, noise, lm_options) -> tuple[list, int]:
    """Each start refined by Levenberg-Marquardt, re-weighted once with the budget at the refined point and refined
    again: ([(chi2, theta, r, J, status, path, problem)] best first, iterations)."""
    lo, hi = box
    runs, iterations = [], 0
    for st in starts:
        theta, r, J, it, status, path = _lm(problem, st, lo, hi, scale, **lm_options)
        iterations += it
        runs.append((float(r @ r), theta, status, path))
    runs.sort(key=lambda t: t[0])
    refined = []
    for chi2_0, theta, status, path in runs:
        prob = _Problem(problem.parts, problem.model_cov(theta, budget, noise), problem.free)
        theta2, r, J, it, status, path2 = _lm(prob, theta, lo, hi, scale, **lm_options)
        iterations += it
        refined.append((float(r @ r), theta2, r, J, status, np.concatenate([path, path2[1:]]), prob))
    refined.sort(key=lambda t: t[0])
    return refined, iterations


def _covariance(J, scale, chi2, dof, level) -> tuple[np.ndarray, float]:
    """The free parameters' covariance from the Jacobian at the optimum, inflated by chi2 / dof when the model does
    not explain the record; and that inflation."""
    explained = dof == 0 or float(stats.chi2.sf(chi2, dof)) > level
    inflation = 1.0 if explained else chi2 / dof
    Js = J * scale  # scaled columns: flows (m^3/s) and e.g. a stiffness (N/m) differ by 1e15
    return scale[:, None] * np.linalg.pinv(Js.T @ Js) * scale[None, :] * inflation, inflation


def feature_parts(chains, measured, names):
    """[(chain, feature names, measured values)] and the block-diagonal noise covariance."""
    parts, blocks = [], []
    for chain, meas in zip(chains, measured):
        use = tuple(n for n in (meas.names if names is None else names) if n in meas.names)
        static = tuple(n for n in getattr(meas, "static_names", ()) if feature_plane(n)[1] - 1 in chain.static_planes)
        use = tuple(n for n in use if n not in meas.static_names or n in static)
        use = use + tuple(n for n in static if n not in use)
        idx = [meas.names.index(n) for n in use]
        parts.append((chain, use, np.asarray(meas.values)[idx]))
        blocks.append(np.asarray(meas.cov)[np.ix_(idx, idx)])
    n = sum(b.shape[0] for b in blocks)
    noise = np.zeros((n, n))
    i = 0
    for b in blocks:
        noise[i:i + b.shape[0], i:i + b.shape[0]] = b
        i += b.shape[0]
    return parts, noise


def _lm_options(screening: bool, level: float, dof: int) -> dict:
    """`_lm`'s stops: a screening fit's (SCREENING_GAIN, SCREENING_ITER, the hopeless stop) or a full one's (FIT_GAIN)."""
    if not screening:
        return dict(cost_tol=FIT_GAIN)
    return dict(max_iter=SCREENING_ITER, cost_tol=SCREENING_GAIN,
                hopeless=(HOPELESS * stats.chi2.ppf(1 - level, max(dof, 1)), HOPELESS_GAIN))


def fit(chain, measured, *, names: Sequence[str] | None = None, budget: ModelBudget | None = None,
        level: float = 0.01, lower: float = 0.25, upper: float = 2.0, grid: int = 41, most_basins: int = 4,
        intervals: bool = True, hold_flows=None, start=None, screening: bool = False) -> Fit:
    """Fit the chain's named parameters to `measured` (MeasuredFeatures-like: names, values, cov).

    `chain` and `measured` may be sequences (records of one `set:` at several speeds, one chain each, with
    the same effects): the parameters are shared, the residuals stacked, the model budget's terms
    correlated across the speeds. `names`: the features to use (default all the record holds).
    `start`: a parameter vector to refine from instead of the global search (a local model, e.g. the
    large-orbit correction round of `orbit_fit`, that holds only near its own point; every parameter of the chain,
    or the free ones only: a `Fit`'s `values`), or several (rows): the one the model fits best there is refined (a
    node scan's neighbours' answers and the node's own screening one).
    `screening`: a fit that only ranks (a diagnosis's candidates, refined with intervals once chosen): each
    Levenberg-Marquardt run stops once a step lowers chi2 by less than SCREENING_GAIN or after SCREENING_ITER
    steps, instead of crawling along a valley where the parameters are ill-determined (a forcing effect's phase
    and size at a node that barely matters) for its full 100.
    """
    t0 = time.perf_counter()
    chains = list(chain) if isinstance(chain, (list, tuple)) else [chain]
    meas_list = list(measured) if isinstance(measured, (list, tuple)) else [measured]
    if len(chains) != len(meas_list):
        raise InputError(f"{len(chains)} chains for {len(meas_list)} records")
    ref = chains[0]
    if any(c.names != ref.names for c in chains):
        raise InputError("the records of one set must be fitted with the same effects")
    budget = budget or ModelBudget()
    parts, noise = feature_parts(chains, meas_list, names)
    all_names = tuple(n for _, ns, _ in parts for n in ns)
    fm = np.concatenate([f for _, _, f in parts])
    ev0 = [c.evaluations for c in chains]
    bounds = [c.bounds(lower, upper) for c in chains]
    lo = np.max([b[0] for b in bounds], axis=0)
    hi = np.min([b[1] for b in bounds], axis=0)
    scale = _scales(ref)
    nq = ref.n_flows
    known = ref.known_flows  # a supply the model file gives is held (SPEC §8)
    clipped = [k for k, v in known.items() if abs(v - ref.machine.bearings[k].supply_flow) > 1e-12 * v]
    free = np.array([i for i in range(ref.n_params) if i not in known and (hold_flows is None or i >= nq)], dtype=int)
    free_flows = [k for k in range(nq) if k in free]
    n_free = free.size
    dof = len(all_names) - n_free
    if dof < 0:
        raise InputError(f"{n_free} free parameters {tuple(ref.names[i] for i in free)} for {len(all_names)} "
                         "features: the record cannot determine them; hold some (give their values)")
    local = start is not None
    starts_given = _given_starts(ref, start, free, hold_flows)
    start = starts_given[0]
    # 1. global scan over the flow box (a search another fit already made is not made again: SEARCH_MEMO)
    search = hold_flows is None and not local and bool(free_flows)
    problem, starts = _weighted_starts(parts, noise, ref, start, (lo, hi), free, free_flows if search else [],
                                       (grid, most_basins, level), budget, dof)
    if len(starts_given) > 1:  # several starts given: the one the weighted model fits best is refined, weighted there
        pick = int(np.argmin(problem.cost_many(starts_given)))
        start = starts_given[pick]
        if pick:
            problem, starts = _weighted_starts(parts, noise, ref, start, (lo, hi), free, [],
                                               (grid, most_basins, level), budget, dof)
    # 2. refine each basin, re-weighting once with the budget at the refined point
    lm_options = _lm_options(screening, level, dof)
    refined, iterations = _refine(problem, starts, (lo, hi), scale, budget, noise, lm_options)
    if search and dof > 0 and stats.chi2.sf(refined[0][0], dof) <= level:  # not explained from the effects' starts:
        # their sizes searched in further basins too (a size the flows mimic from its start leaves the truth far)
        more, it = _refine(problem, _variant_starts(problem, parts, noise, ref, start, (lo, hi), free, free_flows,
                                                    (grid, most_basins, level), budget, dof),
                           (lo, hi), scale, budget, noise, lm_options)
        refined, iterations = sorted(refined + more, key=lambda t: t[0]), iterations + it
    for _restart in range(PROFILE_RESTARTS + 1):
        chi2, theta, r, J, status, path, prob = refined[0]
        cov, inflation = _covariance(J, scale[free], chi2, dof, level)
        better, ivals = [], {}
        if intervals and hold_flows is None:  # 4. (below) profile intervals of the flows; a profile point that fits
            # better than the optimum means the optimum is not the global one: refined from there, profiled again
            ivals = {ref.names[k]: _profile(prob, theta, chi2, k, lo, hi, scale, math.sqrt(max(cov[j, j], 0.0)),
                                            CHI2_95_1DOF * inflation, ref.q_threshold[k], lean=_lean(cov, free, k),
                                            better=better)
                     for j, k in enumerate(free) if k in free_flows}
        if not better or _restart == PROFILE_RESTARTS:
            break
        more, it = _refine(problem, [min(better, key=lambda t: t[0])[1]], (lo, hi), scale, budget, noise, lm_options)
        iterations += it
        if more[0][0] >= chi2:  # re-weighted at its own point it fits no better: the optimum stands
            break
        refined = sorted(refined + more, key=lambda t: t[0])
    p = float(stats.chi2.sf(chi2, dof)) if dof > 0 else None
    explained = p is None or p > level
    warnings = [_clipped_text(ref, k, known[k]) for k in clipped] + (
        [] if screening else _past_tables_text(chains, theta))
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    if not explained:
        warnings.append(f"the model does not explain the record (chi2 = {chi2:.1f} for {dof} dof, p = {p:.2g} "
                        f"< {level:g}): uncertainties inflated x{math.sqrt(inflation):.1f}; run a diagnosis")
    at_bound = tuple(ref.names[i] for i in free if np.isclose(theta[i], lo[i], rtol=1e-6, atol=0)
                     or np.isclose(theta[i], hi[i], rtol=1e-6, atol=0))
    if at_bound and status == 0:
        status = 3
    # 3. alternatives that pass the same test
    crit = stats.chi2.ppf(1 - level, dof) if dof > 0 else np.inf
    alternatives = _alternatives(refined[1:], theta, chi2, crit, inflation, ref.q_threshold)
    if alternatives:
        warnings.append(f"not unique: another fit passes as well at {flows_text(alternatives[0][0][:nq])}; "
                        "a record at another speed or the static shaft position would tell them apart")
    # 4. the profile intervals of the flows (made above)
    for k in free_flows:
        if ref.names[k] in ivals and ivals[ref.names[k]][1] is None:
            warnings.append(_unbounded_text(k, ivals[ref.names[k]][0], ref.q_threshold[k]))
    fs = prob.difference(theta) + fm
    n = len(all_names)
    std, cov = std_within([ref.names[i] for i in free], theta[free], std, cov, ivals)
    params = parameters(ref, theta, dict(zip((ref.names[i] for i in free), std)), initial=start, bounds=(lo, hi),
                            intervals=ivals)
    return Fit(names=tuple(ref.names[i] for i in free), values=theta[free], std=std, cov=cov,
               chi2=chi2, dof=dof, p_value=p, level=level, aic=chi2 + 2 * n_free,
               bic=chi2 + n_free * math.log(max(n, 1)), status=status, at_bound=at_bound,
               evaluations=sum(c.evaluations - e for c, e in zip(chains, ev0)), iterations=iterations,
               seconds=time.perf_counter() - t0, features_names=all_names, features_measured=fm,
               features_model=fs, residual=r, intervals=ivals, alternatives=tuple(alternatives),
               paths=tuple(x[5] for x in reversed(refined)), inflation=inflation, warnings=tuple(warnings),
               q_threshold=ref.q_threshold.copy(), features_sigma=np.sqrt(np.sum(prob.L ** 2, axis=1)),
               params=params, flows=theta[:nq].copy())


def _unbounded_text(k: int, low: float, q_threshold: float) -> str:
    """Why the record does not bound flow k from above: its film is flooded over the whole interval (more oil barely
    changes the vibration), or the interval reaches down into the starved side too, so the planes measured barely see
    that bearing at all (no probe near it)."""
    if flooded_above(low, q_threshold):
        return (f"Q{k + 1} is not bounded from above by this record (the film is flooded: more oil barely changes "
                "the vibration)")
    return (f"Q{k + 1} is not bounded by this record: anything from {low * MLMIN_PER_M3S:.0f} ml/min up fits, on both "
            f"sides of this bearing's Q_T ({q_threshold * MLMIN_PER_M3S:.0f} ml/min), so its answer says nothing of "
            "its lubrication: the planes measured barely see this bearing (a probe pair at or near it would)")


def _clipped_text(chain, k: int, held: float) -> str:
    """A known supply past the tables' span (`tables.supply.DEFAULT_SPAN` x Q_T) is taken at its end, and said so."""
    lo, hi = DEFAULT_SPAN
    return (f"bearing {k + 1}'s known supply {chain.machine.bearings[k].supply_flow * MLMIN_PER_M3S:.0f} "
            f"ml/min lies outside {lo:g}-{hi:g} x its Q_T ({chain.q_threshold[k] * MLMIN_PER_M3S:.0f} ml/min), "
            f"the tables' span: held at {held * MLMIN_PER_M3S:.0f} ml/min, the tables' edge")


def _past_tables_text(chains, theta) -> list[str]:
    """A sentence for each bearing whose answer lies past its table's ends at some speed (`past_tables`), whose
    film's Sommerfeld number lies past the tables' grid (`off_grid`), or whose static load turns far off its declared
    line (`turned_loads`): its coefficients there are the end's or a turned film's, so the flows are not to be
    trusted."""
    out = []
    for chain in chains:
        for k, q, q_t, end in chain.past_tables(theta):
            out.append(f"bearing {k + 1}'s flow {q * MLMIN_PER_M3S:.0f} ml/min is {q / q_t:.2f} x its Q_T as the "
                       f"fitted model has it ({q_t * MLMIN_PER_M3S:.0f} ml/min at {chain.speed_hz:g} Hz), past the "
                       f"tables' end at {end / q_t:.2g} x Q_T: its film is taken as at that end, so this flow is "
                       "not to be trusted")
        for k, s, end in chain.off_grid(theta):
            out.append(f"bearing {k + 1}'s film has a Sommerfeld number of {s:.3g} as the fitted model has it (at "
                       f"{chain.speed_hz:g} Hz), past the tables' end at {end:.3g}: its film is taken as at that end, "
                       "so the flows are not to be trusted")
        for k, turn in chain.turned_loads(theta):
            out.append(f"bearing {k + 1}'s static load as the fitted model has it (at {chain.speed_hz:g} Hz) turns "
                       f"{turn:+.0f} deg off its declared direction{' (reversed)' if abs(turn) > 90 else ''}: its film "
                       "is the tables' turned that far, which holds only for loads near their declared direction, so "
                       "the flows are not to be trusted")
    return list(dict.fromkeys(out))


def _alternatives(others, theta, chi2: float, crit: float, inflation: float, q_threshold) -> list:
    """The other refined basins that pass the same test, each at flows > 3 % of Q_T from the best and from
    each other: (theta, chi2) pairs."""
    nq = len(q_threshold)
    alternatives = []
    for c2, th, *_ in others:
        sep = np.max(np.abs(th[:nq] - theta[:nq]) / q_threshold) > 0.03
        dup = any(np.max(np.abs(th[:nq] - a[:nq]) / q_threshold) < 0.03 for a, _ in alternatives)
        if sep and not dup and (c2 <= crit or c2 - chi2 < CHI2_95_1DOF * inflation):
            alternatives.append((th, c2))
    return alternatives


def parameters(chain, theta, std: dict, *, initial, bounds, intervals: dict) -> tuple[FitParameter, ...]:
    """Every parameter of `chain` at `theta`: the flows, then each effect's, fitted ones with their std (`std`:
    key -> std of the fitted ones) and held ones (placements, given values) as given."""
    lo, hi = bounds

    def edge(v):
        return float(v) if np.isfinite(v) else None

    index = {key: j for j, key in enumerate(chain.names)}
    out = [flow_parameter(k, theta[k], std.get(f"q{k + 1}"), initial=initial[k], bounds=(lo[k], hi[k]),
                          free=f"q{k + 1}" in std, interval=intervals.get(f"q{k + 1}"))
           for k in range(len(chain.q_threshold))]
    for e in chain.effects:
        owner = chain.prefix(e)
        for pname in (*e.placement, *e.continuous):
            key, j = f"{owner}.{pname}", index.get(f"{owner}.{pname}")
            if j is None:
                out.append(FitParameter(key=key, name=pname, owner=owner, value=getattr(e, pname), unit=e.unit(pname),
                                        free=False))
            else:
                out.append(FitParameter(key=key, name=pname, owner=owner, value=float(theta[j]), unit=e.unit(pname),
                                        std=std.get(key), initial=float(initial[j]), bounds=(edge(lo[j]), edge(hi[j])),
                                        free=key in std))
    return tuple(out)


def whole_theta(chain, f: Fit) -> np.ndarray:
    """`f`'s answer as `chain`'s whole parameter vector (`chain.names`): every bearing's flow as `f` gives it
    (`Fit.flow_values`: a held one among them), then each of the chain's effect parameters by name, `f`'s value where
    it fitted it and the chain's start elsewhere. `f.values` holds the fitted parameters only: with a known supply it
    lacks that flow, and a pair's fit holds its other effect's too."""
    theta = np.array(chain.start(), dtype=float)
    flows = f.flow_values()
    if len(flows) == chain.n_flows:
        theta[:chain.n_flows] = flows
    for i, name in enumerate(chain.names):
        if name in f.names:
            theta[i] = f.values[f.names.index(name)]
    return theta


def sandwich_cov(chain, measured, theta, *, names: Sequence[str] | None = None, weights: ModelBudget,
                 budget: ModelBudget, free=None) -> np.ndarray:
    """Covariance of the `free` parameters (indices into `chain.names`; default all) of a fit weighted with the model
    budget `weights` when the model's error is the larger `budget` (a term left out of the weights, e.g. one whose
    size is uncertain itself): A V A^T, A = (J^T W^-1 J)^-1 J^T W^-1 with W and V the noise + each budget's
    covariance at `theta` (every parameter of the chain) and J the features' Jacobian there in the free ones (the
    sandwich estimator). Linear in the model's error, so it holds near theta."""
    parts, noise = feature_parts([chain], [measured], names)
    free = np.arange(chain.n_params) if free is None else np.asarray(free, dtype=int)
    probe = _Problem(parts, np.eye(noise.shape[0]), free)
    W = probe.model_cov(theta, weights, noise)
    V = probe.model_cov(theta, budget, noise)
    (ch, ns, _), = parts
    _, J = ch.jacobian(np.asarray(theta, dtype=float), ns, free=free)
    scale = _scales(chain)[free]
    Js = J * scale  # scaled columns, as in `fit`
    WiJ = np.linalg.solve(W, Js)
    A = np.linalg.pinv(Js.T @ WiJ) @ WiJ.T
    return scale[:, None] * (A @ V @ A.T) * scale[None, :]


def std_within(names, values, std, cov, intervals: dict) -> tuple[np.ndarray, np.ndarray]:
    """(std, cov) with each flow's std at least its 95 % interval's larger half-width / 1.96, that row and
    column of the covariance scaled alike (the correlations stay). The covariance is the fit's linearization
    at the answer; near Q_T's kink, or where the chi2 valley bends, the profile interval is wider on one side,
    and the +- shown must not claim more than it. An interval open above leaves the std as it is."""
    std, cov = np.array(std, dtype=float), np.array(cov, dtype=float)
    for j, n in enumerate(names):
        iv = intervals.get(n)
        if iv is None or iv[1] is None or not std[j] > 0:
            continue
        wider = max(values[j] - iv[0], iv[1] - values[j]) / Z95
        if wider > std[j]:
            f = wider / std[j]
            cov[j, :] *= f
            cov[:, j] *= f
            std[j] = wider
    return std, cov


SURE_INSIDE = 0.5  # a profile point whose first start's refit is below this share of the interval's threshold
# tries no other start: a stalled refit lies above the valley's floor, never below it, so the others could only
# lower a point already inside (every point where the crossing is decided still tries each start)
AS_PREDICTED = 0.25  # a profile point whose first refit (from the covariance's valley floor) rises within this
# share of the covariance's parabola tries no other start: a stall lies above the floor and a bend or a lower branch
# moves it off the parabola, so the other starts are tried exactly where the valley stops being the fit's quadratic
BETTER_BY = 0.1  # a profile point this much below the optimum's chi2 shows the optimum is not the global one
PROFILE_RESTARTS = 1  # then the fit is refined from that point and profiled again, at most this many times
SAME_SEED = 1e-9  # profile starts closer than this (in each parameter's scale) are one start
PROFILE_STEP = 1.0  # a profile's first step, in the fit's standard deviations: the next is 1.5 times as long, so
# the interval's crossing (1.96 sigma where the profile is a parabola) lies between the first two points
PROFILE_COST_TOL = 1e-4  # a profile point's refit stops once a step lowers chi2 by less than this: 25 steps at
# most leave it < 2.5e-3 above its minimum, against the interval's threshold of 3.84


def _lean(cov, free, k) -> np.ndarray:
    """How the other parameters follow parameter k along the chi2 valley's floor, to first order: the full-length
    vector d theta / d theta_k = cov[:, k] / cov[k, k] of the fit's covariance (zero where held)."""
    lean = np.zeros(int(np.max(free)) + 1 if len(free) else 0)
    j = int(np.flatnonzero(np.asarray(free) == k)[0])
    if cov[j, j] > 0:
        lean[np.asarray(free)] = cov[:, j] / cov[j, j]
    lean[k] = 1.0
    return lean


def _crossing(a, da, b, db, threshold) -> float:
    """Where the profile crosses `threshold` between a (inside, da) and b (outside, db), both offsets from the
    optimum (where it is 0): on the parabola through the three points where that opens upwards and crosses
    between them, else on the chord. Near its optimum a profile is a parabola, and the chord of a convex curve
    lies above it: it would cut the interval short (by 0.7 % of its half-width from points at 1 and 2 sigma)."""
    chord = a + (threshold - da) / max(db - da, 1e-300) * (b - a)
    if b == a or b == 0:
        return chord
    if a == 0:  # the optimum and one point: d(x) = c2 x^2
        c1, c2 = 0.0, db / (b * b)
    else:
        c2 = (db / b - da / a) / (b - a)  # d(x) = c1 x + c2 x^2 through (0, 0), (a, da), (b, db)
        c1 = da / a - c2 * a
    if not c2 > 0:
        return chord
    disc = c1 * c1 + 4.0 * c2 * threshold
    roots = [(-c1 + sgn * math.sqrt(disc)) / (2.0 * c2) for sgn in (1.0, -1.0)]
    inside = [x for x in roots if min(a, b) <= x <= max(a, b)]
    return inside[0] if inside else chord


def _profile(problem: _Problem, theta, chi2_min, k, lo, hi, scale, sigma, threshold, q_t, lean=None, better=None):
    """95 % profile-likelihood interval of parameter k: (low, high); None for a side open at the box edge.

    Walked out from the optimum in steps of about one standard deviation; at each step the other
    parameters are re-fitted from where the fit's covariance says the valley's floor is (`lean`: the optimum
    moved along the valley to first order), from the previous point and from a linear continuation along the
    valley (near a critical speed, or with a nuisance such as the oil's viscosity, the valley is long, curved
    and bumpy, and one warm start can stall); the crossing of the threshold is then located by bisection (the
    profile turns sharply where a nuisance reaches its bound) and the parabola through the optimum and the
    last two points (PARABOLA).
    """
    others = np.array([i for i in problem.free if i != k])
    sub = problem.with_free(others) if others.size else None
    step0 = max(PROFILE_STEP * sigma, 1e-3 * q_t) if np.isfinite(sigma) else 0.02 * q_t

    def profile_at(v, history, warm):
        th = warm.copy()
        th[k] = v
        if sub is None:
            return float(problem.cost_many(th[None, :])[0]) - chi2_min, th
        seeds = [th, np.where(np.arange(th.size) == k, v, theta)]
        if len(history) >= 2 and history[-1][0] != history[-2][0]:
            (v0, t0), (v1, t1) = history[-2], history[-1]
            seeds.insert(0, np.clip(t1 + (t1 - t0) * (v - v1) / (v1 - v0), lo, hi))
        if lean is not None:  # the valley's floor to first order (in place of the optimum's values): a refit from
            # there takes a step or two where a warm start from the last point takes two or three
            seeds[-1] = np.clip(theta + lean * (v - theta[k]), lo, hi)
            seeds.insert(0, seeds.pop())
        trials, tried = [], []
        parabola = threshold / CHI2_95_1DOF * ((v - theta[k]) / sigma) ** 2 if sigma > 0 else math.nan
        for seed in seeds:
            if trials and min(t[0] for t in trials) - chi2_min < SURE_INSIDE * threshold:
                break  # inside by a margin: another start could only lower it, which decides nothing here
            if trials and lean is not None and abs(trials[0][0] - chi2_min - parabola) <= AS_PREDICTED * parabola:
                break  # the first refit, from the valley's floor as the covariance puts it, lands on the
                # covariance's parabola: no stall and no bend to guard against here (AS_PREDICTED)
            seed = seed.copy()
            seed[k] = v
            if any(np.all(np.abs(seed - t) <= SAME_SEED * scale) for t in tried):
                continue  # the same start gives the same answer (the first step out: warm start = optimum)
            tried.append(seed)
            t_new, r, *_ = _lm(sub, seed, lo, hi, scale, max_iter=25, step_tol=1e-6, cost_tol=PROFILE_COST_TOL)
            trials.append((float(r @ r), t_new))
        c, t_best = min(trials, key=lambda t: t[0])
        if better is not None and c < chi2_min - BETTER_BY:
            better.append((c, t_best.copy()))
        return c - chi2_min, t_best

    bounds = []
    for direction in (-1, 1):
        edge = lo[k] if direction < 0 else hi[k]
        prev_v, prev_th, prev_d = theta[k], theta.copy(), 0.0
        step = step0
        history = [(theta[k], theta.copy())]
        found = None
        for _ in range(60):
            v = prev_v + direction * step
            if (v - edge) * direction >= 0:
                v = edge
            d, th = profile_at(v, history, prev_th)
            if d > threshold:
                a, b, ta, da, db = prev_v, v, prev_th, prev_d, d  # inside at a, outside at b
                for _ in range(6):
                    if db < 2.0 * threshold:  # smooth enough here: interpolate
                        break
                    mid = 0.5 * (a + b)
                    dm, tm = profile_at(mid, history, ta)
                    if dm > threshold:
                        b, db = mid, dm
                    else:
                        a, ta, da = mid, tm, dm
                found = theta[k] + _crossing(a - theta[k], da, b - theta[k], db, threshold)
                break
            history.append((v, th.copy()))
            if v == edge:
                break
            prev_v, prev_th, prev_d = v, th, max(d, 0.0)
            step = min(step * 1.5, 2.0 * step0)
        bounds.append(found)
    low = bounds[0] if bounds[0] is not None else float(lo[k])
    return (float(low), None if bounds[1] is None else float(bounds[1]))


def to_identification(res: Fit, chain) -> "Identification":
    """The `Identification` (the app's and the JSON's shape) of a `Fit` of `chain`."""
    from .result import Identification

    nq = chain.n_flows
    alternatives = tuple(a[0][:nq] for a in res.alternatives)
    return Identification(
        q=res.flow_values(), q_std=res.flow_stds(), converged=res.status in (0, 1), iterations=res.iterations,
        starts_tried=len(res.paths), paths=res.paths, features_names=res.features_names,
        features_measured=res.features_measured, features_model=res.features_model, residual=res.residual,
        total_error=res.chi2, mode="best", evaluations=res.evaluations, seconds=res.seconds,
        message="; ".join([res.message, *res.warnings]), q_threshold=chain.q_threshold.copy(), chi2=res.chi2,
        dof=res.dof, p_value=res.p_value, unique=not alternatives, alternatives=alternatives,
        intervals=tuple(res.intervals.get(n) for n in chain.names[:nq]), level=res.level, warnings=res.warnings,
        alternatives_chi2=tuple(a[1] for a in res.alternatives), features_sigma=res.features_sigma,
        params=res.params)


def identify_features(model, measured, settings=None) -> "Identification":
    """Best mode on measured features and a `ForwardModel` (its tables, rotor and planes; no record, so
    the declared probe angles and no effects): the same fit as a record's (`batch.identify_record`)."""
    from ..forward.chain import ForwardChain
    from .result import check_record
    from .settings import IdentificationSettings

    settings = settings or IdentificationSettings()
    check_record(model, measured, settings)
    chain = ForwardChain(model.machine, model.omega / (2 * math.pi), model.nodes, tables=model.tables,
                         rotor=model.rotor)
    budget = None if settings.include_model_error else ModelBudget.none()
    res = fit(chain, measured, names=tuple(settings.features), budget=budget, lower=settings.lower,
              upper=settings.upper)
    return to_identification(res, chain)
