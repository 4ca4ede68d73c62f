"""What an identification gives and what it refuses: the result type, its parameters, its summary, the lubrication
verdicts, the record check.

Shared by paper mode (`paper.newton`) and best mode (`fit.least_squares`), so neither imports the other for them.
Every rendering (the CLI's JSON and text, the batch CSV, the diagnosis, the report, the pages) reads a result
through `summary()` and its `FitParameter`s: one place says what a parameter is, its unit and whether it was
fitted or held (lmfit's `Parameter` and `fit_report` are the model).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ...errors import InputError
from ...units import MLMIN_PER_M3S

VERDICT_BAND = (0.95, 1.05)  # a flow within this fraction of Q_T is "normal"
UNBOUNDED_FLOODED = VERDICT_BAND[0]  # an interval open above and starting here x Q_T or higher: the film is flooded
# over all of it (more oil barely changes the vibration); one starting lower spans the starved side too: the
# record barely sees that bearing


def flooded_above(low: float, q_threshold: float) -> bool:
    """Whether a flow interval open above (its low end `low`, same unit as `q_threshold`) is open because the film
    is flooded over all of it, rather than because the record barely sees that bearing (`UNBOUNDED_FLOODED`)."""
    return low >= UNBOUNDED_FLOODED * q_threshold
Z95 = float(stats.norm.ppf(0.975))  # 1.96: a 95 % interval's half-width in standard deviations


@dataclass(frozen=True)
class FitParameter:
    """One parameter of a fit, fitted or held, in the unit it is shown in (flows in ml/min).

    `key` is its name in the fit's vector (`q1`, `probe_rotation.angle_deg`); `owner` what it belongs to
    ("bearing 1", an effect's label); `interval` the 95 % interval (low, high or None when the record does
    not bound it from above), None where none was computed; `initial` where the search started; `bounds`
    the box it was searched in (None: unbounded). A held parameter (`free` False) has no std: it was given.
    A placement (bearing, plane, channel) is held and may be a word ("both")."""

    key: str
    name: str
    owner: str
    value: object
    unit: str = ""
    std: float | None = None
    initial: float | None = None
    bounds: tuple = (None, None)
    free: bool = True
    interval: tuple | None = None

    @property
    def is_flow(self) -> bool:
        return self.owner.startswith("bearing ")

    def as_dict(self) -> dict:
        return {"key": self.key, "name": self.name, "owner": self.owner, "value": self.value, "unit": self.unit,
                "std": self.std, "initial": self.initial, "bounds": list(self.bounds), "free": self.free,
                "interval_95": None if self.interval is None else list(self.interval)}

    def text(self) -> str:
        """'angle_deg = 4.99 deg, 95 % interval 4.37 to 5.61' (the profile interval, else +-1.96 sigma with the
        model budget) or 'plane = 1 (held)'."""
        unit = f" {self.unit}" if self.unit else ""
        if not self.free:
            return f"{self.name} = {_fmt(self.value)}{unit} (held)"
        low, high = self.interval or ((None, None) if self.std is None else
                                      (self.value - Z95 * self.std, self.value + Z95 * self.std))
        span = ("" if low is None else
                f", 95 % interval {low:.4g} to {'open' if high is None else format(high, '.4g')}")
        return f"{self.name} = {self.value:.4g}{unit}{span}"


def _fmt(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def flow_parameter(k: int, value: float, std: float | None = None, *, initial: float | None = None,
                   bounds=(None, None), free: bool = True, interval=None) -> FitParameter:
    """Bearing k's supply flow (0-based; SI in, ml/min out) as a `FitParameter`."""
    def ml(v):
        return None if v is None else float(v) * MLMIN_PER_M3S

    return FitParameter(key=f"q{k + 1}", name=f"q{k + 1}", owner=f"bearing {k + 1}", value=ml(value), unit="ml/min",
                        std=ml(std), initial=ml(initial), bounds=(ml(bounds[0]), ml(bounds[1])), free=free,
                        interval=None if interval is None else (ml(interval[0]), ml(interval[1])))


def effect_values(params) -> dict:
    """{owner: {name: value, name_std: std}} of the effects' parameters (SPEC §7 `effects`), held ones as given."""
    out: dict = {}
    for p in params:
        if p.is_flow:
            continue
        out.setdefault(p.owner, {})[p.name] = p.value
        if p.free:
            out[p.owner][p.name + "_std"] = p.std
    return out


