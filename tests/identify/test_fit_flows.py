"""`Fit.flow_values` and `flow_stds` read every bearing's flow, as many as the fit has, whether or not the search kept
its `flows` (a fit made by a refinement that does not, e.g. a large-orbit round): no machine is assumed to have two."""

import numpy as np

from lubeviz.identify.fit.least_squares import Fit


def _fit(names, values, std, flows=None):
    n = len(names)
    z = np.zeros(1)
    return Fit(names=tuple(names), values=np.asarray(values, float), std=np.asarray(std, float), cov=np.eye(n),
               chi2=1.0, dof=1, p_value=0.3, level=0.01, aic=0.0, bic=0.0, status=0, at_bound=(), evaluations=1,
               iterations=1, seconds=0.0, features_names=("a",), features_measured=z, features_model=z, residual=z,
               intervals={}, flows=flows)


def test_every_fitted_flow_is_read_without_the_search_s_flows():
    f = _fit(["q1", "q2", "q3", "gain"], [1e-5, 2e-5, 3e-5, 1.1], [1e-7, 2e-7, 3e-7, 0.01])
    np.testing.assert_array_equal(f.flow_values(), [1e-5, 2e-5, 3e-5])
    np.testing.assert_array_equal(f.flow_stds(), [1e-7, 2e-7, 3e-7])


def test_a_held_flow_comes_from_the_search_s_flows_with_no_std():
    f = _fit(["q1", "q3"], [1e-5, 3e-5], [1e-7, 3e-7], flows=np.array([0.9e-5, 2e-5, 2.9e-5]))
    np.testing.assert_array_equal(f.flow_values(), [1e-5, 2e-5, 3e-5])  # fitted ones from `values`
    np.testing.assert_array_equal(f.flow_stds(), [1e-7, 0.0, 3e-7])


def test_an_unbounded_flow_says_why_the_film_flooded_or_the_bearing_barely_seen():
    """A flow the record does not bound from above: over an interval that starts near or above its Q_T the film is
    flooded (more oil barely changes the vibration); one that starts well below reaches the starved side too, so the
    record barely sees that bearing (session 67: a four-bearing record of two planes far from bearing 1 read Q1 at
    1.78 Q_T, interval [140, open] ml/min, and said its film was flooded while the truth was 0.9 Q_T)."""
    from lubeviz.identify.fit.least_squares import _unbounded_text
    from lubeviz.units import MLMIN_PER_M3S

    qt = 560.0 / MLMIN_PER_M3S
    flooded = _unbounded_text(0, 0.97 * qt, qt)
    assert "the film is flooded" in flooded and "not bounded from above" in flooded
    unseen = _unbounded_text(0, 140.0 / MLMIN_PER_M3S, qt)
    assert "the film is flooded" not in unseen
    assert "anything from 140 ml/min up" in unseen and "Q_T (560 ml/min)" in unseen and "barely see" in unseen
