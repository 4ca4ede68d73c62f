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

import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import stats

from ..errors import InputError
from .budget import ModelBudget, model_covariance
from .forward import wrap_difference

STATUS = {
    0: "converged: the step fell below the tolerance",
    1: "converged: the cost stopped decreasing (lambda ran away at a minimum)",
    2: "stopped at the iteration limit",
    3: "the best fit lies on a bound of the search box",
}
CHI2_95_1DOF = float(stats.chi2.ppf(0.95, 1))


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

    @property
    def message(self) -> str:
        return STATUS[self.status]

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

    def report(self) -> str:
        """lmfit's layout: fit statistics, parameters with std, correlations, what sits at a bound."""
        lines = ["[[Fit Statistics]]",
                 f"    features           = {len(self.features_names)}",
                 f"    free parameters    = {len(self.names)}",
                 f"    chi-square         = {self.chi2:.4g}  (noise + model budget)",
                 f"    degrees of freedom = {self.dof}",
                 f"    p-value            = {'n/a' if self.p_value is None else format(self.p_value, '.3g')}"
                 f"  (explained at level {self.level:g}: {self.explained})",
                 f"    AIC / BIC          = {self.aic:.4g} / {self.bic:.4g}",
                 f"    status             = {self.message}", "[[Variables]]"]
        for j, n in enumerate(self.names):
            v, s = self.values[j], self.std[j]
            if n in ("q1", "q2"):
                iv = self.intervals.get(n)
                ivs = "" if iv is None else (f"  95 %: [{iv[0] * 6e7:.1f}, "
                                             f"{'open' if iv[1] is None else format(iv[1] * 6e7, '.1f')}] ml/min")
                lines.append(f"    {n}: {v * 6e7:.2f} +/- {s * 6e7:.2f} ml/min{ivs}")
            else:
                lines.append(f"    {n}: {v:.6g} +/- {s:.3g}")
        lines.append("[[Correlations]] (|r| > 0.1)")
        c = self.correl
        for i in range(len(self.names)):
            for j in range(i + 1, len(self.names)):
                if abs(c[i, j]) > 0.1:
                    lines.append(f"    C({self.names[i]}, {self.names[j]}) = {c[i, j]:+.3f}")
        if self.at_bound:
            lines.append("[[At bound]] " + ", ".join(self.at_bound))
        for w in self.warnings:
            lines.append(f"[[Warning]] {w}")
        return "\n".join(lines)


class _Problem:
    """Whitened residuals of the chain against measured features, for a fixed total covariance."""

    def __init__(self, chain, measured_values, names, cov_total, free):
        self.chain, self.names, self.free = chain, tuple(names), np.asarray(free)
        self.fm = np.asarray(measured_values, dtype=float)
        self.L = np.linalg.cholesky(cov_total)

    def residual_jacobian(self, theta):
        g, J = self.chain.jacobian(theta, self.names, free=self.free)
        d = wrap_difference(g - self.fm, self.names)
        return np.linalg.solve(self.L, d), np.linalg.solve(self.L, J)

    def cost_many(self, thetas):
        g = self.chain.features(thetas, self.names)
        d = wrap_difference(g - self.fm, self.names)
        w = np.linalg.solve(self.L, np.moveaxis(d, -1, 0).reshape(len(self.names), -1))
        return np.sum(w**2, axis=0).reshape(d.shape[:-1])


def _lm(problem: _Problem, theta0, lo, hi, scale, max_iter=40, step_tol=1e-7):
    """Bounded Levenberg-Marquardt on the free parameters; returns (theta, r, J, iterations, status, path)."""
    free = problem.free
    theta = theta0.copy()
    theta[free] = np.clip(theta[free], lo[free], hi[free])
    r, J = problem.residual_jacobian(theta)
    cost = r @ r
    lam = 1e-3
    path = [theta[:2].copy()]
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
            r_new, J_new = problem.residual_jacobian(new)
            cost_new = r_new @ r_new
            if cost_new <= cost:
                lam = max(lam / 10.0, 1e-12)
                break
            lam *= 10.0
            if lam > 1e10:
                return theta, r, J, it, 1, np.array(path)
        moved = np.abs(new[free] - theta[free]) / s
        theta, r, J, cost = new, r_new, J_new, cost_new
        path.append(theta[:2].copy())
        if np.all(moved < step_tol):
            status = 0
            break
    return theta, r, J, it, status, np.array(path)


