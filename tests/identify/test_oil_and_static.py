"""Oil hotter than declared mimics less oil: what separates them (issue 11 and 15), on independent records.

One record at one speed cannot tell a viscosity change from a supply change; the static shaft position
(SPEC §6 `static: absolute`) and records at several speeds (`set:`) can. Records from
`lubeviz.verification` (another film mesh and linearization, another rotor, time integration).
"""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.batch import identify_set, identify_record
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.verification import IndependentSpec, make_record, make_set
from lubeviz.units import MLMIN_PER_M3S

pytestmark = pytest.mark.slow

Q = (480.0, 600.0)


def _inside(interval, q):
    low, high = interval
    return low * MLMIN_PER_M3S <= q <= (np.inf if high is None else high * MLMIN_PER_M3S)


def test_hot_oil_at_one_speed_is_never_a_confident_wrong_answer(machine):
    """Issue 15: 20 % thinner oil at 75 Hz, no static position: the flows come out ~17 % low and the
    record is explained; the answer must say that the oil is not pinned, with intervals that hold."""
    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=500.0, q2_mlmin=560.0, effects=("viscosity:factor=0.8",), seed=3)
    rec = make_record(spec).record
    quiet = identify_record(rec, machine, IdentificationSettings(oil_check="never")).result
    assert not any("viscosity" in w for w in quiet.warnings)
    r = identify_record(rec, machine, IdentificationSettings(oil_check="always")).result
    q = (spec.q1_mlmin, spec.q2_mlmin)
    assert np.all(r.q * MLMIN_PER_M3S < 0.9 * np.array(q))  # the degeneracy is real
    assert not r.model_explains_data or all(_inside(r.intervals_any_oil[k], q[k]) for k in range(2))
    assert any("viscosity" in w for w in r.warnings)
    assert r.oil_degeneracy["correlation_q1"] < -0.9  # thinner oil reads as less oil


@pytest.mark.parametrize("seed", [1, 2])
def test_the_static_position_separates_hot_oil_from_less_oil(machine, seed):
    """Issue 11: oil 25 % less viscous, (Q1, Q2, mu) from one record with the static position."""
    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=Q[0], q2_mlmin=Q[1], effects=("viscosity:factor=0.75",),
                           static=True, seed=seed)
    rec = make_record(spec).record
    assert rec.static_offset is not None
    plain = identify_record(rec, machine).result
    assert not plain.model_explains_data  # the static position contradicts the plain model
    r = identify_record(rec, machine, effects=(parse_effect("viscosity:bearing=both"),)).result
    err = r.q * MLMIN_PER_M3S / np.array(Q) - 1
    factor = r.effects["viscosity"]["factor"]
    # measured: flows -1.8 / -1.7 % and -1.4 / -1.1 %, factor 0.765 and 0.760 (BENCHMARKS "oil and static");
    # issue 11: within 2 %
    assert np.abs(err).max() < 0.02
    assert abs(factor / 0.75 - 1) < 0.05
    assert r.model_explains_data
    assert all(_inside(r.intervals[k], Q[k]) for k in range(2))


def test_a_set_at_three_speeds_pins_the_oil_from_the_dynamic_part_alone(machine):
    """Issue 11: a coast-down set (60, 75, 90 Hz), oil 25 % less viscous, no static position."""
    specs = [IndependentSpec(speed_hz=s, q1_mlmin=Q[0], q2_mlmin=Q[1], effects=("viscosity:factor=0.75",),
                             seed=10 + k) for k, s in enumerate((60.0, 75.0, 90.0))]
    records = [x.record for x in make_set(specs, "coast")]
    plain = identify_set(records, machine).result
    assert not plain.model_explains_data
    r = identify_set(records, machine, effects=(parse_effect("viscosity:bearing=both"),)).result
    err = r.q * MLMIN_PER_M3S / np.array(Q) - 1
    assert np.abs(err).max() < 0.02
    assert abs(r.effects["viscosity"]["factor"] / 0.75 - 1) < 0.05
    assert r.model_explains_data


def test_an_oil_temperature_reading_separates_hot_oil_from_less_oil(machine, tmp_path):
    """One record, one speed, no static position: oil at 45 °C instead of the declared 38.3 °C (VG 100:
    x0.71). Without the reading the flows come out ~20 % low; with the record's `oil_temperature_c` the
    viscosity is settled (the reading's 1 K uncertainty in the budget) and the flows come back."""
    import dataclasses

    from lubeviz.model.machine import DEFAULT_MACHINE, load_machine

    t = 45.0
    factor = float(machine.oil.factor(t))
    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=Q[0], q2_mlmin=Q[1], effects=(f"viscosity:factor={factor!r}",),
                           seed=11)
    rec = make_record(spec).record
    plain = identify_record(rec, machine, IdentificationSettings(oil_check="never")).result
    assert np.all(plain.q * MLMIN_PER_M3S < 0.85 * np.array(Q))
    read = dataclasses.replace(rec, oil_temperature_c=t)
    r = identify_record(read, machine).result
    assert np.all(np.abs(r.q * MLMIN_PER_M3S / np.array(Q) - 1) < 0.03), r.q * MLMIN_PER_M3S
    assert all(_inside(r.intervals[k], Q[k]) for k in range(2))
    assert r.effects["oil_temperature"]["temperature_c"] == t
    assert not any("viscosity" in w for w in r.warnings)  # no oil-check warning: the oil is known
    # the budget carries the reading's uncertainty (1 K) as a viscosity tolerance: |d ln mu/dT| ~ 4-5 %/K
    from lubeviz.identify.fit.oil_reading import oil_reading

    effects, tolerance, notes = oil_reading(read, machine)
    assert 0.03 < tolerance < 0.06 and not notes and effects[0].temperature_c == t
    # a machine without an [oil] cannot use the reading, and says so
    text = DEFAULT_MACHINE.read_text()
    bare = tmp_path / "bare.toml"
    bare.write_text(text[:text.index("[oil]")] + text[text.index("[measurement]"):])
    r = identify_record(read, load_machine(bare), IdentificationSettings(oil_check="never")).result
    assert any("oil_temperature_c = 45 °C not used" in w for w in r.warnings)
    assert np.all(r.q * MLMIN_PER_M3S < 0.85 * np.array(Q))
