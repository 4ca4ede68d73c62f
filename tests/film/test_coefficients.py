"""Dynamic coefficients: the fixed-pattern linearization against re-solved films.

The fixed-pattern tangent is the exact small-step derivative of this mesh's discrete film, so these
tests ask for it explicitly (the default of find_equilibrium is the sub-cell tangent, test_subcell.py).
"""

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.feed import Feed, setup_problem
from lubeviz.film.linearize import finite_difference_coefficients
from lubeviz.film.solver import solve
from tests.conftest import OMEGA_75HZ, PAPER_LOAD

FEEDS = {"starved": Feed.flow(300 / 6e7), "over-supplied": Feed.flow(800 / 6e7), "flooded": Feed.flooded()}


@pytest.fixture(scope="module", params=sorted(FEEDS))
def equilibrium(request, paper_bearing):
    return find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, FEEDS[request.param], coefficients="fixed-pattern")


def test_linearized_and_small_step_fd_agree(equilibrium, paper_bearing):
    eq = equilibrium
    c = paper_bearing.clearance
    fd = finite_difference_coefficients(paper_bearing, OMEGA_75HZ, eq.position, eq.feed, step=1e-6 * c,
                                        velocity_step=1e-6 * c * OMEGA_75HZ, warm=eq.film)
    K, C = eq.coefficients.K, eq.coefficients.C
    assert np.abs(fd.K - K).max() < 1e-4 * np.abs(K).max()
    assert np.abs(fd.C - C).max() < 1e-4 * np.abs(C).max()


def test_coefficients_predict_the_force_change_to_second_order(equilibrium, paper_bearing):
    eq = equilibrium
    c = paper_bearing.clearance
    rng = np.random.default_rng(7)
    d, v = rng.normal(size=2), rng.normal(size=2)
    rel = []
    for h in (1e-3, 1e-4):
        dx, dv = h * c * d, h * c * OMEGA_75HZ * v
        f = solve(setup_problem(paper_bearing, OMEGA_75HZ, eq.position + dx, eq.feed, velocity=dv), warm=eq.film).force
        linear = -eq.coefficients.K @ dx - eq.coefficients.C @ dv
        rel.append(np.linalg.norm(f - eq.film.force - linear) / np.linalg.norm(linear))
    assert rel[1] < 3e-3
    assert rel[0] < 3e-2
    assert rel[0] / rel[1] > 5  # error relative to the step falls with the step: O(h^2) absolute


def test_stiffness_restores_and_damping_dissipates(equilibrium):
    K, C = equilibrium.coefficients.K, equilibrium.coefficients.C
    assert K[0, 0] > 0 and K[1, 1] > 0
    assert C[0, 0] > 0 and C[1, 1] > 0
    assert np.all(np.linalg.eigvalsh(0.5 * (C + C.T)) > 0)  # a film only removes energy


def test_large_fd_steps_drift_near_the_threshold(paper_bearing):
    """Near Q_T the cavitation boundary moves within an FD step: FD depends on the step (SPEC §3)."""
    eq = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(546 / 6e7), coefficients="fixed-pattern")
    c = paper_bearing.clearance
    small = finite_difference_coefficients(paper_bearing, OMEGA_75HZ, eq.position, eq.feed, step=1e-6 * c, warm=eq.film)
    big = finite_difference_coefficients(paper_bearing, OMEGA_75HZ, eq.position, eq.feed, step=3e-2 * c, warm=eq.film)
    K = eq.coefficients.K
    assert np.abs(small.K - K).max() < 1e-4 * np.abs(K).max()
    assert np.abs(big.K - K).max() > 1e-2 * np.abs(K).max()
