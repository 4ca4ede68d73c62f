"""The search for Q1, Q2 (SPEC §5): the paper's generalized Newton-Raphson, and our weighted trust region.

Paper mode (Sec. 2.3, Eq. 11-14): errors eps = (f_s - f_m)/f_m for fb1, fb2 and, for the angles,
eps_phi = (phi_s - phi_m)/s with a fixed angular scale s (`settings.phi_scale`, 30 deg by default;
s = 0 gives the paper's literal phi_m, which explodes where phi_m crosses 0). Step: the least-squares
solution of J dq = -eps (4 equations, 2 unknowns), J by central differences at 2 % Q_T; bounds 25-200 %
Q_T; 3 x 3 starts {0.7, 1, 1.3} Q_T ordered by eps_T = sum |eps|; 15 iterations per start; a start that
leaves the bounds or stalls with eps_T above `accept_total_error` is abandoned for the next. Every
start's path is kept.

Best mode (ours): residuals r = L^-1 (f_s(q) - f_m), L L^T the features' noise covariance estimated from
the record itself, over all invariant features (fb, phi at both planes and Zf2/Zf1), minimized by a
Levenberg-Marquardt trust region inside the bounds with the exact Jacobian of the table model (one
evaluation per iteration). Uncertainty: cov(q) = (J^T J)^-1 of the whitened residuals, plus (sandwich)
the spread that the tables' own error (`ForwardModel.model_error_cov`) propagates into q. chi^2 = |r|^2
with n - 2 degrees of freedom says whether the model explains the data. The 3 x 3 starts are
evaluated; the search runs from the best, and from the best start far from it, so a second minimum
that fits as well (phi's closed contours, Fig. 10) is flagged rather than hidden.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..errors import InputError
from .forward import PAPER_FEATURES, ForwardModel, wrap_difference
from .measured import MeasuredFeatures
from .settings import IdentificationSettings


@dataclass(frozen=True)
class Identification:
    """Result of one identification. Flows in m^3/s; paths as arrays (n_steps, 2) per start tried."""

    q: np.ndarray
    q_std: np.ndarray | None
    converged: bool
    iterations: int
    starts_tried: int
    paths: tuple[np.ndarray, ...]
    features_names: tuple[str, ...]
    features_measured: np.ndarray
    features_model: np.ndarray
    residual: np.ndarray  # paper mode: eps (Eq. 11); best mode: whitened residual
    total_error: float  # paper: eps_T; best: chi^2
    mode: str
    evaluations: int
    seconds: float
    message: str
    q_threshold: np.ndarray
    chi2: float | None = None
    dof: int | None = None
    p_value: float | None = None
    unique: bool = True
    alternatives: tuple[np.ndarray, ...] = field(default=())
    # from the fit on named parameters (`lubeviz.identify.fit`): 95 % intervals of the flows with the model
    # budget ((low, high or None) per bearing), the test's level, warnings, the fitted effect parameters
    intervals: tuple | None = None
    level: float = 1e-3
    warnings: tuple[str, ...] = field(default=())
    effects: dict = field(default_factory=dict)
    alternatives_chi2: tuple[float, ...] = field(default=())
    # the flows' 95 % intervals when the oil's viscosity is not known (a free nuisance within x0.75-1.33):
    # a record at one speed without the static position cannot tell a viscosity change from a supply change
    intervals_any_oil: tuple | None = None
    oil_degeneracy: dict = field(default_factory=dict)

    @property
    def path(self) -> np.ndarray:
        """The path of the start that produced the answer."""
        return self.paths[-1]

    @property
    def model_explains_data(self) -> bool | None:
        """Best mode: the fit is consistent with the record's noise and the model budget (p > `level`)."""
        return None if self.p_value is None else self.p_value > self.level

    def verdict(self, k: int) -> str:
        """'starved', 'normal' or 'over-supplied' for bearing k (0-based), relative to Q_T."""
        return lubrication_verdict(self.q[k], self.q_threshold[k])


def lubrication_verdict(q_supply: float, q_threshold: float) -> str:
    """'starved' below 95 % of Q_T, 'over-supplied' above 105 %, else 'normal'."""
    r = q_supply / q_threshold
    return "starved" if r < 0.95 else ("over-supplied" if r > 1.05 else "normal")


def _grid_starts(model: ForwardModel, settings: IdentificationSettings) -> np.ndarray:
    f = np.asarray(settings.starts, dtype=float)
    a, b = np.meshgrid(f, f, indexing="ij")
    return np.stack([a.ravel() * model.q_threshold[0], b.ravel() * model.q_threshold[1]], axis=1)


def _bounds(model: ForwardModel, settings: IdentificationSettings):
    lo = np.maximum(settings.lower * model.q_threshold, model.bounds[0])
    hi = np.minimum(settings.upper * model.q_threshold, model.bounds[1])
    return lo, hi


