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
from lubeviz.units import MLMIN_PER_M3S

FEEDS = {"starved": Feed.flow(300 / MLMIN_PER_M3S), "over-supplied": Feed.flow(800 / MLMIN_PER_M3S), "flooded": Feed.flooded()}


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
    eq = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(546 / MLMIN_PER_M3S), coefficients="fixed-pattern")
    c = paper_bearing.clearance
    small = finite_difference_coefficients(paper_bearing, OMEGA_75HZ, eq.position, eq.feed, step=1e-6 * c, warm=eq.film)
    big = finite_difference_coefficients(paper_bearing, OMEGA_75HZ, eq.position, eq.feed, step=3e-2 * c, warm=eq.film)
    K = eq.coefficients.K
    assert np.abs(small.K - K).max() < 1e-4 * np.abs(K).max()
    assert np.abs(big.K - K).max() > 1e-2 * np.abs(K).max()


@pytest.mark.parametrize("q_mlmin, pos, vel", [
    (300.0, (0.2, -0.4), (0.0, 0.0)),  # starved
    (545.0, (0.3, -0.5), (-0.05, 0.0)),  # about Q_T, squeezing
    (700.0, (0.1, -0.2), (0.0, 0.03)),  # flooded
])
def test_the_supply_derivative_is_the_force_s_change_with_the_supply(paper_bearing, q_mlmin, pos, vel):
    """dF/dQ at fixed journal motion (one back-substitution, pattern held) against central differences of
    re-solved films (+-0.1 % of Q): the supply enters the balances only as the groove's source."""
    from lubeviz.film.linearize import supply_derivative

    c, om = paper_bearing.clearance, OMEGA_75HZ
    pos = (pos[0] * c, pos[1] * c)
    vel = (vel[0] * c * om, vel[1] * c * om)
    q = q_mlmin / MLMIN_PER_M3S
    sol = solve(setup_problem(paper_bearing, om, pos, Feed.flow(q), velocity=vel))
    f = [solve(setup_problem(paper_bearing, om, pos, Feed.flow(q * (1 + s * 1e-3)), velocity=vel), warm=sol).force
         for s in (1, -1)]
    fd = (f[0] - f[1]) / (2e-3 * q)
    np.testing.assert_allclose(supply_derivative(sol), fd, rtol=0, atol=0.005 * np.abs(fd).max())
