"""Identification with large orbits declared (issue 11) on a record from the time integration
(`verification.orbit_record`, `method="time"`: every harmonic, the 40-element rotor), the path that does not share
the balance's truncation: the 5- and 16-harmonic balances. The time rounds' loop on the same record:
`test_orbit_fit_time_round.py` (its own file, so that under `pytest -n auto --dist loadfile` the two run side by
side: together they held one worker for ~4 min). The same on the balance's records (200 x 200 films, 6 harmonics),
and the correction's parts: `test_orbit_fit_balance.py`."""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.batch import identify_record
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.units import MLMIN_PER_M3S
from tests.identify.conftest import FIVE, WEAKER_Q, inside

pytestmark = pytest.mark.slow


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
