"""The orbit's other lines: +2X, -2X and the strongest sub-synchronous line, each with its noise.

The identification's model is linear (bearing coefficients at the static equilibrium): it predicts 1X
only. A record holds more, and what it holds beyond 1X is evidence of something the model lacks:
- +2X / -2X (forward and backward twice-per-revolution whirl): film nonlinearity at large orbits,
  misalignment (a preloaded coupling), a rub, probe runout;
- a sub-synchronous line (0.1-0.95X): oil whirl near 0.42-0.48X (an unstable or lightly damped film
  mode), a rub or a loose part at an integer fraction (1/2 X), a neighbouring machine.

Each line is read from the full spectrum of z = x + i y (SPEC §1: positive orders forward, negative
backward) over whole revolutions, where 2X falls exactly on a bin. Its noise comes from the same
record: the median |Z|^2 of the bins around it (lines excluded; for the sub-synchronous line, of the whole
band searched), so an amplitude is given with its SNR.
A line counts as present when it exceeds its noise at a 1 % false-alarm level: for a single bin
(2X, -2X) |Z| > sigma sqrt(ln 100); for the sub-synchronous search over N bins, |Z| > sigma sqrt(ln(100 N))
(the largest of N noise bins exceeds that with probability 1 %). Present is a statement about the
record, not a diagnosis: the linear model carries no budget for these lines, so a diagnosis reports
them as what the model and the library lack, with the usual causes.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .spectrum import full_spectrum

FALSE_ALARM = 0.01
SUB_BAND = (0.1, 0.95)  # orders searched for a sub-synchronous line (both directions)
NOISE_HALF_WIDTH = 0.3  # orders either side of a line whose bins give its noise
LINE_NOTICE = 0.05  # a present line above 5 % of 1X is named in identify's warnings and a diagnosis verdict


@dataclass(frozen=True)
class Line:
    """One spectral line at one plane: signed order (+ forward, - backward), amplitude and noise (m)."""

    plane: int  # 1 or 2
    kind: str  # "+2X", "-2X" or "sub"
    order: float
    amplitude_m: float
    noise_m: float  # rms |Z| of a noise bin there
    relative_to_1x: float  # amplitude / |Zf(1X)| of the same plane
    threshold_m: float  # present above this (1 % false alarm)

    @property
    def snr(self) -> float:
        return self.amplitude_m / self.noise_m if self.noise_m > 0 else math.inf

    @property
    def present(self) -> bool:
        return self.amplitude_m > self.threshold_m

    def as_dict(self) -> dict:
        return {**asdict(self), "snr": self.snr, "present": self.present}

    def describe(self) -> str:
        name = {"+2X": "a forward 2X line", "-2X": "a backward 2X line"}.get(
            self.kind, f"a {'forward' if self.order > 0 else 'backward'} sub-synchronous line at {abs(self.order):.2f}X")
        return (f"{name} at plane {self.plane}: {self.amplitude_m * 1e6:.2g} um, {100 * self.relative_to_1x:.1f} % of "
                f"1X ({self.snr:.0f}x its noise)")


def _noise_rms(amp: np.ndarray, order: np.ndarray, centre: float, exclude) -> float:
    band = (np.abs(order - centre) < NOISE_HALF_WIDTH)
    for o in exclude:
        band &= np.abs(order - o) > 0.02
    vals = np.abs(amp[band]) ** 2
    if vals.size < 8:
        return 0.0
    return float(math.sqrt(np.median(vals) / math.log(2.0)))  # median of an exponential -> its mean


def _zoom(z: np.ndarray, spec, order: float, record) -> tuple[float, float]:
    """A line that is not synchronous falls between bins (up to 36 % low): its amplitude and order from the
    largest |mean(z e^{-i w t})| over w within one bin of the peak (a zoom DFT of the same samples)."""
    n = spec.n_samples
    zz = z[:n] - z[:n].mean()
    t = np.arange(n) / record.sample_rate_hz
    step = 1.0 / spec.revolutions  # one bin, in orders
    orders = order + np.linspace(-step, step, 41)
    vals = np.abs(np.exp(-2j * np.pi * np.outer(orders * record.speed_hz, t)) @ zz) / n
    j = int(np.argmax(vals))
    return float(vals[j]), float(orders[j])


def record_lines(record) -> list[Line]:
    """+2X, -2X and the strongest sub-synchronous line of each plane of `record`."""
    xy = record.xy()  # (2 planes, 2, n) resolved to X, Y
    out = []
    for k in range(2):
        spec = full_spectrum(xy[k, 0] + 1j * xy[k, 1], record.sample_rate_hz, record.speed_hz)
        order, amp = spec.order, spec.amplitude
        one = abs(spec.line(1.0)) or math.inf
        lines = (1.0, -1.0, 2.0, -2.0)
        for kind, o in (("+2X", 2.0), ("-2X", -2.0)):
            a = abs(spec.line(o))
            noise = _noise_rms(amp, order, o, lines)
            out.append(Line(k + 1, kind, o, a, noise, a / one, noise * math.sqrt(math.log(1 / FALSE_ALARM))))
        sub = (np.abs(order) > SUB_BAND[0]) & (np.abs(order) < SUB_BAND[1])
        if sub.sum() >= 8:
            i = int(np.flatnonzero(sub)[np.argmax(np.abs(amp[sub]))])
            peak, o = float(abs(amp[i])), float(order[i])
            # the noise from the whole band searched (the largest bin left out): a threshold at ln(100 N)
            # noise powers is sensitive to the noise estimate, so use as many bins as there are
            rest = np.abs(np.delete(amp[sub], int(np.argmax(np.abs(amp[sub]))))) ** 2
            noise = float(math.sqrt(np.median(rest) / math.log(2.0)))
            thr = noise * math.sqrt(math.log(sub.sum() / FALSE_ALARM))
            # presence is decided on the bin maximum (the statistic the threshold is for); a present line
            # is then read by the zoom (>= the bin value) and the threshold scaled alike
            a = peak
            if peak > thr:
                a, o = _zoom(xy[k, 0] + 1j * xy[k, 1], spec, o, record)
                thr *= a / peak
            out.append(Line(k + 1, "sub", o, a, noise, a / one, thr))
    return out


def present_lines(record) -> list[Line]:
    """The lines of `record_lines` that are present (above their noise at the 1 % false-alarm level)."""
    return [line for line in record_lines(record) if line.present]


CAUSES = {"+2X": "large orbits (film nonlinearity), misalignment, a rub or probe runout",
          "-2X": "large orbits (film nonlinearity), misalignment, a rub or probe runout",
          "sub": "oil whirl (near 0.42-0.48X), a rub or a loose part (1/2X), or a neighbouring machine"}