def _paper_errors(fs: np.ndarray, fm: np.ndarray, names, settings) -> np.ndarray:
    eps = np.empty_like(fs)
    for k, n in enumerate(names):
        if n.startswith("phi"):
            d = wrap_difference((fs[..., k] - fm[k])[..., None], ("phi1",))[..., 0]
            scale = abs(fm[k]) if settings.phi_scale == 0 else settings.phi_scale
            eps[..., k] = d / scale
        else:
            eps[..., k] = (fs[..., k] - fm[k]) / fm[k]
    return eps


def identify_paper(model: ForwardModel, measured: MeasuredFeatures,
                   settings: IdentificationSettings | None = None) -> Identification:
    """The paper's identification (SPEC §5), on fb1, fb2, phi1, phi2."""
    t0 = time.perf_counter()
    settings = settings or IdentificationSettings.paper()
    names = PAPER_FEATURES
    fm = measured.subset(names).values
    lo, hi = _bounds(model, settings)
    qt = model.q_threshold
    ev0 = model.evaluations

    def eps(q):
        return _paper_errors(model.features(q[..., 0], q[..., 1], names), fm, names, settings)

    starts = _grid_starts(model, settings)
    e_starts = np.abs(eps(starts)).sum(axis=-1)
    order = np.argsort(e_starts)
    h = settings.fd_step * qt
    paths, iterations, best = [], 0, None
    for s in order:
        q = starts[s].copy()
        path = [q.copy()]
        e = eps(q)
        ok = False
        for _ in range(settings.max_iterations):
            cols = [(eps(q + h[k] * np.eye(2)[k]) - eps(q - h[k] * np.eye(2)[k])) / (2 * h[k]) for k in range(2)]
            J = np.stack(cols, axis=1)
            step = -np.linalg.lstsq(J, e, rcond=None)[0]  # Eq. 14, least-squares form
            q = q + step
            iterations += 1
            path.append(q.copy())
            if np.any(q < lo) or np.any(q > hi):
                break  # diverged out of the search domain: next start
            e = eps(q)
            if np.all(np.abs(step) < settings.step_tolerance * qt):
                ok = np.abs(e).sum() < settings.accept_total_error
                break
        paths.append(np.array(path))
        inside = np.all(q >= lo) and np.all(q <= hi)
        if inside and (best is None or np.abs(e).sum() < best[1]):
            best = (q.copy(), np.abs(e).sum(), e)
        if ok:
            break
    if best is None:
        q, total, e = starts[order[0]], e_starts[order[0]], eps(starts[order[0]])
        msg = "every start left the search domain; reporting the best start point"
        ok = False
    else:
        q, total, e = best
        msg = "converged" if ok else "no start met the stop criterion; reporting the lowest eps_T reached"
    fs = model.features(q[0], q[1], names)
    return Identification(q=q, q_std=None, converged=ok, iterations=iterations, starts_tried=len(paths),
                          paths=tuple(paths), features_names=names, features_measured=fm, features_model=fs,
                          residual=e, total_error=float(total), mode="paper",
                          evaluations=model.evaluations - ev0, seconds=time.perf_counter() - t0, message=msg,
                          q_threshold=qt.copy())


def _lm(fun, q0, lo, hi, scale, max_iter, step_tol):
    """Levenberg-Marquardt in scaled variables u = q/scale, projected onto the bounds.

    fun(q) -> (r, J) with J = dr/dq. Returns (q, r, J, iterations, path)."""
    q = np.clip(q0, lo, hi)
    r, J = fun(q)
    cost = r @ r
    lam = 1e-3
    path = [q.copy()]
    it = 0
    for it in range(1, max_iter + 1):
        Js = J * scale
        A = Js.T @ Js
        g = Js.T @ r
        while True:
            du = -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), g)
            q_new = np.clip(q + du * scale, lo, hi)
            r_new, J_new = fun(q_new)
            cost_new = r_new @ r_new
            if cost_new <= cost:
                lam = max(lam / 10.0, 1e-9)
                break
            lam *= 10.0
            if lam > 1e8:
                return q, r, J, it, np.array(path)
        moved = np.abs(q_new - q) / scale
        q, r, J, cost = q_new, r_new, J_new, cost_new
        path.append(q.copy())
        if np.all(moved < step_tol):
            break
    return q, r, J, it, np.array(path)


