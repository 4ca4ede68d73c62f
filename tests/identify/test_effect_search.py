"""A free effect size in another basin than its start (Effect.search_values), and a profile that finds a point
below the optimum (the fit restarts from it): both on one record of the independent source where each was the
difference between a wrong answer and a right one.

The record (the fan, bench-loop case 141 of session 48): oil 1.289 x as viscous as declared, flows 240, 319, 142
ml/min, planes at bearings A and C with the static position, 12 dB. From the neutral viscosity (x1) the global
search over the flows found a basin at x1.15 with chi2 17 for 6 dof (Q2 at its bound): the loop then named a moved
bearing. From x1.4 the search finds the valley (searched there only when the start's basins leave the record unexplained); there the optimum's profile over Q2 met a point
1.4 below the optimum's chi2, and refined from it the fit is at x1.36 with every interval holding its truth (without
the restart: chi2 3.7 and Q1's interval [193, 208] against 240)."""

import numpy as np
import pytest

import lubeviz.identify.fit.least_squares as LS
from lubeviz.effects import parse_effect
from lubeviz.effects.viscosity import Viscosity
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.identify.forward.measured import measure
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification.independent import IndependentSpec, make_record

FAN = str(MODELS_DIR / "three_bearing_fan.toml")
TRUTH = (240.20252984890826, 318.6912259652679, 142.19791018065678)


@pytest.fixture(scope="module")
def viscous():
    """(the chain with a free viscosity on every bearing, the record's features)."""
    spec = IndependentSpec(speed_hz=20.82161956148677, q_mlmin=TRUTH, nodes=(7, 23), static=True, seed=789675962,
                           effects=("viscosity:factor=1.289,bearing=both",), machine=FAN)
    rec = make_record(spec).record
    chain = ForwardChain(load_machine(FAN), rec.speed_hz, rec.nodes, probe_angles_deg=rec.probe_angles_deg)
    return chain, measure(rec)


def _fit(viscous, text="viscosity:bearing=all", **options):
    """The fit a diagnosis makes of this candidate (`Effect.candidate`: what it frees); a text with its size given:
    that size held."""
    chain, meas = viscous
    LS.forget_searches()
    effect = parse_effect(text)
    return LS.fit(chain.adding(effect if "factor" in text else effect.candidate()), meas, **options)


def _holds(res) -> bool:
    return all(lo < q / MLMIN_PER_M3S and (hi is None or q / MLMIN_PER_M3S < hi)
               for (lo, hi), q in zip((res.intervals[f"q{k + 1}"] for k in range(3)), TRUTH))


def test_a_viscosity_far_from_declared_is_found_from_its_search_values(viscous, monkeypatch):
    at_truth = _fit(viscous, "viscosity:factor=1.289,bearing=all")  # the size held at the truth: the valley's chi2
    res = _fit(viscous)
    assert res.chi2 <= at_truth.chi2 + 0.5 and 1.2 < res.values[-1] < 1.5 and _holds(res)
    assert _fit(viscous, screening=True, intervals=False).chi2 <= at_truth.chi2 + 0.5  # as a diagnosis ranks it
    # Searched from x1 alone, the fit stopped in a basin at x1.15 with Q2 at its bound until session 55: Q2 there
    # is past 2 Q_T of the thicker oil, where the tables ended and the lookup held the film at 2 Q_T. With the
    # tables to 3 Q_T that basin is gone and x1 alone reaches the valley; the search values stay for the records
    # whose valley is far from x1 (a thinner oil's).
    monkeypatch.setattr(Viscosity, "search", {})
    alone = _fit(viscous, screening=True, intervals=False)
    assert alone.chi2 <= at_truth.chi2 + 0.5 and 1.2 < alone.values[-1] < 1.5


def test_a_profile_point_below_the_optimum_restarts_the_fit(viscous, monkeypatch):
    """From the optimum the search reached before the restart (x1.58, Q = 200, 153, 119 ml/min)."""
    start = np.array([200.3 / MLMIN_PER_M3S, 153.3 / MLMIN_PER_M3S, 119.0 / MLMIN_PER_M3S, 1.576])
    res = _fit(viscous, start=start)
    monkeypatch.setattr(LS, "PROFILE_RESTARTS", 0)
    once = _fit(viscous, start=start)
    # (without the restart Q1's interval missed its truth until session 68; with the rigid turn of the films' leaning
    # loads in the budget it is wide enough to hold it: the restart's answer is still the better one, and nearer)
    assert res.chi2 < once.chi2 - LS.BETTER_BY and _holds(res)
    assert abs(res.values[-1] - 1.289) < abs(once.values[-1] - 1.289)


def test_of_several_starts_the_one_the_model_fits_best_is_refined(viscous):
    """`fit(start=rows)`: the rows are costed with the model's weights and the best one refined (a node scan's
    neighbours' answers); the free parameters alone (a fit's `values`) are a start too."""
    far = np.array([200.3 / MLMIN_PER_M3S, 153.3 / MLMIN_PER_M3S, 119.0 / MLMIN_PER_M3S, 1.576])  # a poorer basin
    good = _fit(viscous, intervals=False).values
    alone = _fit(viscous, start=good, intervals=False)
    for rows in ([far, good], [good, far]):
        both = _fit(viscous, start=np.array(rows), intervals=False)
        assert both.chi2 == pytest.approx(alone.chi2, rel=1e-9)
        np.testing.assert_allclose(both.values, alone.values, rtol=1e-9)
    assert _fit(viscous, start=far, intervals=False).chi2 > alone.chi2 + 1.0  # refined alone it stays there


def test_a_screening_fit_that_cannot_pass_stops_once_its_steps_gain_little(viscous, monkeypatch):
    """A screening fit (what a diagnosis ranks with) still `HOPELESS` times above the test's limit stops once a step
    lowers its chi2 by less than `HOPELESS_GAIN` of it: the planes swapped on this record cannot be made to fit. The
    true effect's screening fit never comes near that floor and is the same either way."""
    import math

    from scipy import stats

    floor = LS.HOPELESS
    swapped = _fit(viscous, "wiring:fault=planes_swapped", screening=True, intervals=False)
    true = _fit(viscous, screening=True, intervals=False)
    monkeypatch.setattr(LS, "HOPELESS", math.inf)
    crawled = _fit(viscous, "wiring:fault=planes_swapped", screening=True, intervals=False)
    again = _fit(viscous, screening=True, intervals=False)
    limit = stats.chi2.ppf(0.99, swapped.dof)
    assert crawled.chi2 > floor * limit and swapped.chi2 > floor * limit  # measured 1.2e5 and 1.0e4 against 185
    # it stops within a few steps (2 since session 51, where a step the linear model promises less than SCREENING_GAIN
    # is not taken; the hopeless stop alone made it 8 against 44 before), and never later than without that stop
    assert swapped.iterations <= crawled.iterations and swapped.iterations < 0.25 * LS.SCREENING_ITER
    assert again.chi2 == true.chi2 and again.iterations == true.iterations and true.explained
