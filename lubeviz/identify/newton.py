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

import math
import time
from dataclasses import dataclass, field

import numpy as np

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
    # best mode: 1 sigma of each feature with the model budget (noise + model), what the fit weighs by
    features_sigma: np.ndarray | None = None

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


def verdict_over_interval(q_supply: float, interval, q_threshold: float) -> tuple[str, str]:
    """The verdicts at both ends of a flow's 95 % interval (low, high; an open upper end counts as
    over-supplied); (v, v) with the point verdict when there is no interval. Equal ends: the record
    supports the verdict; different: the interval spans the band around Q_T."""
    if interval is None:
        v = lubrication_verdict(q_supply, q_threshold)
        return v, v
    low, high = interval
    return (lubrication_verdict(low, q_threshold),
            "over-supplied" if high is None else lubrication_verdict(high, q_threshold))


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
            raise InputError(_no_line_message(measured, k, f_snr))
        if b_snr < settings.min_line_snr:
            raise InputError(f"plane {k + 1} (node {measured.nodes[k]}): the backward 1X component is buried in "
                             f"noise ({b_snr:.1f} noise standard deviations); fb cannot be measured")


def _no_line_message(measured: MeasuredFeatures, k: int, f_snr: float) -> str:
    """'<file>: plane k (node n): no usable 1X line ...', with the declared speed and what the spectrum's
    strongest line suggests (a wrong speed label or sample rate puts the line elsewhere)."""
    where = getattr(measured, "source", None) or "record"
    speed = measured.speed_hz
    text = (f"{where}: plane {k + 1} (node {measured.nodes[k]}): no usable 1X line at the declared speed_hz"
            f" {speed:g} Hz (forward component only {f_snr:.1f} noise standard deviations)")
    strongest = getattr(measured, "strongest_line_hz", None)
    if strongest is None:
        return text + "; the spectrum holds no clear line at all (noise only?)"
    strongest = abs(strongest)  # a backward line has a negative frequency
    r = strongest / speed
    if abs(r - 1.0) < 1e-3:
        return text + f"; the spectrum's strongest line is the 1X at {strongest:.6g} Hz, too weak in this plane"
    return (text + f"; the spectrum's strongest line is at {strongest:.6g} Hz ({r:.4g} x the declared speed):"
            " check the speed_hz label or the sample rate")


def identify(model: ForwardModel, measured: MeasuredFeatures,
             settings: IdentificationSettings | None = None) -> Identification:
    """Identify Q1, Q2 from measured features with the settings' mode (default: best)."""
    settings = settings or IdentificationSettings()
    check_record(model, measured, settings)
    if settings.mode == "paper":
        return identify_paper(model, measured, settings)
    from .fit import identify_features

    return identify_features(model, measured, settings)
