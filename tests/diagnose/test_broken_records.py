"""Broken records (issue 34): a mix-up of channels or planes is named and corrected, a copied channel or a
plane in other units is a measurement fault (no effect is fitted to it), impossible amplitudes are named
with their likely unit slip, mains pickup is named as pickup, and no verdict says "explains" when its result
does not. The records are the independent source's (`lubeviz.verification`), their columns then mixed up
as a person or a cable would: a transform of the measurement, not the identification's model."""

import dataclasses
import math

import numpy as np
import pytest

from lubeviz.diagnose import diagnosis_dict, run_diagnosis
from lubeviz.identify.batch import identify_record
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification import IndependentSpec, make_record
from tests.records import record_from_arrays

pytestmark = pytest.mark.slow

Q = (450.0, 600.0)


@pytest.fixture(scope="module")
def columns():
    """The independent source's clean record at Q: its four columns (m), speed and rate."""
    rec = make_record(IndependentSpec(speed_hz=75.0, q1_mlmin=Q[0], q2_mlmin=Q[1], seed=5, total_s=8.0)).record
    return rec.displacement.reshape(4, -1).copy(), rec.speed_hz, rec.sample_rate_hz


def _record(cols, speed, rate, *, units="m", scale=1.0, source="broken.csv"):
    """A record of `cols` (metres) written in `units` (values x `scale` more than those units say)."""
    from lubeviz.units import length_factor

    values = np.asarray(cols) / length_factor(units) * scale
    return dataclasses.replace(record_from_arrays(*values, speed_hz=speed, sample_rate_hz=rate, units=units),
                               source=source)


def _diagnose(machine, rec):
    return run_diagnosis([rec], machine).diagnosis  # the CLI's and the page's pipeline


def _consistent(d):
    """The verdict says what the result is: never 'explains' or 'Explained' when the result is not explained;
    an added effect's refined fit is the outcome."""
    if not d.explained:
        assert " explains the record" not in d.verdict and "Explained:" not in d.verdict, d.verdict
    if d.added is not None:
        assert d.after is not None and bool(d.after.explained) == d.explained
    out = diagnosis_dict(d)
    assert out["explained"] == d.explained


def _errors(fit):
    return np.abs(fit.values[:2] * MLMIN_PER_M3S / np.array(Q) - 1) * 100


@pytest.mark.parametrize("mix, fault", [
    ((2, 3, 0, 1), "planes_swapped"),  # the planes' columns (or node numbers) exchanged
    ((1, 0, 2, 3), "x1_y1_swapped"),  # plane 1's probes exchanged
])
def test_a_channel_mix_up_is_named_and_the_flows_come_back(machine, columns, mix, fault):
    cols, speed, rate = columns
    d = _diagnose(machine, _record(cols[list(mix)], speed, rate))
    _consistent(d)
    assert not d.before.explained  # the mix-up shows
    assert d.added is not None and d.added.label == f"wiring[fault={fault}]" and not d.ambiguous
    assert d.explained and _errors(d.after).max() < 1.0
    assert d.outcome == "effect added"


def test_a_reversed_probe_is_named(machine, columns):
    cols, speed, rate = columns
    flipped = cols.copy()
    flipped[2] *= -1  # x2 reads the gap, not the displacement
    d = _diagnose(machine, _record(flipped, speed, rate))
    _consistent(d)
    assert d.added is not None and d.added.label == "wiring[fault=x2_inverted]" and d.explained
    assert _errors(d.after).max() < 1.0


def test_a_copied_channel_is_a_measurement_fault_not_an_explained_effect(machine, columns):
    cols, speed, rate = columns
    copied = cols.copy()
    copied[0] = copied[1]  # x1 is a copy of y1
    d = _diagnose(machine, _record(copied, speed, rate))
    _consistent(d)
    assert not d.explained and d.added is None and not d.candidates
    assert d.outcome == "measurement fault"
    assert d.verdict.startswith("Measurement fault") and "x1 and y1" in d.verdict
    assert [f["kind"] for f in diagnosis_dict(d)["record_findings"]] == ["copied_channels"]


def test_a_plane_in_other_units_is_a_measurement_fault_named_with_its_units(machine, columns):
    cols, speed, rate = columns
    values = cols / 1e-6  # um
    values[:2] *= 1e-3  # plane 1 written in mm, the file saying um
    rec = record_from_arrays(*values, speed_hz=speed, sample_rate_hz=rate, units="um")
    d = _diagnose(machine, rec)
    _consistent(d)
    assert not d.explained and d.added is None
    assert "plane 1" in d.verdict and "mm declared as um" in d.verdict


def test_impossible_and_implausible_amplitudes_name_the_unit_slip(machine, columns):
    """Identify's warnings (the same findings a diagnosis leads with): the flows stay (ratios), the scale
    is named."""
    cols, speed, rate = columns
    cases = [
        # values in metres, the file saying um: the orbit a million times smaller than any unbalance makes
        (record_from_arrays(*cols, speed_hz=speed, sample_rate_hz=rate, units="um"), "m declared as um", False),
        # values in um, the file saying mils: the orbit 25.4 x larger, beyond the bearings' clearance
        (record_from_arrays(*(cols / 1e-6), speed_hz=speed, sample_rate_hz=rate, units="mils"),
         "um declared as mils", True),
        # the same orbit 30 x larger, in the units declared: beyond the clearance, no unit explains it
        (record_from_arrays(*(30 * cols), speed_hz=speed, sample_rate_hz=rate, units="m"),
         "scale factor", True),
    ]
    for rec, cause, impossible in cases:
        out = identify_record(rec, machine)
        assert out.findings and all(f.impossible == impossible for f in out.findings), out.findings
        assert any(cause in w for w in out.warnings), out.warnings
        assert _errors_of(out).max() < 1.5  # amplitude ratios: the flows hold


def _errors_of(out):
    return np.abs(np.asarray(out.result.q) * MLMIN_PER_M3S / np.array(Q) - 1) * 100


def test_a_clean_record_has_no_finding_and_a_consistent_verdict(machine, columns):
    cols, speed, rate = columns
    d = _diagnose(machine, _record(cols, speed, rate))
    _consistent(d)
    assert d.explained and not d.findings and d.outcome == "explained"


def test_mains_hum_is_named_as_pickup_not_oil_whirl(machine, columns):
    cols, speed, rate = columns
    t = np.arange(cols.shape[1]) / rate
    hum = 6e-6 * np.sin(2 * math.pi * 50.0 * t + 0.4) + 2e-6 * np.sin(2 * math.pi * 100.0 * t)
    d = _diagnose(machine, _record(cols + hum, speed, rate))
    _consistent(d)
    assert "mains" in d.verdict and "pickup" in d.verdict
    assert "whirl" not in d.verdict.split("pickup")[0] and d.stability is None  # no whirl reading of it
    assert _errors(d.final).max() < 1.0
