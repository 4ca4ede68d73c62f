"""The time rounds' loop of the large-orbit identification (`fit_large_orbit(time_rounds=)`) on the time
integration's record of `test_orbit_fit.py` (the `time_record` fixture, `tests/identify/conftest.py`). In a file of
its own so that under `pytest -n auto --dist loadfile` it runs beside that file's two fits (together they held one
worker for ~4 min while the other idled at the end of the run). The gap's conventions: `test_time_rounds.py`."""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.batch import identify_record
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.units import MLMIN_PER_M3S
from tests.identify.conftest import WEAKER_Q, inside

pytestmark = pytest.mark.slow


def test_a_time_round_with_a_better_orbit_model_standing_in_brings_the_five_harmonic_fit_to_it(machine, time_record,
                                                                                                monkeypatch):
    """The time rounds' loop (`fit_large_orbit(time_rounds=)`), with the 16-harmonic balance standing in for the time
    integration (which costs 3-5 min a round): the 5-harmonic fit of the time-integration record (+0.87 / +1.02 %
    measured, `test_orbit_fit.py`) takes the better model's 1X gap to its own at its answer into the correction, held
    constant, and runs its rounds again. The fixed point of that loop is the better model's own answer (-0.23 / +0.30 %
    with 16 harmonics, `test_orbit_fit.py`), so the round must move the flows toward the truth. The stand-in is called
    at the last balance's flows with that balance and its unbalance scale, as `time_gap` is. (A first version on a
    record of the 16-harmonic balance at the paper's unbalance failed in CI: from the 5-harmonic orbit that balance did
    not settle, the round was dropped with a warning; here the orbit is the 0.6 x one, where it settles.)"""
    from lubeviz.identify.fit import large_orbit as orbit_fit
    from lubeviz.identify.fit.large_orbit import SLOPE_MESH, _balance, _with_mesh
    from lubeviz.progress import silent

    rec = time_record.record
    q = np.array(WEAKER_Q)
    calls = []

    def better(chain, ob, scale, revolutions=4, steps=512, progress=silent):
        calls.append((np.asarray(ob.bearings.flows, dtype=float).copy(), scale))
        # the 16-harmonic balance on the model's films, its Newton started from the same balance on coarser films,
        # 30 x 30 then the slopes' 50 x 50: the same orbit as from the 50 x 50 balance alone (the gap agrees to
        # 1.5e-11 of itself), 17 s (6 + 3 + 9) against 40 s (32 + 8) on a quiet machine; that one against 21
        # shortened steps and 174 s from the 5-harmonic orbit directly (measured, one other process on the 2 cores)
        flows = ob.bearings.flows
        rough = _balance(chain, flows, ob, 16, 64, 1e-4, silent, scale=scale, machine=_with_mesh(chain.machine, 30))
        coarse = _balance(chain, flows, rough, 16, 64, 1e-5, silent, scale=scale,
                          machine=_with_mesh(chain.machine, SLOPE_MESH))
        b = _balance(chain, flows, coarse, 16, 64, 1e-5, silent, scale=scale)
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