def summary(result) -> dict:
    """What a result says, in the units it is shown in: every parameter (`FitParameter.as_dict`), the test's
    statistics, the features (measured, model, 1 sigma with the model budget), the alternatives, the
    warnings. `result`: a `least_squares.Fit` or an `Identification` (both carry `params`)."""
    names = list(result.features_names)
    sigma = getattr(result, "features_sigma", None)
    nq = len(result.q_threshold)
    alternatives = [{"flows_mlmin": [float(v) * MLMIN_PER_M3S for v in np.asarray(a)[:nq]], "chi2": c}
                    for a, c in _alternatives(result, nq)]
    return {
        "parameters": [p.as_dict() for p in result.params],
        "chi2": result.chi2, "dof": result.dof, "p_value": result.p_value, "level": result.level,
        "explained": result.explained, "features": names,
        "features_measured": np.asarray(result.features_measured).tolist(),
        "features_model": np.asarray(result.features_model).tolist(),
        "features_sigma": None if sigma is None else np.asarray(sigma).tolist(),
        "residual": np.asarray(result.residual).tolist(), "alternatives": alternatives,
        "warnings": list(result.warnings),
    }


def _alternatives(result, nq: int):
    """(flows, chi2 or None) of the other fits that pass the test (`nq` flows)."""
    if hasattr(result, "alternatives_chi2"):  # Identification: flows and their chi2 in parallel
        chi2 = result.alternatives_chi2
        return [(a, chi2[j] if j < len(chi2) else None) for j, a in enumerate(result.alternatives)]
    return [(a[0][:nq], a[1]) for a in result.alternatives]  # Fit: (parameter vector, chi2)


def union_interval(*intervals) -> tuple[float, float | None] | None:
    """The smallest interval holding every given one ((low, high or None: open); None entries skipped): the
    flows over several explanations, and never an interval that leaves out its own answer's."""
    given = [iv for iv in intervals if iv is not None]
    if not given:
        return None
    low = min(float(iv[0]) for iv in given)
    high = None if any(iv[1] is None for iv in given) else max(float(iv[1]) for iv in given)
    return low, high


def parameter(params, key: str) -> FitParameter | None:
    """The parameter called `key` (`q1`, `probe_rotation.angle_deg`), None when the result has none."""
    return next((p for p in params if p.key == key), None)


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
    # what an effect reports beyond its parameters (large orbits: the balance's rounds, the 2X ratio, ...)
    effect_details: dict = field(default_factory=dict)
    alternatives_chi2: tuple[float, ...] = field(default=())
    # the flows' 95 % intervals when the oil's viscosity is not known (a free nuisance within x0.75-1.33):
    # a record at one speed without the static position cannot tell a viscosity change from a supply change
    intervals_any_oil: tuple | None = None
    oil_degeneracy: dict = field(default_factory=dict)
    # best mode: 1 sigma of each feature with the model budget (noise + model), what the fit weighs by
    features_sigma: np.ndarray | None = None
    # every parameter, fitted and held (flows first); what every rendering reads (`summary`)
    params: tuple[FitParameter, ...] = ()

    @property
    def path(self) -> np.ndarray:
        """The path of the start that produced the answer."""
        return self.paths[-1]

    @property
    def model_explains_data(self) -> bool | None:
        """Best mode: the fit is consistent with the record's noise and the model budget (p > `level`)."""
        return None if self.p_value is None else self.p_value > self.level

    explained = model_explains_data

    @property
    def effects(self) -> dict:
        """{effect: {parameter: value, parameter_std: std, ...details}} (SPEC §7 `effects`)."""
        out = effect_values(self.params)
        for owner, details in self.effect_details.items():
            out.setdefault(owner, {}).update(details)
        return out

    def verdict(self, k: int) -> str:
        """'starved', 'normal' or 'over-supplied' for bearing k (0-based), relative to Q_T."""
        return lubrication_verdict(self.q[k], self.q_threshold[k])

    def summary(self) -> dict:
        return summary(self)


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
    for k in range(len(measured.nodes)):  # every plane of the record
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
