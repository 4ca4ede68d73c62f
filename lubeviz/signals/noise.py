"""Measurement noise (SPEC §1): white Gaussian noise at a given SNR, like MATLAB `awgn(x, snr, 'measured')`.

The SNR is relative to the channel's *measured* dynamic power (mean removed), so a channel with a
small orbit axis gets proportionally small noise. Randomness comes only from the `rng` argument.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError


def noise_std(signal: np.ndarray, snr_db: float) -> np.ndarray:
    """Standard deviation of the noise that gives `snr_db` on each channel (last axis = time)."""
    if not math.isfinite(snr_db):
        raise InputError(f"SNR {snr_db!r} dB; expected a finite number")
    x = np.asarray(signal, dtype=float)
    power = np.mean((x - x.mean(axis=-1, keepdims=True)) ** 2, axis=-1)
    return np.sqrt(power / 10.0 ** (snr_db / 10.0))


def add_noise(signal: np.ndarray, snr_db: float | None, rng: np.random.Generator) -> np.ndarray:
    """`signal` plus white Gaussian noise at `snr_db` per channel (None: no noise, a copy)."""
    x = np.asarray(signal, dtype=float)
    if snr_db is None:
        return x.copy()
    if not isinstance(rng, np.random.Generator):
        raise InputError("noise needs an explicit numpy.random.Generator (e.g. np.random.default_rng(seed))")
    std = noise_std(x, snr_db)
    return x + std[..., None] * rng.standard_normal(x.shape)
