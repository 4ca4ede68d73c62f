"""Mass conservation, and the two solvers / two domains reaching the same discrete solution."""

import math

import numpy as np
import pytest

from lubeviz.film.feed import Feed, make_mesh, setup_problem
from lubeviz.film.operator import residual
from lubeviz.film.solver import solve, solve_active_set, solve_sor
from tests.conftest import OMEGA_75HZ, plain_bearing
from lubeviz.units import MLMIN_PER_M3S

POSITION = (0.3 * 120e-6 * math.sin(1.0), -0.3 * 120e-6 * math.cos(1.0))


@pytest.mark.parametrize("feed", [Feed.flow(300 / MLMIN_PER_M3S), Feed.flow(800 / MLMIN_PER_M3S), Feed.flooded()],
                         ids=["starved", "over-supplied", "flooded"])
def test_mass_is_conserved(paper_bearing, feed):
    sol = solve(setup_problem(paper_bearing, OMEGA_75HZ, POSITION, feed)).raise_if_failed()
    assert sol.mass_residual < 1e-8
    if feed.kind == "flow":
        assert sol.side_leakage == pytest.approx(feed.q_supply, rel=1e-8)
    # every free cell balances, in units of one face's Couette flux
    R = residual(sol.problem.coef, sol.P, sol.theta)
    assert np.abs(R[~sol.problem.fixed]).max() < 1e-9


def test_complementarity_holds(paper_bearing):
    sol = solve(setup_problem(paper_bearing, OMEGA_75HZ, POSITION, Feed.flow(300 / MLMIN_PER_M3S)))
    assert np.all(sol.P >= 0.0) and np.all(sol.theta <= 1.0) and np.all(sol.theta > 0.0)
    assert np.all((sol.P == 0.0) | (sol.theta == 1.0))  # Eq. 6
    assert (sol.theta < 0.999).any() and (sol.P > 0).any()  # both regimes present when starved


def test_mass_is_conserved_plain_bearing():
    b = plain_bearing(1.0)
    sol = solve(setup_problem(b, OMEGA_75HZ, (0.0, -0.5 * b.clearance), Feed.plain()))
    assert sol.converged and sol.mass_residual < 1e-8 and sol.side_leakage > 0


@pytest.mark.parametrize("feed", [Feed.flow(350 / MLMIN_PER_M3S), Feed.flooded()], ids=["starved", "flooded"])
def test_sor_and_active_set_reach_the_same_solution(paper_bearing, feed):
    b = paper_bearing.copy(n_circumferential=60, n_axial=40)
    problem = setup_problem(b, OMEGA_75HZ, POSITION, feed)
    exact = solve_active_set(problem)
    sor = solve_sor(problem, relax=1.9, tol=1e-12)
    assert exact.converged and sor.converged
    assert np.max(np.abs(sor.force - exact.force)) < 1e-7 * np.max(np.abs(exact.force))
    assert np.max(np.abs(sor.theta - exact.theta)) < 1e-6


def test_half_domain_equals_full_domain(paper_bearing):
    feed = Feed.flow(400 / MLMIN_PER_M3S)
    half = solve(setup_problem(paper_bearing, OMEGA_75HZ, POSITION, feed, mesh=make_mesh(paper_bearing, half=True)))
    full = solve(setup_problem(paper_bearing, OMEGA_75HZ, POSITION, feed, mesh=make_mesh(paper_bearing, half=False)))
    np.testing.assert_allclose(half.force, full.force, rtol=1e-10)
    np.testing.assert_allclose(half.pressure_field(), full.pressure_field(), rtol=1e-9, atol=1e-6)
    assert half.side_leakage == pytest.approx(full.side_leakage, rel=1e-10)
    edges = full.edge_leakage
    assert edges[0] == pytest.approx(edges[1], rel=1e-9)  # symmetric film: equal edge flows
    assert sum(edges) == pytest.approx(full.side_leakage, rel=1e-12)


def test_warm_start_gives_the_same_solution_in_fewer_solves(paper_bearing):
    feed = Feed.flow(400 / MLMIN_PER_M3S)
    cold = solve(setup_problem(paper_bearing, OMEGA_75HZ, POSITION, feed))
    moved = setup_problem(paper_bearing, OMEGA_75HZ, (POSITION[0] * 1.01, POSITION[1] * 1.01), feed)
    warm = solve(moved, warm=cold)
    again = solve(moved)
    assert warm.iterations < again.iterations
    np.testing.assert_allclose(warm.force, again.force, rtol=1e-12)


