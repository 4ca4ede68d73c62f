"""The paper's bearing (Table 3) at 75 Hz under its share of the rotor weight, 100 x 100 cells."""

import numpy as np
import pytest

from lubeviz.film.derived import summarize
from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed
from lubeviz.film.sweep import sweep_supply
from tests.conftest import OMEGA_75HZ, PAPER_LOAD
from lubeviz.units import MLMIN_PER_M3S

PAPER_Q_T_MLMIN = 546.0


def test_flooded_threshold_matches_the_paper(paper_bearing):
    q_t, eq = flooded_threshold(paper_bearing, OMEGA_75HZ, PAPER_LOAD)
    assert eq.converged
    assert q_t * MLMIN_PER_M3S == pytest.approx(PAPER_Q_T_MLMIN, rel=0.03)


def test_equilibrium_balances_the_load(flooded_equilibrium):
    eq = flooded_equilibrium
    np.testing.assert_allclose(eq.film.force, -PAPER_LOAD, atol=1e-6 * 3272.8)
    # the journal sits below the centre, displaced in the direction of rotation (towards +X)
    assert eq.position[1] < 0 and eq.position[0] > 0


def test_eccentricity_grows_as_the_bearing_starves(paper_bearing):
    flows = np.array([273.0, 350.0, 430.0, 500.0, 546.0]) / MLMIN_PER_M3S  # 50 % ... 100 % of Q_T
    sweep = sweep_supply(paper_bearing, OMEGA_75HZ, PAPER_LOAD, flows)
    assert np.all(np.diff(sweep.eccentricity_ratio) < 0)  # less oil -> larger eccentricity
    assert sweep.eccentricity_ratio[0] > 1.5 * sweep.eccentricity_ratio[-1]
    np.testing.assert_allclose(sweep.side_leakage, flows, rtol=1e-8)


def test_groove_pressurizes_above_the_threshold(paper_bearing):
    groove_p = []
    prev = None
    for q in (300.0, 480.0, 620.0, 720.0, 819.0):
        eq = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(q / MLMIN_PER_M3S),
                              start=None if prev is None else prev.position)
        groove_p.append(summarize(eq.film, eq.position).groove_pressure)
        prev = eq
    assert groove_p[0] == 0.0 and groove_p[1] == 0.0  # starved: the groove is not full
    assert 0.0 < groove_p[2] < groove_p[3] < groove_p[4]


def test_starved_film_has_an_incomplete_inlet(paper_bearing):
    starved = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(300 / MLMIN_PER_M3S))
    flooded = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flooded())
    s, f = summarize(starved.film, starved.position), summarize(flooded.film, flooded.position)
    # Even flooded, the film ruptures between the groove (0 deg) and the thickest film (~62 deg) and
    # enters the converging gap incomplete; starving makes that incomplete inlet much longer.
    assert s.starved_fraction > f.starved_fraction + 0.1
    assert s.max_pressure > f.max_pressure  # a smaller pressure zone carries the same load
