"""Smoothed complementarity (film/smoothed.py): its limit, its conservation, its derivative, its values."""

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.feed import Feed, setup_problem
from lubeviz.film.operator import residual
from lubeviz.film.roughness import coefficient_roughness
from lubeviz.film.smoothed import (
    DEFAULT_SMOOTHING,
    smoothed_coefficients,
    smoothed_force_jacobian,
    solve_smoothed,
)
from lubeviz.film.solver import solve
from lubeviz.film.sweep import sweep_supply
from tests.conftest import OMEGA_75HZ, PAPER_LOAD
from lubeviz.units import MLMIN_PER_M3S

FEEDS = {"starved": Feed.flow(300 / MLMIN_PER_M3S), "near-threshold": Feed.flow(546 / MLMIN_PER_M3S),
         "over-supplied": Feed.flow(800 / MLMIN_PER_M3S), "flooded": Feed.flooded()}

# Mesh study of BENCHMARKS.md, 200 x 200 (fixed-pattern tangent): K in MN/m, C in kN*s/m, [xx, xy, yx, yy].
FINE_MESH = {400: ([138.7, 63.1, -67.1, 67.7], [216, -418, -204, 623]),
             546: ([204.4, 123.3, -102.4, 54.9], [503, -725, -121, 536]),
             700: ([219.7, 203.0, -199.3, 104.1], [858, -794, 93, 865])}


@pytest.fixture(scope="module")
def paper_bearing(machine):
    """The paper's uniform 100 x 100 mesh: the smoothing acts per cell and was chosen on it (smoothed.py)."""
    return machine.bearings[0].copy(groove_refinement=1)


@pytest.fixture(scope="module", params=sorted(FEEDS))
def equilibrium(request, paper_bearing):
    return find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, FEEDS[request.param], coefficients="fixed-pattern")


def test_vanishing_smoothing_recovers_the_fixed_pattern_tangent(equilibrium):
    tiny = smoothed_coefficients(equilibrium.film, 1e-16)
    K, C = equilibrium.coefficients.K, equilibrium.coefficients.C
    assert np.abs(tiny.K - K).max() < 1e-6 * np.abs(K).max()
    assert np.abs(tiny.C - C).max() < 1e-6 * np.abs(C).max()


def test_smoothed_film_conserves_mass_and_keeps_the_smoothed_eq6(equilibrium):
    film = solve_smoothed(equilibrium.film)
    assert film.converged
    problem = film.problem
    free = ~problem.fixed
    R = residual(problem.coef, film.P, film.theta)
    assert np.abs(R[free]).max() < 1e-10  # every balance holds, as in the exact film
    if equilibrium.feed.kind == "flow":
        assert film.side_leakage == pytest.approx(equilibrium.feed.q_supply, rel=1e-9)
    assert np.all(film.P[free] > 0.0) and np.all(film.theta[free] < 1.0)
    np.testing.assert_allclose(film.P[free] * (1.0 - film.theta[free]), DEFAULT_SMOOTHING, rtol=1e-6)
    # the smoothing is local: the film carries nearly the same load (measured: within 0.3 %)
    assert np.abs(film.force - equilibrium.film.force).max() < 5e-3 * np.abs(equilibrium.film.force).max()


def test_smoothed_coefficients_are_the_derivative_of_the_smoothed_force(equilibrium, paper_bearing):
    """Implicit-function tangent against central differences of re-solved smoothed films."""
    eq = equilibrium
    film = solve_smoothed(eq.film)
    dF = smoothed_force_jacobian(film)
    c = paper_bearing.clearance
    steps = [2e-5 * c] * 2 + [2e-5 * c * OMEGA_75HZ] * 2
    fd = np.empty((2, 4))
    for k in range(4):
        d = np.zeros(4)
        d[k] = steps[k]
        forces = []
        for sign in (1.0, -1.0):
            prob = setup_problem(paper_bearing, OMEGA_75HZ, eq.position + sign * d[:2], eq.feed, velocity=sign * d[2:])
            forces.append(solve_smoothed(solve(prob, warm=eq.film)).force)
        fd[:, k] = (forces[0] - forces[1]) / (2.0 * steps[k])
    assert np.abs(fd[:, :2] - dF[:, :2]).max() < 2e-4 * np.abs(dF[:, :2]).max()
    assert np.abs(fd[:, 2:] - dF[:, 2:]).max() < 2e-4 * np.abs(dF[:, 2:]).max()


@pytest.mark.parametrize("q_mlmin", sorted(FINE_MESH))
def test_smoothed_coefficients_do_not_move_the_mesh_converged_values(paper_bearing, q_mlmin):
    """At 100 x 100 the smoothed K, C are no farther from the 200 x 200 values than the tangent is."""
    eq = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(q_mlmin / MLMIN_PER_M3S), coefficients="fixed-pattern")
    sm = smoothed_coefficients(eq.film)
    K_ref = np.reshape(FINE_MESH[q_mlmin][0], (2, 2)) * 1e6
    C_ref = np.reshape(FINE_MESH[q_mlmin][1], (2, 2)) * 1e3

    def dist(a, ref):
        return np.abs(a - ref).max() / np.abs(ref).max()

    assert dist(sm.K, K_ref) < 0.01 and dist(sm.C, C_ref) < 0.0125
    assert dist(sm.K, K_ref) <= dist(eq.coefficients.K, K_ref) + 1e-3
    assert dist(sm.C, C_ref) <= dist(eq.coefficients.C, C_ref) + 1e-3


def test_equilibrium_offers_the_smoothed_coefficients(paper_bearing):
    feed = Feed.flow(450 / MLMIN_PER_M3S)
    exact = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, feed, coefficients="fixed-pattern")
    smooth = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, feed, coefficients="smoothed")
    np.testing.assert_array_equal(smooth.position, exact.position)  # the equilibrium is the exact film's
    assert smooth.coefficients.method.startswith("smoothed")
    assert exact.coefficients.method == "fixed-pattern"
    with pytest.raises(InputError, match="coefficient method"):
        find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, feed, coefficients="secant")


@pytest.mark.slow
def test_smoothed_coefficients_are_smoother_along_the_supply(paper_bearing):
    """1 ml/min sweep across Q_T (473-573 ml/min): the staircase is at least 1.6x lower (measured ~2x)."""
    flows = np.arange(473.0, 574.0, 1.0) / MLMIN_PER_M3S
    keep = []
    s = sweep_supply(paper_bearing, OMEGA_75HZ, PAPER_LOAD, flows, keep=keep, coefficients="fixed-pattern")
    coefs = [smoothed_coefficients(e.film) for e in keep]
    old = coefficient_roughness(s.K, s.C)
    new = coefficient_roughness(np.array([c.K for c in coefs]), np.array([c.C for c in coefs]))
    assert new["K_max"] < old["K_max"] / 1.6 and new["C_max"] < old["C_max"] / 1.6
    assert new["K_max"] < 0.0075 and new["C_max"] < 0.0075
