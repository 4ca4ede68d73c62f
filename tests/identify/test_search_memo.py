"""The global search is not made twice for the same record, box and model (SEARCH_MEMO): a diagnosis's candidates
that start where they change nothing (a probe gain of 1) would search the flows exactly as the plain fit did (their
basins are picked again with their own dof's limit). A candidate that changes the model at its start (a pedestal)
searches afresh; the memo changes no answer."""

import numpy as np
import pytest

import lubeviz.identify.fit.least_squares as LS
from lubeviz.effects import parse_effect
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.identify.forward.measured import measure


@pytest.fixture(scope="module")
def record(machine):
    chain = ForwardChain(machine, 75.0, (6, 20))
    theta = chain.start()
    theta[:2] = chain.q_threshold * np.array([0.8, 1.1])
    return chain, measure(simulate(chain, theta, snr_db=12.0, rng=np.random.default_rng(3)))


def _counting(monkeypatch):
    """The searches that evaluate their lattices (a remembered one is given its costs)."""
    calls = []
    real = LS._search_starts

    def spy(*a, costs=None, **k):
        if costs is None:
            calls.append(1)
        return real(*a, costs=costs, **k)

    monkeypatch.setattr(LS, "_search_starts", spy)
    return calls


def test_a_candidate_neutral_at_its_start_reuses_the_plain_search_and_fits_alike(record, monkeypatch):
    chain, meas = record
    calls = _counting(monkeypatch)
    LS._SEARCHES.clear()
    plain = LS.fit(chain, meas, intervals=False)
    gain = chain.adding(parse_effect("probe_gain:channel=x1,gain=1").candidate())
    memo = LS.fit(gain, meas, intervals=False)
    assert memo.explained  # so its gain is searched from 1 alone (Effect.search_values: only when unexplained)
    assert len(calls) == 1  # the candidate's search was the plain one's
    LS._SEARCHES.clear()
    fresh = LS.fit(gain, meas, intervals=False)
    assert len(calls) == 2
    np.testing.assert_array_equal(memo.values, fresh.values)
    assert memo.chi2 == fresh.chi2 and plain.chi2 >= memo.chi2 - 1e-9


def test_a_candidate_that_changes_the_model_at_its_start_searches_afresh(record, monkeypatch):
    chain, meas = record
    calls = _counting(monkeypatch)
    LS._SEARCHES.clear()
    LS.fit(chain, meas, intervals=False)
    LS.fit(chain.adding(parse_effect("pedestals:bearing=1,mass_kg=50,stiffness_n_m=2e8").candidate()), meas,
           intervals=False)
    assert len(calls) == 2
