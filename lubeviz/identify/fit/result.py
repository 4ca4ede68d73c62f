"""What an identification gives and what it refuses: the result type, the lubrication verdicts, the record check.

Shared by paper mode (`newton`) and best mode (`fit`), so neither imports the other for them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...errors import InputError

VERDICT_BAND = (0.95, 1.05)  # a flow within this fraction of Q_T is "normal"


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
    # from the fit on named parameters (`lubeviz.identify.fit.least_squares`): 95 % intervals of the flows with the model
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
    """'starved' below 95 % of Q_T, 'over-supplied' above 105 %, else 'normal' (`VERDICT_BAND`)."""
    r = q_supply / q_threshold
    return "starved" if r < VERDICT_BAND[0] else ("over-supplied" if r > VERDICT_BAND[1] else "normal")


def check_record(model, measured, settings) -> None:
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


def _no_line_message(measured, k: int, f_snr: float) -> str:
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
