"""Bad input to the film model: a clear error naming the value, never a silent NaN."""


import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.feed import Feed, setup_problem
from tests.conftest import OMEGA_75HZ
from lubeviz.units import MLMIN_PER_M3S


@pytest.mark.parametrize("q", [-1e-6, 0.0, float("nan"), float("inf")])
def test_supply_flow_must_be_positive_and_finite(q):
    with pytest.raises(InputError, match="supply flow"):
        Feed.flow(q)


@pytest.mark.parametrize("eps", [1.0, 1.3])
def test_eccentricity_must_stay_inside_the_clearance(paper_bearing, eps):
    c = paper_bearing.clearance
    with pytest.raises(InputError, match="eccentricity ratio"):
        setup_problem(paper_bearing, OMEGA_75HZ, (0.0, -eps * c), Feed.flooded())


@pytest.mark.parametrize("omega", [0.0, -10.0, float("nan")])
def test_speed_must_be_positive(paper_bearing, omega):
    with pytest.raises(InputError, match="speed"):
        setup_problem(paper_bearing, omega, (0.0, -1e-5), Feed.flooded())


def test_mesh_too_coarse_for_the_groove(paper_bearing):
    coarse = paper_bearing.copy(n_circumferential=20, n_axial=10)
    with pytest.raises(InputError, match="too coarse to resolve the groove"):
        setup_problem(coarse, OMEGA_75HZ, (0.0, -1e-5), Feed.flooded())


def test_groove_feeds_need_a_groove():
    from tests.conftest import plain_bearing
    with pytest.raises(InputError, match="needs a groove"):
        setup_problem(plain_bearing(1.0), OMEGA_75HZ, (0.0, -1e-5), Feed.flooded())


def test_load_must_be_finite_and_nonzero(paper_bearing):
    for load in ([0.0, 0.0], [0.0, float("nan")], [1.0]):
        with pytest.raises(InputError, match="load"):
            find_equilibrium(paper_bearing, OMEGA_75HZ, load, Feed.flooded())


def test_impossible_load_reports_non_convergence_instead_of_a_number(paper_bearing):
    # 100 MN would need the journal closer than 0.5 % of the clearance to the wall: the result says so.
    eq = find_equilibrium(paper_bearing, OMEGA_75HZ, np.array([0.0, -1e8]), Feed.flow(300 / MLMIN_PER_M3S), max_iter=15)
    assert not eq.converged and eq.message
