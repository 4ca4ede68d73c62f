"""Orbit features at a measurement plane (SPEC §1, §4): Zf, Zb, fb, phi and their noise.

Estimator: a least-squares fit of the synchronous lines to each displacement channel,
    x(t) = a0 + sum_k (a_k cos k Omega t + b_k sin k Omega t),  k = 1..`harmonics`,
so x's 1X complex amplitude is X = a_1 - i b_1 (x = Re(X e^{i Omega t})), likewise Y; then Zf, Zb, fb
and phi as in `lubeviz.rotor.directional` (Eq. 10). Over a whole number of revolutions this *is* the
DFT at +-1X; over any other length it stays unbiased (the fit absorbs the leakage between the mean,
1X and the fitted harmonics), so records need not be trimmed. Times are the record's own, and fb,
phi do not depend on the time origin (a shift multiplies Zf by e^{i Omega tau} and Zb by its inverse).

Noise, never assumed absent: the per-sample noise variance of each channel comes from the record's
own spectrum, the median periodogram of the fit residual in a band around 1X (0.5-1.5 Omega), so
other lines (2X, subsynchronous whirl) hardly bias it. Covariances of (a_1, b_1) follow from the
normal equations; those of fb and phi by the delta method on (Re X, Im X, Re Y, Im Y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataFormatError, InputError
from ..rotor.directional import directional_components, forward_backward_ratio, orbit_angle

MIN_LINE_SNR = 3.0  # a 1X component smaller than 3 noise standard deviations is "buried in noise"


@dataclass(frozen=True)
class ChannelFit:
    """1X complex amplitude of one channel, its covariance (Re, Im) and the channel's noise std."""

    amplitude: complex
    cov: np.ndarray  # 2x2 covariance of (Re, Im) of `amplitude` (m^2)
    noise_std: float  # per-sample noise standard deviation (m)
    mean: float


@dataclass(frozen=True)
class PlaneFeatures:
    """Features of one measurement plane; *_std are one standard deviation from the record's noise."""

    node: int
    x: complex
    y: complex
    zf: complex
    zb: complex
    fb: float
    phi: float  # rad, branch (-pi/2, pi/2]
    fb_std: float
    phi_std: float
    zf_std: float
    zb_std: float
    cov: np.ndarray  # covariance of (fb, phi)
    noise_std: tuple[float, float]  # per-sample noise of x and y (m)



def _design(t: np.ndarray, omega: float, harmonics: int) -> np.ndarray:
    cols = [np.ones_like(t)]
    for k in range(1, harmonics + 1):
        cols += [np.cos(k * omega * t), np.sin(k * omega * t)]
    return np.column_stack(cols)


def _band_noise_variance(residual: np.ndarray, sample_rate: float, speed_hz: float) -> float:
    n = residual.size
    spec = np.abs(np.fft.rfft(residual)) ** 2
    f = np.fft.rfftfreq(n, 1.0 / sample_rate)
    band = (f > 0.5 * speed_hz) & (f < 1.5 * speed_hz)
    if band.sum() >= 16:
        return float(np.median(spec[band]) / math.log(2.0) / n)
    return float(np.sum(residual**2) / max(n - 1, 1))


def fit_channels(signals: np.ndarray, t: np.ndarray, speed_hz: float, *, harmonics: int = 3,
                 sample_rate: float | None = None) -> list[ChannelFit]:
    """Least-squares synchronous fit of each row of `signals` (channels x samples) at times `t` (s)."""
    signals = np.atleast_2d(np.asarray(signals, dtype=float))
    t = np.asarray(t, dtype=float)
    if signals.shape[-1] != t.size:
        raise InputError(f"{signals.shape[-1]} samples but {t.size} times")
    if not np.all(np.isfinite(signals)):
        raise DataFormatError("displacement samples contain NaN or inf")
    if not (math.isfinite(speed_hz) and speed_hz > 0):
        raise InputError(f"shaft speed {speed_hz!r} Hz; expected a positive number")
    if harmonics < 1:
        raise InputError(f"harmonics = {harmonics}; expected at least 1")
    fs = sample_rate if sample_rate is not None else 1.0 / float(np.median(np.diff(t)))
    if speed_hz * (harmonics + 0.5) >= fs / 2:
        harmonics = max(1, int(fs / 2 / speed_hz - 0.5))
    omega = 2.0 * math.pi * speed_hz
    tc = t - t[0]  # better conditioned; the phase is restored below
    A = _design(tc, omega, harmonics)
    if A.shape[0] < 4 * A.shape[1]:
        raise DataFormatError(f"{t.size} samples are too few to fit {harmonics} harmonics")
    coef, *_ = np.linalg.lstsq(A, signals.T, rcond=None)
    resid = signals.T - A @ coef
    AtA_inv = np.linalg.inv(A.T @ A)
    shift = np.exp(-1j * omega * t[0])  # back to the record's own time origin
    out = []
    for c in range(signals.shape[0]):
        a1, b1 = coef[1, c], coef[2, c]
        var = _band_noise_variance(resid[:, c], fs, speed_hz)
        cov_ab = var * AtA_inv[1:3, 1:3]
        amp = complex(a1 - 1j * b1) * shift
        # (Re, Im) of (a1 - i b1) * shift is a rotation of (a1, -b1): rotate the covariance too
        R = np.array([[shift.real, -shift.imag], [shift.imag, shift.real]]) @ np.diag([1.0, -1.0])
        out.append(ChannelFit(amplitude=amp, cov=R @ cov_ab @ R.T, noise_std=math.sqrt(var), mean=coef[0, c]))
    return out


