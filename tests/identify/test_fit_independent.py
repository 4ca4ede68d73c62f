"""The fit on records made along another path than the model (lubeviz.verification: 200x200 uniform film
with fixed-pattern coefficients, 40-element rotor, other shaft damping, time integration from rest).

A small seeded subset runs here; the rates over >= 100 records are `lubeviz bench coverage`.
"""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.batch import identify_record
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.verification import IndependentSpec, clean_corpus, make_record
from lubeviz.units import MLMIN_PER_M3S

pytestmark = pytest.mark.slow


def _errors(result, spec):
    q = np.array([spec.q1_mlmin, spec.q2_mlmin])
    return 100 * (result.q * MLMIN_PER_M3S / q - 1), q


def _holds(result, q):
    out = []
    for k in range(2):
        low, high = result.intervals[k]
        out.append(low * MLMIN_PER_M3S <= q[k] <= (np.inf if high is None else high * MLMIN_PER_M3S))
    return out


@pytest.fixture(scope="module")
def clean_records():
    specs = clean_corpus(8, np.random.default_rng(11), total_s=8.0)
    return [(s, make_record(s).record) for s in specs]


def test_clean_independent_records_are_explained_and_their_intervals_hold(machine, clean_records):
    flagged, held, errors = 0, [], []
    flagged_noise_only = 0
    for spec, rec in clean_records:
        r = identify_record(rec, machine).result
        err, q = _errors(r, spec)
        errors.append(np.abs(err).max())
        held.extend(_holds(r, q))
        flagged += not r.model_explains_data
        for k, (low, high) in enumerate(r.intervals):  # the +- shown claims no more than the interval
            if high is not None:
                assert 1.96 * r.q_std[k] >= 0.999 * max(r.q[k] - low, high - r.q[k]), (spec, k)
        noise_only = IdentificationSettings(include_model_error=False)  # the app's switch: ModelBudget.none()
        flagged_noise_only += not identify_record(rec, machine, noise_only).result.model_explains_data
    assert flagged <= 1, f"{flagged} of {len(clean_records)} clean records flagged"
    assert np.mean(held) >= 0.8, f"intervals hold the true flows on {np.mean(held):.0%}"
    assert np.median(errors) < 1.5
    # the noise alone flags clean records: the budget is what makes the test usable
    assert flagged_noise_only >= flagged + 2


@pytest.mark.parametrize("spec_text", [
    "probe_rotation:plane=1,angle_deg=6",
    "probe_gain:channel=y2,gain=1.15",
    "unbalance2:node=15,ratio=0.5,phase_deg=90",
    "pedestals:bearing=2,mass_kg=50,stiffness_n_m=1e8,damping_ns_m=1e4",
    "bow:node=13,amplitude_um=60,phase_deg=45",
    "viscosity:factor=0.75",  # hotter oil: the plain fit is ~20 % low and yet explained (one speed)
    "clearance:bearing=1,clearance_um=165",  # a worn bearing 1 (x1.375): plain Q1 ~46 % low
])
def test_a_declared_effect_recovers_the_flows_on_independent_records(machine, spec_text):
    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=480.0, q2_mlmin=600.0, effects=(spec_text,), seed=5, total_s=8.0)
    rec = make_record(spec).record
    plain = identify_record(rec, machine).result
    known = identify_record(rec, machine, effects=(parse_effect(spec_text),)).result
    err_plain, q = _errors(plain, spec)
    err_known, _ = _errors(known, spec)
    assert np.abs(err_known).max() < 1.0, (spec_text, err_known)
    assert known.model_explains_data
    # the plain model is biased or flags the record: the effect matters at this strength
    assert np.abs(err_plain).max() > 1.0 or not plain.model_explains_data


@pytest.mark.parametrize("spec_text, free, value", [
    ("probe_rotation:plane=1,angle_deg=6", "probe_rotation:plane=1", 6.0),
    ("probe_gain:channel=y2,gain=1.15", "probe_gain:channel=y2", 1.15),
    ("pedestals:bearing=2,mass_kg=50,stiffness_n_m=1e8,damping_ns_m=1e4",
     "pedestals:bearing=2,mass_kg=50,damping_ns_m=1e4", 1e8),
])
def test_an_effect_with_a_free_parameter_is_identified_with_the_flows(machine, spec_text, free, value):
    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=520.0, q2_mlmin=560.0, effects=(spec_text,), seed=8, total_s=8.0)
    rec = make_record(spec).record
    r = identify_record(rec, machine, effects=(parse_effect(free),)).result
    err, _ = _errors(r, spec)
    assert np.abs(err).max() < 1.0
    (name, params), = r.effects.items()
    pname = next(p for p in params if not p.endswith("_std") and p in parse_effect(free).free)
    assert abs(params[pname] - value) < max(3 * params[pname + "_std"], 0.05 * abs(value))


def test_the_wrong_root_at_57_5_hz_is_not_presented_as_the_answer(machine):
    """Issue 15: a clean record at 57.5 Hz, 135 / 128 % Q_T, was identified at -42 / -38 % with +-3.5 ml/min."""
    spec = IndependentSpec(speed_hz=57.5, q1_mlmin=705.0, q2_mlmin=666.0, seed=3)
    r = identify_record(make_record(spec).record, machine).result
    err, q = _errors(r, spec)
    near = np.abs(err).max() < 10.0
    among_alternatives = any(np.all(np.abs(a * MLMIN_PER_M3S / q - 1) < 0.1) for a in r.alternatives)
    assert near or among_alternatives
    assert all(_holds(r, q))
