"""Time rounds of the large-orbit identification (`identify.fit.large_orbit.time_gap`, `fit_large_orbit(time_rounds=)`).

The time integration itself is too slow for the suite (4-6 min a round at the paper's point); its figures on the
bench's 12 time-integration records are in BENCHMARKS "Time rounds". Here: the gap's conventions on a small orbit
(the time integration at a coarse step). The rounds' loop, with a better orbit model standing in for the time
integration, is tested in `test_orbit_fit_time_round.py` on the time-integration record of `test_orbit_fit.py`."""

import numpy as np
import pytest

from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.identify.fit.large_orbit import _balance, time_gap
from lubeviz.progress import silent
from lubeviz.units import MLMIN_PER_M3S
from tests.memo import integration_memoized

pytestmark = pytest.mark.slow

Q = np.array([460.0, 600.0])  # ml/min: Q1 at 0.84, Q2 at 1.10 of their Q_T (75 Hz), away from the kink


def test_the_time_integration_s_gap_to_a_small_orbit_s_balance_is_its_time_step_error(machine, monkeypatch):
    """`time_gap` integrates the model in time from the balance's orbit and returns the difference of their 1X at
    the planes, per unit of the unbalance's scale. On a small orbit (0.1 x the paper's unbalance) the 16-harmonic
    balance holds every line there is, so the gap is the time step's own error: second order, 0.075 % of the 1X at
    64 steps a revolution and 0.019 % at 128 (measured). A wrong phase convention, node or scale would make it
    tens of %; the integration has settled (its last two revolutions against the two before)."""
    import lubeviz.rotor.film_transient as film_transient

    integration_memoized(monkeypatch, film_transient)  # the integration itself run once and kept (a seed)
    chain = ForwardChain(machine, 75.0, (6, 20))
    scale = 0.1
    ob = _balance(chain, Q / MLMIN_PER_M3S, None, 16, 64, 1e-8, silent, scale=scale)
    (gx, gy, gs), pct, settled = time_gap(chain, ob, scale, revolutions=4, steps=64)
    assert pct.shape == (4,) and np.all(pct < 0.2) and np.all(pct > 0.0)
    assert settled < 0.2
    ones = np.ravel(np.stack([ob.x[1], ob.y[1]], axis=-1))
    np.testing.assert_allclose(100 * np.abs(np.ravel(np.stack([gx, gy], axis=-1)) * scale / ones), pct, rtol=1e-9)
    assert gs.shape == (2, 2) and np.abs(gs).max() < 1e-8  # the 0X at the bearing centres: within 0.01 um

