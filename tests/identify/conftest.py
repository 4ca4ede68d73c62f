"""Fixtures shared by the identification tests, and what the large-orbit test files share
(`test_orbit_fit.py`: the time integration's record; `test_orbit_fit_balance.py`: the balance's records)."""

import pytest

from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.identify.tables import dimensionless
from lubeviz.units import MLMIN_PER_M3S

LARGE_Q = (460.0, 600.0)  # ml/min: the large-orbit records at the machine's unbalance
WEAKER_Q = (480.0, 520.0)  # ml/min: those at 0.6 x the unbalance

# the 5-harmonic balance (what a diagnosis tries; identification's default is 16, tested in test_orbit_fit.py)
FIVE = IdentificationSettings(orbit_harmonics=5)


def inside(interval, q):
    """Whether the flow `q` (ml/min) lies in `interval` (m^3/s; an open upper end is None)."""
    low, high = interval
    return low * MLMIN_PER_M3S <= q <= (float("inf") if high is None else high * MLMIN_PER_M3S)


@pytest.fixture
def builds(monkeypatch):
    """Counts calls of dimensionless.build_slice (the in-process builder the cache uses), by slice S."""
    calls = []
    original = dimensionless.build_slice

    def counting(*args, **kwargs):
        calls.append(args[1])
        return original(*args, **kwargs)

    monkeypatch.setattr(dimensionless, "build_slice", counting)
    return calls