def _scales(chain) -> np.ndarray:
    lo, hi = chain.bounds()
    sc = np.array(chain.steps()) * 1e3
    sc[:2] = chain.q_threshold
    width = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
    return np.minimum(sc, np.where(np.isfinite(width), width, sc))


def _grid_starts(chain, lower, upper, n):
    s = np.linspace(math.sqrt(lower), math.sqrt(upper), n) ** 2
    a, b = np.meshgrid(s * chain.q_threshold[0], s * chain.q_threshold[1], indexing="ij")
    start = chain.start()
    pts = np.repeat(start[None, None, :], n, axis=0).repeat(n, axis=1)
    pts[..., 0], pts[..., 1] = a, b
    return pts


def _basins(cost: np.ndarray, limit: float, most: int) -> list[tuple[int, int]]:
    """Grid local minima (against their 8 neighbours) with cost below `limit`, best first."""
    n, m = cost.shape
    padded = np.pad(cost, 1, constant_values=np.inf)
    is_min = np.ones_like(cost, dtype=bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                is_min &= cost <= padded[1 + di:1 + di + n, 1 + dj:1 + dj + m]
    idx = [tuple(i) for i in np.argwhere(is_min & (cost <= limit))]
    idx.sort(key=lambda ij: cost[ij])
    return idx[:most] or [tuple(np.unravel_index(np.argmin(cost), cost.shape))]


def fit(chain, measured, *, names: Sequence[str] | None = None, budget: ModelBudget | None = None,
        level: float = 0.01, lower: float = 0.25, upper: float = 2.0, grid: int = 21, most_basins: int = 4,
        intervals: bool = True, hold_flows=None) -> Fit:
    """Fit the chain's named parameters to `measured` (MeasuredFeatures-like: names, values, cov)."""
    t0 = time.perf_counter()
    names = tuple(measured.names if names is None else names)
    idx = [measured.names.index(n) for n in names]
    fm = np.asarray(measured.values)[idx]
    cov_noise = np.asarray(measured.cov)[np.ix_(idx, idx)]
    budget = budget or ModelBudget()
    ev0 = chain.evaluations
    lo, hi = chain.bounds(lower, upper)
    scale = _scales(chain)
    free = np.arange(chain.n_params)
    if hold_flows is not None:
        free = free[2:]
    n_free = free.size
    dof = len(names) - n_free
    if dof < 0:
        raise InputError(f"{n_free} free parameters {tuple(chain.names[i] for i in free)} for {len(names)} "
                         "features: the record cannot determine them; hold some (give their values)")
    start = chain.start()
    if hold_flows is not None:
        start[:2] = hold_flows
    cov_model = model_covariance(chain, start, names, budget)
    problem = _Problem(chain, fm, names, cov_noise + cov_model, free)
    # 1. global scan over the flow box
    if hold_flows is None:
        pts = _grid_starts(chain, lower, upper, grid)
        cost = problem.cost_many(pts)
        limit = float(np.min(cost)) + max(stats.chi2.ppf(1 - level, max(dof, 1)) * 4.0, 25.0)
        starts = [pts[ij] for ij in _basins(cost, limit, most_basins)]
    else:
        starts = [start]
    # 2. refine each basin, re-weighting once with the budget at the refined point
    runs, iterations = [], 0
    for st in starts:
        theta, r, J, it, status, path = _lm(problem, st, lo, hi, scale)
        iterations += it
        runs.append((float(r @ r), theta, status, path))
    runs.sort(key=lambda t: t[0])
    refined = []
    for chi2_0, theta, status, path in runs:
        cov_m = model_covariance(chain, theta, names, budget)
        prob = _Problem(chain, fm, names, cov_noise + cov_m, free)
        theta2, r, J, it, status, path2 = _lm(prob, theta, lo, hi, scale)
        iterations += it
        refined.append((float(r @ r), theta2, r, J, status, np.concatenate([path, path2[1:]]), prob, cov_m))
    refined.sort(key=lambda t: t[0])
    chi2, theta, r, J, status, path, prob, cov_m = refined[0]
    p = float(stats.chi2.sf(chi2, dof)) if dof > 0 else None
    explained = p is None or p > level
    inflation = 1.0 if (explained or dof == 0) else chi2 / dof
    warnings = []
    try:
        cov = np.linalg.pinv(J.T @ J) * inflation
    except np.linalg.LinAlgError:
        cov = np.full((n_free, n_free), np.inf)
    full_cov = np.zeros((chain.n_params, chain.n_params))
    full_cov[np.ix_(free, free)] = cov
    std = np.sqrt(np.maximum(np.diag(full_cov), 0.0))
    if not explained:
        warnings.append(f"the model does not explain the record (chi2 = {chi2:.1f} for {dof} dof, p = {p:.2g} "
                        f"< {level:g}): uncertainties inflated x{math.sqrt(inflation):.1f}; run a diagnosis")
    at_bound = tuple(chain.names[i] for i in free if np.isclose(theta[i], lo[i], rtol=1e-6, atol=0)
                     or np.isclose(theta[i], hi[i], rtol=1e-6, atol=0))
    if at_bound and status == 0:
        status = 3
    # 3. alternatives that pass the same test
    crit = stats.chi2.ppf(1 - level, dof) if dof > 0 else np.inf
    alternatives = []
    for c2, th, *_ in refined[1:]:
        sep = np.max(np.abs(th[:2] - theta[:2]) / chain.q_threshold) > 0.03
        dup = any(np.max(np.abs(th[:2] - a[:2]) / chain.q_threshold) < 0.03 for a, _ in alternatives)
        if sep and not dup and (c2 <= crit or c2 - chi2 < CHI2_95_1DOF * inflation):
            alternatives.append((th, c2))
    if alternatives:
        alt = alternatives[0][0][:2] * 6e7
        warnings.append(f"not unique: another fit passes as well at Q1, Q2 = {alt[0]:.0f}, {alt[1]:.0f} ml/min; "
                        "a record at another speed or the static shaft position would tell them apart")
    # 4. profile intervals of the flows
    ivals = {}
    if intervals and hold_flows is None:
        for k in (0, 1):
            ivals[chain.names[k]] = _profile(prob, theta, chi2, k, lo, hi, scale, std[k],
                                             CHI2_95_1DOF * inflation, chain.q_threshold[k])
            if ivals[chain.names[k]][1] is None:
                warnings.append(f"Q{k + 1} is not bounded from above by this record (the film is flooded: "
                                "more oil barely changes the vibration)")
    fs = chain.features(theta, names)
    n = len(names)
    aic = chi2 + 2 * n_free
    bic = chi2 + n_free * math.log(max(n, 1))
    vals = theta[free] if hold_flows is not None else theta
    return Fit(names=tuple(chain.names[i] for i in free), values=vals, std=std[free], cov=full_cov[np.ix_(free, free)],
               chi2=chi2, dof=dof, p_value=p, level=level, aic=aic, bic=bic, status=status, at_bound=at_bound,
               evaluations=chain.evaluations - ev0, iterations=iterations, seconds=time.perf_counter() - t0,
               features_names=names, features_measured=fm, features_model=fs, residual=r, intervals=ivals,
               alternatives=tuple(alternatives), paths=tuple(x[5] for x in reversed(refined)),
               inflation=inflation, warnings=tuple(warnings), q_threshold=chain.q_threshold.copy())


def _profile(problem: _Problem, theta, chi2_min, k, lo, hi, scale, sigma, threshold, q_t):
    """95 % profile-likelihood interval of parameter k: (low, high); None for a side open at the box edge."""
    others = np.array([i for i in problem.free if i != k])
    sub = _Problem(problem.chain, problem.fm, problem.names, np.eye(1), others) if others.size else None
    if sub is not None:
        sub.L = problem.L
    step0 = max(0.5 * sigma, 1e-3 * q_t) if np.isfinite(sigma) else 0.02 * q_t
    bounds = []
    for direction in (-1, 1):
        edge = lo[k] if direction < 0 else hi[k]
        th = theta.copy()
        prev_v, prev_d = theta[k], 0.0
        step = step0
        found = None
        for _ in range(40):
            v = prev_v + direction * step
            if (v - edge) * direction >= 0:
                v = edge
            th[k] = v
            if sub is not None:
                th, r, *_ = _lm(sub, th, lo, hi, scale, max_iter=8, step_tol=1e-5)
                d = float(r @ r) - chi2_min
            else:
                d = float(problem.cost_many(th[None, :])[0]) - chi2_min
            if d > threshold:
                f = (threshold - prev_d) / max(d - prev_d, 1e-300)
                found = prev_v + f * (v - prev_v)
                break
            if v == edge:
                break
            prev_v, prev_d = v, max(d, 0.0)
            step *= 1.5
        bounds.append(found)
    low = bounds[0] if bounds[0] is not None else float(lo[k])
    return (float(low), None if bounds[1] is None else float(bounds[1]))
