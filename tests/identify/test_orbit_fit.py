"""Identification with large orbits declared (issue 11) on a record from the time integration
(`verification.orbit_record`, `method="time"`: every harmonic, the 40-element rotor), the path that does not share
the balance's truncation: the 5- and 16-harmonic balances, and the time rounds' loop. The same on the balance's
records (200 x 200 films, 6 harmonics), and the correction's parts: `test_orbit_fit_balance.py`; the two files run
side by side under `pytest -n auto --dist loadfile`."""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.batch import identify_record
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.verification import IndependentSpec
from lubeviz.verification.orbit_record import make_orbit_records
from lubeviz.units import MLMIN_PER_M3S
from tests.identify.conftest import FIVE, WEAKER_Q, inside

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def time_record():
    """The weaker record of `test_orbit_fit_balance.py` (480 / 520 ml/min, 0.6 x the unbalance) again, from the time
    integration (`make_orbit_records(method="time")`: every harmonic, the 40-element rotor; 3-4 min, then cached):
    the path that does not share the balance's truncation. The paper's unbalance from this path is in
    `lubeviz bench coverage --large-orbit` (12 records at 0.5-1 x the unbalance, BENCHMARKS), not here: one more
    record is 4 min of CI. Its 6 revolutions are the fewest the tests below allow: over 4 or 5 the 0.5X line the
    record leaves out is still 1.06 / 0.89 % of 1X (0.51 % over 6), and 256 steps a revolution instead of 512 save
    only 13 % (each film solve then takes more iterations)."""
    return make_orbit_records([
        (IndependentSpec(speed_hz=75.0, q1_mlmin=WEAKER_Q[0], q2_mlmin=WEAKER_Q[1], seed=5), 0.6)], method="time")[0]


def test_on_the_time_integration_s_record_the_intervals_hold_the_flows(machine, time_record):
    """A record along another path than the model's balance: the time integration holds every harmonic (its 2X is
    10-16 % larger than the model's 5-harmonic balance's). With `large_orbit` declared and a 5-harmonic balance
    (what a diagnosis tries) the record is explained, the 95 % intervals hold the flows and they come back within
    about 1 % (measured +0.9 / +1.0 %, bound 1.5 %). At fuller unbalances (bench, 12 records at 0.5-1 x: 5 harmonics
    median 2.4 %, max 10 %, intervals 23 / 24) the balance's truncation (`ModelBudget.orbit_truncation`) makes
    sigma large: the model cannot say more there with 5 harmonics."""
    rec, truth = time_record.record, time_record.truth
    q = np.array(WEAKER_Q)
    # the start's transient has died out (the 1X of the last two revolutions against the two one revolution
    # earlier: 0.4 % measured) and the 0.5X line the periodic record leaves out is small (0.5 % of 1X)
    assert truth["method"] == "time" and truth["periodicity"] < 0.02
    assert truth["half_order"] < 0.05
    assert min(truth["ratio_2x"]) > 0.1
    r = identify_record(rec, machine, FIVE, effects=(parse_effect("large_orbit"),)).result
    err = np.abs(r.q * MLMIN_PER_M3S / q - 1)
    assert r.model_explains_data
    assert all(inside(r.intervals[k], q[k]) for k in range(2))
    assert err.max() < 0.015
    info = r.effects["large_orbit"]
    assert info["unbalance_scale"] == pytest.approx(0.6, rel=0.06)
    model, source = np.asarray(info["ratio_2x_model"]), np.asarray(truth["ratio_2x"])
    assert np.all(np.abs(model / source - 1) < 0.2)


def test_with_16_harmonics_the_flows_come_within_1_percent_on_the_time_integration_s_record(machine, time_record):
    """Issue 11's 1 % on records along another path: identification's default balance, 16 harmonics and 64 points
    (`IdentificationSettings.orbit_harmonics`), follows the film's sharp turn where it is thinnest. At 0.6 x the
    unbalance measured -0.23 / +0.30 % (5 harmonics: +0.87 / +1.02 %), chi2 0.30, the 2X within 2-3 % of the record's
    (5 harmonics: 10-14 % short), 73 s; at the paper's unbalance -0.02 / +0.20 % (5 harmonics: +4.0 / +0.3 %), 107 s
    (not run here: CI time, BENCHMARKS)."""
    assert IdentificationSettings().orbit_harmonics == 16
    rec, truth = time_record.record, time_record.truth
    q = np.array(WEAKER_Q)
    r = identify_record(rec, machine, effects=(parse_effect("large_orbit"),)).result
    assert r.effects["large_orbit"]["harmonics"] == 16
    err = np.abs(r.q * MLMIN_PER_M3S / q - 1)
    assert err.max() < 0.01
    assert r.model_explains_data and all(inside(r.intervals[k], q[k]) for k in range(2))
    for k in range(2):  # the +- shown claims no more than the intervals
        lo, hi = r.intervals[k]
        assert 1.96 * r.q_std[k] >= 0.999 * max(r.q[k] - lo, hi - r.q[k])
    model, source = np.asarray(r.effects["large_orbit"]["ratio_2x_model"]), np.asarray(truth["ratio_2x"])
    assert np.all(np.abs(model / source - 1) < 0.06)
    # the orbit at the answer is stable: its half-order multiplier (Hill, -0.66 measured) is far from -1, as the
    # source's 0.5X line, 0.5 % of 1X two revolutions after its start, says
    stab = r.effects["large_orbit"]["orbit_stability"]
    assert stab["state"] == "stable" and -0.8 < stab["half_order_multiplier"] < -0.5
    assert truth["half_order"] < 0.01


