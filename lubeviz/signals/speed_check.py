"""Does the record's declared `speed_hz` match its own 1X line? (issue 34, item 7)

A wrong speed label and a wrong sample rate look the same in a spectrum: every line sits at r x where
the declared speed puts it (a speed label off by 1/r, or a sample rate off by r). The 1X least-squares
fit (`signals.features`) then looks at the wrong frequency and finds "no usable 1X line", or, a few
resolution bins off, a leaked remnant of the line. So the spectrum is asked first.

The full spectrum of each plane, Z = x + i y (SPEC §1), with a Hann window (sidelobes 31 dB down, so a
strong line does not fake a neighbour), summed in power over the two planes:

1. a line at the declared 1X is a local maximum within `SEARCH_BINS` resolution bins (1/T, T the
   record's duration) of +speed_hz, above the noise floor (`SIGNIFICANT` x the median bin power / ln 2,
   the mean of exponentially distributed noise bins) and not a sidelobe of the strongest line
   (`SIDELOBE` of its power);
2. its frequency is refined below the bin spacing by maximizing the windowed DTFT of the record
   (heterodyne to the coarse peak, sum blocks of samples, golden section on the short block series: a
   local least-squares fit of one complex tone, O(n) in the record's length);
3. the tolerance is set by resolution and noise: `TOLERANCE_BINS` of a bin, or 5 x the Cramér-Rao
   standard deviation of a tone's frequency at the line's SNR (Rife & Boorstyn 1974), whichever is larger.
   Within it: fine. Beyond it but within `MISS_BINS` of a bin: a warning (the 1X fit at the declared
   speed still catches 98 % of the line, and the feature ratios share that factor). Farther but within
   `ADOPT_RTOL` (a label rounded to whole rpm, a speed that drifted): the record is read at its 1X line's
   speed, with a warning. Farther, or no line near the declared 1X at all while the spectrum has a clear
   strongest line elsewhere: a `DataFormatError` naming the file, the declared and the measured speed.

A record with no significant line anywhere (noise, a dead record) is left to the 1X fit's own check.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.fft

from ..errors import DataFormatError

SEARCH_BINS = 1.5  # a line at the declared 1X peaks within this many bins of it (Hann main lobe: +-2)
SIGNIFICANT = 20.0  # x the mean noise power of a bin: e^-20 per bin of a false line in white noise
SIDELOBE = 1e-2  # fraction of the strongest line's power below which a peak may be its sidelobe (-31 dB)
TOLERANCE_BINS = 0.02  # a declared speed within 1/50 of a bin of the 1X peak is fine
MISS_BINS = 0.1  # beyond 1/10 of a bin the 1X fit at the declared speed is distorted (a record 0.375 bin off
# fitted with chi2 240 for 4 dof and a phantom 0.96X line)
ADOPT_RTOL = 0.01  # a label this close to the measured 1X is a rounded or drifted speed: the 1X line's speed is used
LOW_CUT_BINS = 3.0  # bins around DC left out: the mean's and slow drift's leakage
_CHUNK = 1 << 18  # samples per chunk of the heterodyne pass (bounded temporary memory)
_BLOCKS = 512  # length of the decimated series the refinement maximizes over


@dataclass(frozen=True)
class SpeedCheck:
    """What the spectrum says about the declared speed (Hz throughout)."""

    declared_hz: float
    resolution_hz: float  # 1 / duration
    line_hz: float | None  # the refined 1X line near the declared speed, None when there is none
    strongest_hz: float | None  # the refined strongest line of the spectrum (any frequency), None in noise
    tolerance_hz: float  # |line - declared| within this is fine
    line_snr: float  # power of the line near 1X (or of the strongest) over the mean noise power of a bin

    @property
    def ratio(self) -> float | None:
        """Measured 1X (the line near 1X, else the strongest line) over the declared speed."""
        f = self.line_hz if self.line_hz is not None else self.strongest_hz
        return None if f is None else f / self.declared_hz

    @property
    def verdict(self) -> str:
        """'ok', 'off' (a warning: within MISS_BINS of a bin), 'wrong' (refused) or 'no lines' (left to the 1X fit)."""
        if self.line_hz is None:
            return "no lines" if self.strongest_hz is None else "wrong"
        off = abs(self.line_hz - self.declared_hz)
        if off <= self.tolerance_hz:
            return "ok"
        return "off" if off <= MISS_BINS * self.resolution_hz else "wrong"


def spectrum_speed_check(record) -> SpeedCheck:
    """Locate the record's 1X line (and its strongest line) in the full spectrum of its planes."""
    n, fs = record.n_samples, record.sample_rate_hz
    nfft = scipy.fft.next_fast_len(n, real=False)
    power = np.zeros(nfft, dtype=np.float32)
    n_planes = record.displacement.shape[0]
    for k in range(n_planes):  # single precision, one plane at a time: a spectrum's search needs no more
        spectrum = scipy.fft.fft(_windowed_plane(record, k), nfft, overwrite_x=True)
        power += spectrum.real ** 2
        power += spectrum.imag ** 2
        del spectrum
    planes = tuple((lambda k=k: _windowed_plane(record, k)) for k in range(n_planes))  # made again when refined
    resolution = fs / n
    bin_hz = fs / nfft

    def freq(j: int) -> float:  # signed frequency of bin j (numpy's fftfreq order)
        return (j if j < (nfft + 1) // 2 else j - nfft) * bin_hz

    noise = float(np.median(power)) / math.log(2.0)  # mean noise power of a bin (exponential law)
    cut = int(LOW_CUT_BINS * resolution / bin_hz)
    power[:cut + 1] = 0.0  # DC and drift leakage left out
    if cut:
        power[nfft - cut:] = 0.0
    strongest = int(np.argmax(power))
    floor = max(SIGNIFICANT * noise, np.finfo(float).tiny)
    strongest_ok = power[strongest] > floor

    centre, half = record.speed_hz / bin_hz, SEARCH_BINS * resolution / bin_hz
    near = [j for j in range(math.ceil(centre - half), math.floor(centre + half) + 1)
            if 0 < j < nfft - 1 and power[j] > power[j - 1] and power[j] >= power[j + 1]  # a local maximum
            and power[j] > floor and power[j] >= SIDELOBE * power[strongest]]
    line_hz = strongest_hz = None
    snr = 0.0
    j = max(near, key=lambda i: power[i]) if near else None
    if j is not None:
        line_hz = _refine(planes, freq(j), bin_hz, fs)
        snr = float(power[j] / max(noise, np.finfo(float).tiny))
    if strongest_ok:
        strongest_hz = line_hz if j == strongest else _refine(planes, freq(strongest), bin_hz, fs)
        if line_hz is None:
            snr = float(power[strongest] / max(noise, np.finfo(float).tiny))
    # Cramér-Rao bound of a complex tone's frequency: var = 6 fs^2 / ((2 pi)^2 eta n (n^2 - 1)), eta the
    # per-sample SNR; a Hann-windowed bin holds eta * (sum w)^2 / sum w^2 = eta * n * 2/3 noise powers.
    eta = snr * 1.5 / n
    crlb = math.sqrt(6.0 / ((2 * math.pi) ** 2 * max(eta, 1e-300) * n * (n * n - 1.0))) * fs
    tolerance = max(TOLERANCE_BINS * resolution, 5.0 * 2.0 * crlb)  # x2: the window's loss of efficiency
    return SpeedCheck(declared_hz=record.speed_hz, resolution_hz=resolution, line_hz=line_hz,
                      strongest_hz=strongest_hz, tolerance_hz=tolerance, line_snr=snr)


def check_speed_label(record):
    """The record, with a warning when its 1X line sits slightly off the declared speed; refused
    (`DataFormatError`) when the declared speed has no line and the spectrum's strongest line is elsewhere."""
    check = spectrum_speed_check(record)
    where = record.source or "record"
    verdict = check.verdict
    if verdict in ("ok", "no lines"):
        return record
    f = check.line_hz if check.line_hz is not None else check.strongest_hz
    whirl = " (backward whirl)" if f < 0 else ""
    f = abs(f)  # a backward line (negative frequency) is as much a 1X as a forward one
    r = f / check.declared_hz
    pct = 100.0 * (r - 1.0)
    said = (f"the 1X line is at {f:.6g} Hz, {abs(pct):.3g} % {'above' if pct > 0 else 'below'} the declared"
            f" speed_hz {check.declared_hz:g} Hz" if check.line_hz is not None else
            f"no line at the declared speed_hz {check.declared_hz:g} Hz; the spectrum's strongest line is at"
            f" {f:.6g} Hz{whirl} ({r:.4g} x the declared speed)")
    cause = (f"a speed_hz label off by x{1 / r:.4g} (the shaft at {f:.6g} Hz) or a sample_rate_hz off by"
             f" x{r:.4g} (every line scaled alike){_unit_hint(r)}")
    if verdict == "off":
        note = (f"{where}: speed_hz: {said} (resolution {check.resolution_hz:.3g} Hz: the 1X fit still holds);"
                f" check the speed_hz label or the sample rate: {cause}")
        return dataclasses.replace(record, warnings=tuple(record.warnings) + (note,))
    if abs(r - 1.0) <= ADOPT_RTOL and not whirl:  # a rounded or drifted label: the shaft's own 1X is the speed
        note = (f"{where}: speed_hz: {said}; the record is read at its 1X line's speed, {f:.6g} Hz (if instead the "
                f"sample_rate_hz is off by x{r:.4g}, the model runs {abs(pct):.2g} % off the true speed)")
        return dataclasses.replace(record, speed_hz=f, warnings=tuple(record.warnings) + (note,))
    raise DataFormatError(f"{where}: speed_hz: {said}, more than {MISS_BINS:g} of the record's resolution"
                          f" ({check.resolution_hz:.3g} Hz) away; expected the declared speed at the 1X line:"
                          f" check the speed_hz label or the sample rate ({cause})")


def _windowed_plane(record, k: int) -> np.ndarray:
    """Z = X + i Y of plane k, mean removed, Hann-windowed, complex64, built chunk by chunk."""
    n = record.n_samples
    readings = record.displacement[k]
    z = np.empty(n, dtype=np.complex64)
    for start in range(0, n, _CHUNK):
        stop = min(n, start + _CHUNK)
        x, y = record._resolve(k, readings[:, start:stop])
        z.real[start:stop] = x
        z.imag[start:stop] = y
    z -= z.mean(dtype=np.complex128)
    for start in range(0, n, _CHUNK):  # np.hanning(n), a chunk at a time
        stop = min(n, start + _CHUNK)
        z[start:stop] *= (0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(start, stop) / max(n - 1, 1))).astype(np.float32)
    return z


