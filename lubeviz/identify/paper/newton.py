"""The search for Q1, Q2 (SPEC §5): the paper's generalized Newton-Raphson, and the route to our fit (best mode).

Paper mode (Sec. 2.3, Eq. 11-14): errors eps = (f_s - f_m)/f_m for fb1, fb2 and, for the angles,
eps_phi = (phi_s - phi_m)/s with a fixed angular scale s (`settings.phi_scale`, 30 deg by default;
s = 0 gives the paper's literal phi_m, which explodes where phi_m crosses 0). Step: the least-squares
solution of J dq = -eps (4 equations, 2 unknowns), J by central differences at 2 % Q_T; bounds 25-200 %
Q_T; 3 x 3 starts {0.7, 1, 1.3} Q_T ordered by eps_T = sum |eps|; 15 iterations per start; a start that
leaves the bounds or stalls with eps_T above `accept_total_error` is abandoned for the next. Every
start's path is kept.

Best mode (ours) is the fit on named parameters, `fit.fit`: global search over the flow box, noise +
model-budget weights, profile intervals. `identify` routes it there (`fit.identify_features`), so one
record has one best-mode answer whichever page or command asks.
"""

from __future__ import annotations

import time
import numpy as np

from ..forward.model import PAPER_FEATURES, ForwardModel, wrap_difference
from ..forward.measured import MeasuredFeatures
from ..fit.result import Identification, check_record, flow_parameter
from ..fit.settings import IdentificationSettings


def start_grid(model: ForwardModel, settings: IdentificationSettings) -> np.ndarray:
    """The paper's start points (`settings.starts` x Q_T per bearing, every pair), as (n, 2) flows in m^3/s."""
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

    starts = start_grid(model, settings)
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
                          q_threshold=qt.copy(), params=tuple(flow_parameter(k, q[k]) for k in range(len(q))))


def identify(model: ForwardModel, measured: MeasuredFeatures,
             settings: IdentificationSettings | None = None) -> Identification:
    """Identify Q1, Q2 from measured features with the settings' mode (default: best)."""
    settings = settings or IdentificationSettings()
    check_record(model, measured, settings)
    if settings.mode == "paper":
        return identify_paper(model, measured, settings)
    from ..fit.least_squares import identify_features

    return identify_features(model, measured, settings)