def _fb_phi(p: np.ndarray) -> np.ndarray:
    zf, zb = directional_components(p[0] + 1j * p[1], p[2] + 1j * p[3])
    return np.array([float(forward_backward_ratio(zf, zb)), float(orbit_angle(zf, zb))])


def plane_features(x: np.ndarray, y: np.ndarray, t: np.ndarray, speed_hz: float, *, node: int = 0,
                   harmonics: int = 3, sample_rate: float | None = None) -> PlaneFeatures:
    """Zf, Zb, fb, phi of one plane from its x(t), y(t) (m) with their noise-based uncertainty."""
    fx, fy = fit_channels(np.vstack([x, y]), t, speed_hz, harmonics=harmonics, sample_rate=sample_rate)
    X, Y = fx.amplitude, fy.amplitude
    zf, zb = directional_components(X, Y)
    p0 = np.array([X.real, X.imag, Y.real, Y.imag])
    cov_p = np.zeros((4, 4))
    cov_p[:2, :2], cov_p[2:, 2:] = fx.cov, fy.cov
    # delta method, central differences on the four real parameters
    base = _fb_phi(p0)
    scale = max(abs(X), abs(Y), 1e-30)
    J = np.empty((2, 4))
    for k in range(4):
        h = 1e-6 * scale
        dp = np.zeros(4)
        dp[k] = h
        hi, lo = _fb_phi(p0 + dp), _fb_phi(p0 - dp)
        d = hi - lo
        d[1] = (d[1] + 0.5 * np.pi) % np.pi - 0.5 * np.pi  # phi is defined modulo pi
        J[:, k] = d / (2 * h)
    cov = J @ cov_p @ J.T
    # |Zf| and |Zb| noise: Zf = (X + iY)/2, each complex error has variance (tr cov_X + tr cov_Y)/4
    zf_std = zb_std = 0.5 * math.sqrt(np.trace(fx.cov) + np.trace(fy.cov))
    return PlaneFeatures(node=node, x=X, y=Y, zf=complex(zf), zb=complex(zb), fb=float(base[0]),
                         phi=float(base[1]), fb_std=math.sqrt(cov[0, 0]), phi_std=math.sqrt(cov[1, 1]),
                         zf_std=zf_std, zb_std=zb_std, cov=cov, noise_std=(fx.noise_std, fy.noise_std))


@dataclass(frozen=True)
class RecordFeatures:
    """Features of both planes of a record, and the record's speed (Hz)."""

    speed_hz: float
    planes: tuple[PlaneFeatures, ...]

    @property
    def nodes(self) -> tuple[int, ...]:
        return tuple(p.node for p in self.planes)

    def vector(self) -> np.ndarray:
        """(fb1, fb2, phi1, phi2), the paper's response parameters (phi in rad)."""
        return np.array([p.fb for p in self.planes] + [p.phi for p in self.planes])

    def std(self) -> np.ndarray:
        return np.array([p.fb_std for p in self.planes] + [p.phi_std for p in self.planes])


def record_features(record, *, harmonics: int = 3) -> RecordFeatures:
    """Features of every plane of a `lubeviz.signals.records.Record` (probes resolved onto X, Y)."""
    xy = record.xy()
    t = record.t
    planes = tuple(plane_features(xy[k, 0], xy[k, 1], t, record.speed_hz, node=int(record.nodes[k]),
                                  harmonics=harmonics, sample_rate=record.sample_rate_hz)
                   for k in range(xy.shape[0]))
    return RecordFeatures(speed_hz=float(record.speed_hz), planes=planes)
