"""Full spectrum of an orbit (SPEC §1, Eq. 10): the DFT of Z = x + i y, positive and negative lines.

Positive frequencies are forward whirl (with the spin), negative ones backward whirl. A line
Z = A e^{i w t} shows up with amplitude |A| at +w (and nothing at -w); a circular forward orbit has
no backward line; an elliptical one has both (SPEC §1: Zf at +Omega, Zb at -Omega).

Window choice (documented, selectable): by default the record is trimmed to the largest whole number
of revolutions and left unwindowed, so every synchronous line (1X, 2X, ...) falls exactly on a bin
and is read without leakage. `window="hann"` uses the whole record with a Hann window (amplitude
corrected), better for lines that are not synchronous with the shaft.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DataFormatError, InputError


@dataclass(frozen=True)
class FullSpectrum:
    """freq_hz: signed bin frequencies, ascending; amplitude: complex line amplitude at each bin (m)."""

    freq_hz: np.ndarray
    amplitude: np.ndarray
    speed_hz: float
    window: str
    n_samples: int
    revolutions: float

    @property
    def order(self) -> np.ndarray:
        """Frequencies in multiples of the shaft speed (1 = forward 1X, -1 = backward 1X)."""
        return self.freq_hz / self.speed_hz

    def line(self, order: float) -> complex:
        """Complex amplitude of the bin nearest to `order` x shaft speed."""
        k = int(np.argmin(np.abs(self.freq_hz - order * self.speed_hz)))
        return complex(self.amplitude[k])


def whole_revolutions(n_samples: int, sample_rate: float, speed_hz: float) -> int:
    """Number of samples spanning the largest whole number of revolutions (at least one)."""
    revs = math.floor(n_samples * speed_hz / sample_rate + 1e-9)
    if revs < 1:
        raise DataFormatError(f"record of {n_samples} samples at {sample_rate:g} Hz is shorter than one "
                              f"revolution at {speed_hz:g} Hz")
    return min(n_samples, int(round(revs * sample_rate / speed_hz)))


def full_spectrum(z: np.ndarray, sample_rate: float, speed_hz: float, *, window: str = "revolutions",
                  remove_mean: bool = True) -> FullSpectrum:
    """Full spectrum of the complex orbit signal z(t) = x + i y sampled at `sample_rate` (Hz)."""
    z = np.asarray(z, dtype=complex)
    if z.ndim != 1 or z.size < 8:
        raise InputError(f"full spectrum needs a 1-D signal of at least 8 samples, got shape {z.shape}")
    if not (sample_rate > 0 and speed_hz > 0):
        raise InputError(f"sample rate {sample_rate!r} Hz and speed {speed_hz!r} Hz must be positive")
    if window == "revolutions":
        z = z[:whole_revolutions(z.size, sample_rate, speed_hz)]
        w = np.ones(z.size)
    elif window == "hann":
        w = np.hanning(z.size)
    else:
        raise InputError(f"window {window!r}; expected 'revolutions' or 'hann'")
    if remove_mean:
        z = z - z.mean()
    spec = np.fft.fftshift(np.fft.fft(z * w)) / w.sum()
    freq = np.fft.fftshift(np.fft.fftfreq(z.size, 1.0 / sample_rate))
    return FullSpectrum(freq_hz=freq, amplitude=spec, speed_hz=float(speed_hz), window=window,
                        n_samples=z.size, revolutions=z.size * speed_hz / sample_rate)