def identify_best(model: ForwardModel, measured: MeasuredFeatures,
                  settings: IdentificationSettings | None = None) -> Identification:
    """Noise-weighted least squares on all invariant features, with uncertainty and uniqueness check."""
    t0 = time.perf_counter()
    settings = settings or IdentificationSettings()
    names = tuple(settings.features)
    meas = measured.subset(names)
    L = np.linalg.cholesky(meas.cov)
    lo, hi = _bounds(model, settings)
    qt = model.q_threshold
    ev0 = model.evaluations

    def fun(q):
        g, J = model.features_jacobian(q[0], q[1], names)
        d = wrap_difference(g - meas.values, names)
        return np.linalg.solve(L, d), np.linalg.solve(L, J)

    def cost_many(q):
        g = model.features(q[:, 0], q[:, 1], names)
        d = wrap_difference(g - meas.values, names)
        w = np.linalg.solve(L, d.T)
        return np.sum(w**2, axis=0)

    starts = _grid_starts(model, settings)
    c0 = cost_many(starts)
    order = np.argsort(c0)
    first = starts[order[0]]
    far = [s for s in order[1:] if np.max(np.abs(starts[s] - first) / qt) > 0.45]
    runs = []
    iterations = 0
    for s in [order[0]] + far[:1]:
        q, r, J, it, path = _lm(fun, starts[s], lo, hi, qt, settings.max_iterations, settings.step_tolerance)
        iterations += it
        runs.append((float(r @ r), q, r, J, path))
    runs_sorted = sorted(runs, key=lambda t: t[0])
    chi2, q, r, J, _ = runs_sorted[0]
    try:
        H = np.linalg.inv(J.T @ J)  # J: whitened Jacobian, so H is the noise-only covariance of q
        cov_q = H
        if settings.include_model_error:
            # sandwich: the estimator weights by the noise only; the tables' own error adds to its spread
            A = H @ J.T @ np.linalg.inv(L)  # dq = A d(features)
            cov_q = H + A @ model.model_error_cov(names) @ A.T
        q_std = np.sqrt(np.diag(cov_q))
    except np.linalg.LinAlgError:
        q_std = np.full(2, np.inf)
    alternatives = []
    for c, qa, *_ in runs_sorted[1:]:
        separated = np.any(np.abs(qa - q) > 3 * np.maximum(q_std, 1e-3 * qt))
        if separated and c - chi2 < stats.chi2.ppf(0.95, 2):
            alternatives.append(qa)
    dof = len(names) - 2
    # goodness of fit against noise *and* the tables' own resolution: does the model explain the record?
    d = wrap_difference(model.features(q[0], q[1], names) - meas.values, names)
    cov_fit = meas.cov + (model.model_error_cov(names) if settings.include_model_error else 0.0)
    chi2_fit = float(d @ np.linalg.solve(cov_fit, d))
    p = float(stats.chi2.sf(chi2_fit, dof)) if dof > 0 else None
    at_bound = np.any(np.isclose(q, lo, rtol=1e-6)) or np.any(np.isclose(q, hi, rtol=1e-6))
    converged = not at_bound
    msg = "converged" if converged else "the best fit lies on the search bound"
    if alternatives:
        msg += f"; not unique: another minimum fits as well at {np.round(alternatives[0] * 6e7, 1).tolist()} ml/min"
    if p is not None and p < 1e-3:
        msg += f"; the model does not explain the record (chi2 = {chi2_fit:.1f} for {dof} dof)"
    fs = model.features(q[0], q[1], names)
    paths = tuple(run[4] for run in sorted(runs, key=lambda t: -t[0]))  # the answer's path last
    return Identification(q=q, q_std=q_std, converged=converged, iterations=iterations, starts_tried=len(runs),
                          paths=paths, features_names=names, features_measured=meas.values, features_model=fs,
                          residual=r, total_error=chi2, mode="best", evaluations=model.evaluations - ev0,
                          seconds=time.perf_counter() - t0, message=msg, q_threshold=qt.copy(), chi2=chi2_fit, dof=dof,
                          p_value=p, unique=not alternatives, alternatives=tuple(alternatives))


def check_record(model: ForwardModel, measured: MeasuredFeatures, settings: IdentificationSettings) -> None:
    """Refuse, with a message and no number, records the identification cannot use."""
    speed = model.omega / (2 * math.pi)
    if abs(measured.speed_hz / speed - 1) > settings.speed_tolerance:
        raise InputError(f"record speed {measured.speed_hz:g} Hz is far from the model's {speed:g} Hz "
                         f"(more than {settings.speed_tolerance:.0%}); build the model at the record's speed")
    if tuple(measured.nodes) != tuple(model.nodes):
        raise InputError(f"record planes at nodes {measured.nodes}, model at {model.nodes}")
    for k in range(2):
        f_snr, b_snr = measured.line_snr[k]
        if f_snr < settings.min_line_snr:
            raise InputError(f"plane {k + 1} (node {measured.nodes[k]}): no usable 1X line (forward component "
                             f"only {f_snr:.1f} noise standard deviations)")
        if b_snr < settings.min_line_snr:
            raise InputError(f"plane {k + 1} (node {measured.nodes[k]}): the backward 1X component is buried in "
                             f"noise ({b_snr:.1f} noise standard deviations); fb cannot be measured")


def identify(model: ForwardModel, measured: MeasuredFeatures,
             settings: IdentificationSettings | None = None) -> Identification:
    """Identify Q1, Q2 from measured features with the settings' mode (default: best)."""
    settings = settings or IdentificationSettings()
    check_record(model, measured, settings)
    if settings.mode == "paper":
        return identify_paper(model, measured, settings)
    return identify_best(model, measured, settings)
