"""Measured features of a record and their noise covariance, for the identification.

Each of the four displacement channels (x1, y1, x2, y2, after resolving the probes) gets a
least-squares 1X fit with its own noise from the record's spectrum (`lubeviz.signals.features`);
the features are functions of the four complex amplitudes, so their covariance follows by the delta
method (central differences on the eight real parameters). Non-orthogonal probes correlate the x
and y noise of a plane; that correlation is neglected here (exact for X/Y probes).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Sequence

import numpy as np

from ...signals.features import fit_channels
from .model import ALL_FEATURES, feature_vector, plane_features, static_features, wrap_difference


@dataclass(frozen=True)
class MeasuredFeatures:
    """Feature values (in `names` order), their covariance, and the fitted 1X amplitudes x, y (2 planes)."""

    names: tuple[str, ...]
    values: np.ndarray
    cov: np.ndarray
    x: np.ndarray
    y: np.ndarray
    nodes: tuple[int, ...]
    speed_hz: float
    line_snr: np.ndarray  # |Zf|, |Zb| of each plane over their noise std: (planes, 2)
    static_names: tuple[str, ...] = ()  # static offsets the record holds (SPEC §6 `static: absolute`)
    source: str | None = None  # the record's file, for messages
    strongest_line_hz: float | None = None  # the strongest line of the record's full spectrum (Hz), if any

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.diag(self.cov))

    def subset(self, names: Sequence[str]) -> "MeasuredFeatures":
        idx = [self.names.index(n) for n in names]
        return MeasuredFeatures(names=tuple(names), values=self.values[idx], cov=self.cov[np.ix_(idx, idx)],
                                x=self.x, y=self.y, nodes=self.nodes, speed_hz=self.speed_hz,
                                line_snr=self.line_snr,
                                static_names=tuple(n for n in self.static_names if n in names),
                                source=self.source, strongest_line_hz=self.strongest_line_hz)


def measure(record, names: Sequence[str] | None = None, *, harmonics: int = 3) -> MeasuredFeatures:
    """Features of a `Record` for the identification, with the noise covariance. `names`: the features to
    measure (default: every 1X invariant of the record's planes, `model.plane_features`; the paper's six for two
    planes)."""
    names = plane_features(record.xy().shape[0] if not hasattr(record, "n_planes") else record.n_planes) \
        if names is None else tuple(names)
    xy = record.xy()
    # The features do not depend on the time origin (a common shift rotates every amplitude alike), so the
    # start is taken modulo one revolution: a t0 of 1.7e15 s (epoch nanoseconds in seconds) keeps every
    # sample time exact instead of rounding them to 0.25 s. For a usual t0 the times are the record's own.
    t0 = math.fmod(float(getattr(record, "t0", 0.0)), 1.0 / record.speed_hz)
    t = t0 + np.arange(record.n_samples) / record.sample_rate_hz
    n_planes = xy.shape[0]
    nc = 2 * n_planes
    fits = fit_channels(xy.reshape(nc, -1), t, record.speed_hz, harmonics=harmonics,
                        sample_rate=record.sample_rate_hz)
    amp = np.array([f.amplitude for f in fits])  # x1, y1, x2, y2, ...
    x, y = amp[0::2], amp[1::2]
    p0 = np.concatenate([[a.real, a.imag] for a in amp])
    cov_p = np.zeros((2 * nc, 2 * nc))
    for k, f in enumerate(fits):
        cov_p[2 * k:2 * k + 2, 2 * k:2 * k + 2] = f.cov

    def g(p):
        a = p[0::2] + 1j * p[1::2]
        return feature_vector(a[0::2], a[1::2], names)

    values = g(p0)
    scale = np.abs(amp).max()
    J = np.empty((len(names), 2 * nc))
    for k in range(2 * nc):
        h = 1e-6 * scale
        dp = np.zeros(2 * nc)
        dp[k] = h
        J[:, k] = wrap_difference(g(p0 + dp) - g(p0 - dp), names) / (2 * h)
    cov = J @ cov_p @ J.T
    zf, zb = 0.5 * (x + 1j * y), np.conj(0.5 * (x - 1j * y))
    z_std = 0.5 * np.sqrt(np.array([np.trace(fits[2 * k].cov) + np.trace(fits[2 * k + 1].cov)
                                    for k in range(n_planes)]))
    snr = np.stack([np.abs(zf) / z_std, np.abs(zb) / z_std], axis=1)
    static_names: tuple[str, ...] = ()
    offset = getattr(record, "static_offset", None)
    if offset is not None:  # the static journal offsets from the rest reading (SPEC §6), metres
        std = np.asarray(record.static_offset_std, dtype=float).reshape(nc)
        static_names = static_features(n_planes)
        values = np.concatenate([values, np.asarray(offset, dtype=float).reshape(nc)])
        full = np.zeros((len(names) + nc, len(names) + nc))
        full[:len(names), :len(names)] = cov
        full[len(names):, len(names):] = np.diag(std**2)
        cov = full
        names = names + static_names
    return MeasuredFeatures(names=names, values=values, cov=cov, x=x, y=y, nodes=tuple(int(n) for n in record.nodes),
                            speed_hz=float(record.speed_hz), line_snr=snr, static_names=static_names,
                            source=getattr(record, "source", None), strongest_line_hz=_strongest_line(record))


def _strongest_line(record) -> float | None:
    """The record's strongest spectral line (Hz), to say what a record without a usable 1X line holds."""
    from ...errors import LubevizError
    from ...signals.speed_check import spectrum_speed_check

    try:
        return spectrum_speed_check(record).strongest_hz
    except (LubevizError, ValueError):
        return None
