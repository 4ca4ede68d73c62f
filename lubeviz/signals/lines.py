"""The orbit's other lines: +2X, -2X and the strongest sub-synchronous line, each with its noise.

The identification's model is linear (bearing coefficients at the static equilibrium): it predicts 1X
only. A record holds more, and what it holds beyond 1X is evidence of something the model lacks:
- +2X / -2X (forward and backward twice-per-revolution whirl): film nonlinearity at large orbits,
  misalignment (a preloaded coupling), a rub, probe runout;
- a sub-synchronous line (0.1-0.95X): oil whirl near 0.42-0.48X (an unstable or lightly damped film
  mode), a rub or a loose part at an integer fraction (1/2 X), a neighbouring machine.

- a line at the mains frequency (50 or 60 Hz) or one of its harmonics, at no fixed order of the shaft's
  speed: electrical pickup in the probes' cables (a ground loop, a cable run beside power cables), not
  the machine. It is named as such, never read as a whirl; where it also sits in the oil-whirl band the
  description says so (a record at another speed tells them apart: pickup stays at its frequency).

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
MAINS_HZ = (50.0, 60.0)  # the grids' frequencies
MAINS_HARMONICS = (1, 2, 3)  # pickup also shows at twice and three times the mains frequency (rectifiers, magnetics)
MAINS_TOLERANCE_HZ = 0.25  # a grid runs within +-0.2 Hz of its nominal frequency
WHIRL_BAND = (0.38, 0.5)  # orders where oil whirl sits (SUB_BAND holds it)


@dataclass(frozen=True)
class Line:
    """One spectral line at one plane: signed order (+ forward, - backward), amplitude and noise (m)."""

    plane: int  # 1 or 2
    kind: str  # "+2X", "-2X", "sub" or "mains"
    order: float
    amplitude_m: float
    noise_m: float  # rms |Z| of a noise bin there
    relative_to_1x: float  # amplitude / |Zf(1X)| of the same plane
    threshold_m: float  # present above this (1 % false alarm)

    speed_hz: float = 0.0  # the record's shaft speed (a line's frequency is order x speed)

    @property
    def frequency_hz(self) -> float:
        return abs(self.order) * self.speed_hz

    @property
    def snr(self) -> float:
        return self.amplitude_m / self.noise_m if self.noise_m > 0 else math.inf

    @property
    def present(self) -> bool:
        return self.amplitude_m > self.threshold_m

    def as_dict(self) -> dict:
        return {**asdict(self), "snr": self.snr, "present": self.present}

    def describe(self) -> str:
        if self.kind == "mains":
            f = self.frequency_hz
            base, n = mains_frequency(f, math.inf)
            whirl = (f"; it also sits at {abs(self.order):.2f}X, where oil whirl would: a record at another speed "
                     "tells them apart (pickup stays at its frequency)") if WHIRL_BAND[0] <= abs(self.order) <= WHIRL_BAND[1] else ""
            return (f"a line at {f:.2f} Hz ({'the' if n == 1 else f'{n} x the'} {base:g} Hz mains frequency) at plane "
                    f"{self.plane}: {self.amplitude_m * 1e6:.2g} um, {100 * self.relative_to_1x:.1f} % of 1X "
                    f"({self.snr:.0f}x its noise){whirl}")
        name = {"+2X": "a forward 2X line", "-2X": "a backward 2X line"}.get(
            self.kind, f"a {'forward' if self.order > 0 else 'backward'} sub-synchronous line at {abs(self.order):.2f}X")
        return (f"{name} at plane {self.plane}: {self.amplitude_m * 1e6:.2g} um, {100 * self.relative_to_1x:.1f} % of "
                f"1X ({self.snr:.0f}x its noise)")


def mains_frequency(f_hz: float, tolerance_hz: float = MAINS_TOLERANCE_HZ) -> tuple[float, int] | tuple[None, None]:
    """(grid frequency, harmonic) of the mains line nearest `f_hz`, when within `tolerance_hz`."""
    best = min(((base, n) for base in MAINS_HZ for n in MAINS_HARMONICS), key=lambda bn: abs(f_hz - bn[0] * bn[1]))
    return best if abs(f_hz - best[0] * best[1]) <= tolerance_hz else (None, None)


def _mains_lines(z, spec, record, plane: int, one: float, taken) -> list[Line]:
    """One line per mains frequency and harmonic that no shaft order explains, forward or backward, whichever
    is stronger; present at a 1 % false alarm over all the bins tested. Frequencies within a bin of an
    integer order or of a line already named (`taken`) are skipped: nothing tells pickup from the machine."""
    width = max(MAINS_TOLERANCE_HZ, 1.5 * record.speed_hz / spec.revolutions)
    nyquist = 0.5 * record.sample_rate_hz
    order, amp = spec.order, np.abs(spec.amplitude)
    tests = []
    for base in MAINS_HZ:
        for n in MAINS_HARMONICS:
            f = base * n
            o = f / record.speed_hz
            if f > 0.9 * nyquist or abs(o - round(o)) * record.speed_hz < 2 * width or o < 2 / spec.revolutions:
                continue
            if any(abs(f - t) < 2 * width for t in taken):
                continue
            idx = np.flatnonzero(np.abs(np.abs(order) - o) <= width / record.speed_hz)
            if idx.size:
                tests.append((o, idx))
    n_bins = sum(idx.size for _, idx in tests)
    exclude = [float(k) for k in range(-3, 4)]
    out = []
    for o, idx in tests:
        i = int(idx[np.argmax(amp[idx])])
        peak = float(amp[i])
        noise = _noise_rms(spec.amplitude, order, float(order[i]), exclude + [float(order[j]) for j in idx])
        thr = noise * math.sqrt(math.log(n_bins / FALSE_ALARM))  # the largest of n_bins noise bins: 1 %
        a, oz = peak, float(order[i])
        if noise > 0 and peak > thr:  # decided on the bins; a present line is read by the zoom (>= the bin)
            a, oz = _zoom(z, spec, oz, record)
            thr *= a / peak
        out.append(Line(plane, "mains", oz, a, noise, a / one, thr if noise > 0 else math.inf, record.speed_hz))
    return out


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
    xy = record.xy()  # (P planes, 2, n) resolved to X, Y
    out = []
    for k in range(xy.shape[0]):
        spec = full_spectrum(xy[k, 0] + 1j * xy[k, 1], record.sample_rate_hz, record.speed_hz)
        order, amp = spec.order, spec.amplitude
        one = abs(spec.line(1.0)) or math.inf
        lines = (1.0, -1.0, 2.0, -2.0)
        for kind, o in (("+2X", 2.0), ("-2X", -2.0)):
            a = abs(spec.line(o))
            noise = _noise_rms(amp, order, o, lines)
            out.append(Line(k + 1, kind, o, a, noise, a / one, noise * math.sqrt(math.log(1 / FALSE_ALARM)),
                            record.speed_hz))
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
            # a sub-synchronous line at the mains frequency is pickup, not the machine
            kind = "mains" if peak > thr and mains_frequency(abs(o) * record.speed_hz)[0] is not None else "sub"
            out.append(Line(k + 1, kind, o, a, noise, a / one, thr, record.speed_hz))
        taken = [line.frequency_hz for line in out if line.plane == k + 1 and line.kind == "mains"]
        out += _mains_lines(xy[k, 0] + 1j * xy[k, 1], spec, record, k + 1, one, taken)
    return out


def present_lines(record) -> list[Line]:
    """The lines of `record_lines` that are present (above their noise at the 1 % false-alarm level)."""
    return [line for line in record_lines(record) if line.present]


CAUSES = {"+2X": "large orbits (film nonlinearity), misalignment, a rub or probe runout",
          "-2X": "large orbits (film nonlinearity), misalignment, a rub or probe runout",
          "sub": "oil whirl (near 0.42-0.48X), a rub or a loose part (1/2X), or a neighbouring machine",
          "mains": "electrical pickup at the mains frequency or its harmonics, not the machine: check the probes' "
                   "cable shields, grounding (one ground point) and routing away from power cables"}
