"""Is the record physically possible for this machine as declared? Findings with their likely cause.

The identification's features are amplitude ratios and angles (SPEC §1: fb, phi, Zf2/Zf1), so a record in
the wrong units or with copied channels can still give flows and a chi^2 that passes. Two checks that
the features cannot make:
- channels: two channels that are the same signal (exactly, up to sign or scale) cannot come from two
  probes, whose noise is independent: a copied column or a wiring fault;
- amplitude: at a plane in a bearing's centre the journal's orbit cannot exceed the bearing's radial
  clearance (it would cut through the bearing); and the record's 1X, against the model's response to its
  declared unbalance at the flows found, should lie within the range real unbalances span. Outside it
  and one unit slip (mm for um, um for mils...) brings it back, that slip is named; a plane alone off by a
  unit factor is named as that plane's units.
A finding is `impossible` (the record cannot be what it says) or only suspicious; either way the flows
rest on ratios only, and a diagnosis leads with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...units import length_factor

# The 1X orbit against the model's response to the declared unbalance: real machines are balanced to
# grades roughly 30x apart either way of a typical declared unbalance, so a ratio beyond this is suspicious.
UNBALANCE_SPAN = 30.0
IDENTICAL_RTOL = 1e-6  # two channels closer than this (relative rms of the difference) are one signal
UNIT_NAMES = ("m", "mm", "um", "mils")


# findings that make the record's features describe the measurement, not the machine: a diagnosis fits no
# effect to such a record (an effect would "explain" the fault) and asks for the record to be corrected
MEASUREMENT_FAULTS = ("copied_channels", "plane_scale")


@dataclass(frozen=True)
class Finding:
    """One thing about a record that is impossible or suspicious for the machine as declared."""

    kind: str  # "copied_channels", "orbit_exceeds_clearance", "amplitude_scale", "plane_scale"
    text: str  # for a person: what, where, and the likely cause
    impossible: bool  # the record cannot be what it says (vs. unusual)

    @property
    def fault(self) -> bool:
        """The features describe the measurement, not the machine (`MEASUREMENT_FAULTS`)."""
        return self.kind in MEASUREMENT_FAULTS

    def as_dict(self) -> dict:
        return {"kind": self.kind, "text": self.text, "impossible": self.impossible}


def record_findings(record, measured, chain) -> tuple[Finding, ...]:
    """Every finding on `record` (its `MeasuredFeatures` `measured`), the model being `chain` at its start (the
    flows at the bearings' flooded thresholds, the declared unbalance): what identify and diagnose report."""
    copied = channel_findings(record)
    if copied:  # the orbit of that plane is not the shaft's: its amplitude says nothing more
        return tuple(copied)
    return tuple(amplitude_findings(record, measured, chain, chain.start()))


def channel_findings(record) -> list[Finding]:
    """Channels of `record` that are one signal: a copy (up to sign or a scale) of another channel."""
    d = np.asarray(record.displacement, dtype=float)
    names = [f"{axis}{k + 1}" for k in range(d.shape[0]) for axis in "xy"]  # the record's columns, plane by plane
    d = d.reshape(len(names), -1)
    d = d - d.mean(axis=1, keepdims=True)
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            a, b = d[i], d[j]
            bb = float(b @ b)
            if bb <= 0.0 or float(a @ a) <= 0.0:
                continue
            s = float(a @ b) / bb
            rel = math.sqrt(float(np.mean((a - s * b) ** 2)) / float(np.mean(a ** 2)))
            if rel < IDENTICAL_RTOL:
                how = "the same signal" if abs(s - 1) < 1e-6 else (
                    "the same signal with its sign reversed" if abs(s + 1) < 1e-6 else f"the same signal x {s:.4g}")
                out.append(Finding("copied_channels",
                                   f"{_where(record)}channels {names[i]} and {names[j]} are {how}: two probes cannot "
                                   "read identical noise, so a column was copied or two channels are wired to one "
                                   "probe; the orbit of that plane is not the shaft's, and no flow or effect found "
                                   "from it can be trusted", True))
    return out


def amplitude_findings(record, measured, chain, theta) -> list[Finding]:
    """The record's 1X orbits against the bearings' clearances and the model's response at `theta` (the
    chain's declared unbalance; the flows move it far less than the span checked). `measured`: the record's
    `MeasuredFeatures`."""
    units = getattr(record, "units", None)
    major = _semi_major(measured.x, measured.y)
    out = chain.output(np.asarray(theta, dtype=float))
    model = _semi_major(np.asarray(out.x), np.asarray(out.y))
    bearing_at = {b.node: b for b in chain.machine.bearings}
    findings = []
    ratio = major / model
    for k, node in enumerate(measured.nodes):
        b = bearing_at.get(node)
        if b is not None and major[k] > b.clearance:
            cause = _unit_cause(ratio[k], units) or ("the probes' scale factor, the units or the planes' nodes "
                                                     "(is the plane really in the bearing?)")
            findings.append(Finding(
                "orbit_exceeds_clearance",
                f"{_where(record)}plane {k + 1} (node {node}) orbits {major[k] * 1e6:.4g} um (1X, half the major "
                f"axis), more than {b.name}'s radial clearance {b.clearance * 1e6:.4g} um: the journal cannot "
                f"move that far in its bearing. Likely cause: {cause}", True))
    if findings:
        return findings
    if len(ratio) > 1:  # one plane off by a unit factor against the others (e.g. its columns in mm, declared um)
        k = int(np.argmax(np.abs(np.log(ratio))))
        others = np.delete(ratio, k)
        rel = ratio[k] / math.exp(float(np.mean(np.log(others))))
        cause = _unit_cause(rel, units, plane=k + 1)
        if cause and abs(math.log(rel)) > 0.5 * math.log(UNBALANCE_SPAN):
            return [Finding("plane_scale", f"{_where(record)}plane {k + 1}'s 1X orbit is {_times(rel)} what the model "
                            f"expects relative to the other plane{'s' if len(others) > 1 else ''}, a unit's factor "
                            f"that no machine effect makes. Likely cause: {cause}", True)]
    whole = math.exp(float(np.mean(np.log(ratio))))
    if not 1 / UNBALANCE_SPAN <= whole <= UNBALANCE_SPAN:
        cause = _unit_cause(whole, units)
        findings.append(Finding(
            "amplitude_scale",
            f"{_where(record)}the 1X orbit is {_times(whole)} the model's response to the declared unbalance "
            f"with the bearings fed at their flooded thresholds (real unbalances span about {UNBALANCE_SPAN:g}x either way). Likely cause: "
            f"{cause or 'the units, the probes scale factor, or an unbalance far from the declared one'}",
            False))
    return findings


def _semi_major(x, y) -> np.ndarray:
    """Half the major axis of each plane's 1X ellipse: |Zf| + |Zb| (SPEC §1)."""
    x, y = np.asarray(x), np.asarray(y)
    return np.abs(0.5 * (x + 1j * y)) + np.abs(0.5 * (x - 1j * y))


def _unit_cause(ratio: float, declared: str | None, plane: int | None = None) -> str:
    """The unit slip that brings an amplitude `ratio` (record / expected) closest to 1, when one brings it
    within the unbalance span and does better than the declared units; '' otherwise."""
    best, best_err = None, abs(math.log(ratio))
    pairs = ([(declared, u) for u in UNIT_NAMES if u != declared] if declared else
             [(a, b) for a in UNIT_NAMES for b in UNIT_NAMES if a != b])
    for said, real in pairs:
        r = ratio * length_factor(real) / length_factor(said)
        err = abs(math.log(r))
        if err < best_err - math.log(3.0) and err < math.log(UNBALANCE_SPAN):
            best, best_err = (said, real), err
    if best is None:
        return ""
    said, real = best
    where = f"plane {plane}'s columns" if plane else "the readings"
    return f"{where} look like {real} declared as {said}: check the record's units field"


def _times(r: float) -> str:
    return f"{r:.3g} times" if r >= 1 else f"1/{1 / r:.3g} of"


def _where(record) -> str:
    src = getattr(record, "source", None)
    return f"{src}: " if src else ""