def test_a_time_round_with_a_better_orbit_model_standing_in_brings_the_five_harmonic_fit_to_it(machine, time_record,
                                                                                                monkeypatch):
    """The time rounds' loop (`fit_large_orbit(time_rounds=)`), with the 16-harmonic balance standing in for the time
    integration (which costs 3-5 min a round): the 5-harmonic fit of the time-integration record (+0.87 / +1.02 %
    measured, above) takes the better model's 1X gap to its own at its answer into the correction, held constant,
    and runs its rounds again. The fixed point of that loop is the better model's own answer (-0.23 / +0.30 % with
    16 harmonics, above), so the round must move the flows toward the truth. The stand-in is called at the last
    balance's flows with that balance and its unbalance scale, as `time_gap` is. (A first version on a record of the
    16-harmonic balance at the paper's unbalance failed in CI: from the 5-harmonic orbit that balance did not settle,
    the round was dropped with a warning; here the orbit is the 0.6 x one, where it settles.)"""
    from lubeviz.identify.fit import large_orbit as orbit_fit
    from lubeviz.identify.fit.large_orbit import SLOPE_MESH, _balance, _with_mesh
    from lubeviz.progress import silent

    rec = time_record.record
    q = np.array(WEAKER_Q)
    calls = []

    def better(chain, ob, scale, revolutions=4, steps=512, progress=silent):
        calls.append((np.asarray(ob.bearings.flows, dtype=float).copy(), scale))
        # the 16-harmonic balance on the model's films, its Newton started from the same balance on the slopes'
        # coarser films: the same orbit (the gap agrees to 5e-8 of itself) in 4 steps after 15 there, 47 s, against
        # 21 shortened steps and 174 s from the 5-harmonic orbit (measured, one other process on the 2 cores)
        coarse = _balance(chain, ob.bearings.flows, ob, 16, 64, 1e-5, silent, scale=scale,
                          machine=_with_mesh(chain.machine, SLOPE_MESH))
        b = _balance(chain, ob.bearings.flows, coarse, 16, 64, 1e-8, silent, scale=scale)
        gs = np.zeros((2, 2))
        for k in chain.static_planes:
            gs[k] = b.x[0, k].real - ob.x[0, k].real, b.y[0, k].real - ob.y[0, k].real
        one = np.ravel(np.stack([ob.x[1], ob.y[1]], axis=-1))
        pct = 100 * np.abs(np.ravel(np.stack([b.x[1], b.y[1]], axis=-1)) / one - 1)
        return ((b.x[1] - ob.x[1]) / scale, (b.y[1] - ob.y[1]) / scale, gs), pct, 0.0

    monkeypatch.setattr(orbit_fit, "time_gap", better)
    # Q2's answer lies 3.6 % below Q_T, inside KINK_BAND: the round would also run across the kink from 3.6 % above
    # it (measured: the test passed so, in twice the time, 17 min against 8 on a loaded machine; that branch is
    # measured on the bench, record 5 of BENCHMARKS "Time rounds"). Here the loop alone: the band narrowed so
    # that no flow is near the kink.
    monkeypatch.setattr(orbit_fit, "KINK_BAND", 0.03)
    r = identify_record(rec, machine, IdentificationSettings(orbit_harmonics=5, orbit_time_rounds=1),
                        effects=(parse_effect("large_orbit"),)).result
    assert not [w for w in r.warnings if "time round" in w], r.warnings
    rounds = r.effects["large_orbit"]["time_rounds"]
    assert len(rounds) == 1 and len(calls) == 1 and not rounds[0]["not_kept"]
    kept = rounds[0]
    # the gap is taken at the last balance's flows (the 5-harmonic answer, within the rounds' tolerance)
    np.testing.assert_allclose(np.asarray(kept["flows_at_mlmin"]) / MLMIN_PER_M3S, calls[0][0], rtol=1e-12)
    before = np.abs(np.asarray(kept["flows_at_mlmin"]) / q - 1)
    after = np.abs(r.q * MLMIN_PER_M3S / q - 1)
    assert before.max() > 0.006  # the 5-harmonic answer's truncation
    assert after.max() < 0.6 * before.max() and after.max() < 0.006
    assert 0.5 < max(kept["gap_1x_percent"]) < 10.0  # the truncation in the 1X: a few %, not a convention's 100 %
    assert kept["consistent"] and r.model_explains_data
    assert all(inside(r.intervals[k], q[k]) for k in range(2))
    # the time rounds' own intervals are reported (for the bench's coverage) and the answer's hold them
    own = r.effects["large_orbit"]["time_round_intervals_mlmin"]
    assert len(own) == 2
    for k, (lo, hi) in enumerate(own):
        hi = np.inf if hi is None else hi
        shown_hi = np.inf if r.intervals[k][1] is None else r.intervals[k][1] * MLMIN_PER_M3S
        assert lo <= r.q[k] * MLMIN_PER_M3S <= hi
        assert r.intervals[k][0] * MLMIN_PER_M3S <= lo * (1 + 1e-12) and hi <= shown_hi * (1 + 1e-12)