def test_a_sweep_s_predicted_starts_change_the_work_not_the_answer(paper_bearing):
    """`sweep_supply` starts each equilibrium at the parabola through the last positions and at the cavitation
    pattern extrapolated along the last two films (`predicted_pattern`). The starts decide only the work:
    each equilibrium equals the one solved cold to the force tolerance, and the extrapolated pattern is
    nearer the next film's than the last film's own pattern is."""
    from lubeviz.film.equilibrium import find_equilibrium
    from lubeviz.film.sweep import predicted_pattern, sweep_supply
    from tests.conftest import PAPER_LOAD

    flows = np.array([400.0, 410.0, 420.0, 430.0]) / MLMIN_PER_M3S
    keep = []
    sweep = sweep_supply(paper_bearing, OMEGA_75HZ, PAPER_LOAD, flows, keep=keep)
    for k in (2, 3):
        cold = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(flows[k]))
        np.testing.assert_allclose(sweep.position[k], cold.position, rtol=0, atol=1e-8 * paper_bearing.clearance)
        K = cold.coefficients.K
        np.testing.assert_allclose(sweep.K[k], K, rtol=1e-6, atol=1e-6 * np.abs(K).max())
    predicted = predicted_pattern(keep[1].film, keep[2].film, 1.0)
    actual = keep[3].film.full
    assert (predicted != actual).sum() < (keep[2].film.full != actual).sum()


def test_a_reused_factorization_changes_the_work_not_the_answer(paper_bearing):
    """A pattern system may solve with another system's LU (the switched columns by Woodbury, a moved journal by
    iterative refinement; `solver.PatternSystem`). Every film and tangent then equals the one solved with its own
    factorization to round-off: within one active-set solve (same position), after an equilibrium-sized Newton
    step (4e-5 c, refined), and from a root too far away to refine (factorized afresh)."""
    from lubeviz.film.linearize import fixed_pattern_coefficients
    from lubeviz.film.solver import Columns, PatternSystem, solve_active_set

    feed = Feed.flow(400 / MLMIN_PER_M3S)
    first = solve(setup_problem(paper_bearing, OMEGA_75HZ, POSITION, feed), base=None)
    root = PatternSystem(first.problem, first.full, Columns(first.problem))  # factorized, first's pattern
    c = paper_bearing.clearance
    for shift, expect_reuse in ((4e-5, True), (3e-2, False)):
        pos = (POSITION[0] + shift * c, POSITION[1] - shift * c)
        problem = setup_problem(paper_bearing, OMEGA_75HZ, pos, feed)
        own = solve_active_set(problem, first.full)
        reused = solve_active_set(problem, first.full, base=first.linear)
        assert reused.converged and reused.iterations == own.iterations
        np.testing.assert_allclose(reused.P, own.P, rtol=0, atol=1e-12 * own.P.max())
        np.testing.assert_allclose(reused.theta, own.theta, rtol=0, atol=1e-12)
        np.testing.assert_allclose(reused.force, own.force, rtol=1e-11)
        ka, kb = fixed_pattern_coefficients(reused), fixed_pattern_coefficients(own)
        np.testing.assert_allclose(ka.K, kb.K, rtol=0, atol=1e-10 * np.abs(kb.K).max())
        np.testing.assert_allclose(ka.C, kb.C, rtol=0, atol=1e-10 * np.abs(kb.C).max())
        # the same pattern at the moved journal: refined from the root's LU after a Newton-sized step; from a
        # root 3 % of the clearance away the refinement does not contract and the system is factorized afresh
        trip = Columns(problem)
        system = PatternSystem(problem, first.full, trip, base=root)
        assert system.reused  # offered and taken (no switched cells) ...
        x = system.solve()
        assert system.reused is expect_reuse  # ... and kept, or dropped after the residual check
        y = PatternSystem(problem, first.full, trip).solve()
        np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * np.abs(y).max())
    # the same position, a few switched cells: the exact Woodbury update, no refinement needed
    problem = first.problem
    full = first.full.copy()
    cells = np.argwhere(full & ~problem.fixed)[:5]
    full[tuple(cells.T)] = False
    trip = Columns(problem)
    fresh = PatternSystem(problem, full, trip)
    update = PatternSystem(problem, full, trip, base=root)
    assert update.reused and update._update[0].size == 5
    x, y = update.solve(), fresh.solve()
    assert update.reused  # solved by the update, not factorized afresh after a failed check
    np.testing.assert_allclose(x, y, rtol=0, atol=1e-12 * np.abs(y).max())