def _unit_hint(r: float) -> str:
    """A likely unit slip behind a speed ratio r = measured / declared."""
    for factor, text in ((60.0, "speed_hz given in rev/min"), (2 * math.pi, "speed_hz given in rad/s")):
        if abs(r * factor - 1.0) < 0.02:
            return f"; it looks like {text}"
    return ""


def _refine(planes, f0: float, bin_hz: float, fs: float) -> float:
    """Frequency (Hz) within one bin of `f0` that maximizes the windowed DTFT power summed over `planes`.

    Heterodyne each windowed plane by f0 and sum blocks of `m` samples: over +-1 bin the block sum's
    response is flat to (pi/_BLOCKS)^2/6 and symmetric, so the maximum of the short series' DTFT is that
    of the record's. Golden section on a unimodal main lobe.
    """
    series, tail = [], []
    for plane in planes:  # one plane's samples at a time
        z = plane()
        n = z.size
        m = max(1, n // _BLOCKS)
        n_used = (n // m) * m
        out = np.empty(n_used // m, dtype=complex)
        step = max(m, (_CHUNK // m) * m)  # whole blocks per chunk
        for start in range(0, n_used, step):
            stop = min(n_used, start + step)
            i = np.arange(start, stop)
            u = z[start:stop] * np.exp(-2j * math.pi * f0 / fs * i)
            out[start // m:stop // m] = u.reshape(-1, m).sum(axis=1)
        series.append(out)
        tail.append(z[n_used:] * np.exp(-2j * math.pi * f0 / fs * np.arange(n_used, n)))
        del z
    centers = (np.arange(n_used // m) * m + 0.5 * (m - 1)) / fs  # block centre times (s)
    tail_t = np.arange(n_used, n) / fs

    def power(delta: float) -> float:
        total = 0.0
        for s, u in zip(series, tail):
            c = s @ np.exp(-2j * math.pi * delta * centers) + u @ np.exp(-2j * math.pi * delta * tail_t)
            total += abs(c) ** 2
        return total

    a, b = -bin_hz, bin_hz
    g = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - g * (b - a), a + g * (b - a)
    pc, pd = power(c), power(d)
    for _ in range(60):
        if pc > pd:
            b, d, pd = d, c, pc
            c = b - g * (b - a)
            pc = power(c)
        else:
            a, c, pc = c, d, pd
            d = a + g * (b - a)
            pd = power(d)
        if b - a < 1e-7 * bin_hz:
            break
    return float(f0 + 0.5 * (a + b))
