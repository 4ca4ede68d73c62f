"""The periodic orbit on the p-theta films (harmonic balance) against the time integration on the same
films (`film_transient`, another path: a step-by-step integration with explicit residual coupling), and
the scaling laws of a weak nonlinearity."""

import numpy as np
import pytest

from lubeviz.errors import ConvergenceError, InputError
from lubeviz.rotor import rotor_from_machine
from lubeviz.rotor.film_bearings import film_bearings
from lubeviz.rotor.film_transient import amplitude_ratio
from lubeviz.rotor.orbit_balance import orbit_balance
from lubeviz.rotor.response import Unbalance, machine_unbalance
from lubeviz.units import MLMIN_PER_M3S
from tests.memo import time_response

pytestmark = pytest.mark.slow

NODES = (6, 20)


@pytest.fixture(scope="module")
def coarse():
    """The paper's machine on 60 x 40 films, flooded (900 ml/min, Q_T ~ 546): the limits checked here do
    not need the 100 x 100 mesh."""
    from lubeviz.model.machine import load_machine

    m = load_machine()
    m.bearings = [b.copy(n_circumferential=60, n_axial=40) for b in m.bearings]
    bearings = film_bearings(m, (900 / MLMIN_PER_M3S, 900 / MLMIN_PER_M3S), coefficients="fixed-pattern")
    return m, rotor_from_machine(m), bearings


def _unbalance(machine, scale):
    return tuple(Unbalance(u.node, u.moment * scale, u.phase) for u in machine_unbalance(machine))


@pytest.fixture(scope="module")
def scaled(coarse):
    """The balances at 0.05, 0.1 and 0.2 x the paper's unbalance on the coarse films, made once: the scaling
    laws read all three, the time integration starts on the last."""
    machine, rotor, bearings = coarse
    return {s: orbit_balance(rotor, bearings, _unbalance(machine, s), nodes=NODES) for s in (0.05, 0.1, 0.2)}


def _counted(steps: list):
    """The film's solve_active_set, appending each solve's active-set steps to `steps`."""
    import lubeviz.film.solver as film_solver

    real = film_solver.solve_active_set

    def counting(*a, **kw):
        sol = real(*a, **kw)
        steps.append(sol.iterations)
        return sol

    return counting


@pytest.fixture(scope="module")
def half(coarse):
    """The balance at half the paper's unbalance on the coarse films (tol 1e-8, inexact early films as by default),
    made once, and the active-set steps its film solves took: the inexact films' orbit and work, the 5-harmonic
    start of the finer balance and the linear-start reference of the mapped films are this one computation."""
    import lubeviz.film.solver as film_solver
    import lubeviz.rotor.orbit_balance as ob_module

    machine, rotor, bearings = coarse
    steps = []
    counting = _counted(steps)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ob_module, "solve_active_set", counting)
        mp.setattr(film_solver, "solve_active_set", counting)
        ob = orbit_balance(rotor, bearings, _unbalance(machine, 0.5), nodes=NODES, tol=1e-8)
    return ob, sum(steps)


def test_the_periodic_orbit_is_the_time_integrations_orbit(coarse, scaled):
    """Started on the harmonic-balance orbit, the time integration stays on it: 1X, the static shift and
    2X agree over three revolutions (the integrator's own error, first order in its step, is what is left:
    at dt = 1e-4 s the 2X of y differs by 30 %, at 2.5e-5 s by 8 %)."""
    machine, rotor, bearings = coarse
    ub = _unbalance(machine, 0.2)
    hb = scaled[0.2]
    assert hb.harmonic_ratio(2) > 0.01  # a 2X the linear model lacks
    tr = time_response(rotor, bearings, ub, duration=0.04, dt=2.5e-5, nodes=NODES, start=hb.state(0.0))
    w = bearings.omega
    for k, node in enumerate(NODES):
        x, y = tr.node_xy(node)
        for sig, ref in ((x, hb.x[:, k]), (y, hb.y[:, k])):
            assert abs(sig.mean() - ref[0].real) < 0.03 * abs(ref[0].real) + 2e-9
            one = amplitude_ratio(tr.t, sig - sig.mean(), w, ref[1])
            assert abs(one - 1) < 5e-3
        two_x = amplitude_ratio(tr.t, x - x.mean(), 2 * w, hb.x[2, k])
        two_y = amplitude_ratio(tr.t, y - y.mean(), 2 * w, hb.y[2, k])
        assert abs(two_x - 1) < 0.03 and abs(two_y - 1) < 0.15


def test_harmonics_scale_as_powers_of_the_orbit(coarse, scaled):
    """A weak nonlinearity: 2X/1X grows as the orbit (x2 for x2 unbalance), the static shift as its square."""
    machine, rotor, bearings = coarse
    r = [scaled[s] for s in (0.05, 0.1, 0.2)]
    # the films kept for warm starts hold their fields, not their factorizations (48 per balance: GBs per fit)
    assert all(f.linear is None and f.P is not None for ob in r for films in ob.films for f in films)
    # on one thread the same orbit, to round-off (each film is solved alone from its own warm start)
    one = orbit_balance(rotor, bearings, _unbalance(machine, 0.1), nodes=NODES, threads=1)
    assert np.allclose(one.x, r[1].x, rtol=0, atol=1e-12 * np.abs(r[1].x).max())
    ratio = [x.harmonic_ratio(2) for x in r]
    shift = [abs(x.y[0, 0]) for x in r]
    for a, b in zip(ratio, ratio[1:]):
        assert b / a == pytest.approx(2.0, rel=0.1)
    for a, b in zip(shift, shift[1:]):
        assert b / a == pytest.approx(4.0, rel=0.15)
    assert all(x.iterations <= 12 for x in r)


def test_bad_settings_are_refused(coarse):
    machine, rotor, bearings = coarse
    with pytest.raises(InputError, match="points per revolution"):
        orbit_balance(rotor, bearings, _unbalance(machine, 0.1), harmonics=4, points=8)


def test_inexact_early_films_reach_the_same_orbit_for_less_work(coarse, half, monkeypatch):
    """While the orbit still moves by more than INEXACT_ABOVE of its 1X, each film stops after INEXACT_STEPS
    active-set steps (an inexact Newton method); closer in every film is exact, so the orbit is the one with
    exact films at every step, to the balance's tolerance, and the active-set work is smaller (on 100 x 100
    from the linear orbit: 22.5 -> 8.2 s at the paper's unbalance)."""
    import lubeviz.film.solver as film_solver
    import lubeviz.rotor.orbit_balance as ob_module

    machine, rotor, bearings = coarse
    ub = _unbalance(machine, 0.5)
    steps = []
    counting = _counted(steps)
    monkeypatch.setattr(ob_module, "solve_active_set", counting)
    monkeypatch.setattr(film_solver, "solve_active_set", counting)
    inexact, work_inexact = half  # orbit_balance(rotor, bearings, ub, nodes=NODES, tol=1e-8), its steps counted
    monkeypatch.setattr(ob_module, "INEXACT_ABOVE", np.inf)  # every film exact from the first step
    exact = orbit_balance(rotor, bearings, ub, nodes=NODES, tol=1e-8)
    work_exact = sum(steps)
    assert inexact.harmonic_ratio(2) > 0.02  # an orbit the linear model does not hold
    size = np.abs(exact.x[1]).max()
    for h in range(exact.harmonics + 1):
        np.testing.assert_allclose(inexact.x[h], exact.x[h], rtol=0, atol=1e-6 * size)
        np.testing.assert_allclose(inexact.y[h], exact.y[h], rtol=0, atol=1e-6 * size)
    assert work_inexact < work_exact


def test_a_balance_with_more_harmonics_starts_from_one_with_fewer(coarse, half):
    """`start` with fewer harmonics and points: its harmonics padded with zeros, each phase point's film warm-started
    from its nearest one. The same orbit as from the linear one, for fewer film solves (a chain 5 -> 8 -> 12 -> 16
    -> 24 harmonics at the paper's point on these films: 28-35 s, against 65 s for 24 from 5 directly)."""
    machine, rotor, bearings = coarse
    ub = _unbalance(machine, 0.5)
    five = half[0]  # orbit_balance(rotor, bearings, ub, nodes=NODES, tol=1e-8)
    direct = orbit_balance(rotor, bearings, ub, nodes=NODES, harmonics=10, points=40, tol=1e-8)
    refined = orbit_balance(rotor, bearings, ub, nodes=NODES, harmonics=10, points=40, tol=1e-8, start=five)
    assert refined.harmonics == 10 and refined.films is not None and len(refined.films[0]) == 40
    size = np.abs(direct.x[1]).max()
    for h in range(direct.harmonics + 1):
        np.testing.assert_allclose(refined.x[h], direct.x[h], rtol=0, atol=1e-6 * size)
        np.testing.assert_allclose(refined.y[h], direct.y[h], rtol=0, atol=1e-6 * size)
    assert refined.film_solves < direct.film_solves
    back = orbit_balance(rotor, bearings, ub, nodes=NODES, start=direct, tol=1e-8)  # and down again: cut to 5
    np.testing.assert_allclose(back.x[1], five.x[1], rtol=0, atol=1e-6 * size)


@pytest.mark.parametrize("flows_mlmin", [(900.0, 900.0), (420.0, 700.0)])
def test_the_flow_slope_is_the_balance_s_derivative_in_the_supply(coarse, flows_mlmin):
    """The nonlinear part's derivative in each supply flow and in the unbalance's size by implicit differentiation of the converged balance
    (the films' supply derivative, the equilibria's, the balance's own Newton matrix) against central
    differences of converged balances (+-0.1 % of the flow): 1X and 0X at both planes, starved and flooded.
    (Measured at 420 / 700 ml/min, the flooded flow: 0.14 % apart at +-0.1 %, 5.9 % at +-1 %, 12 % at +-4 %:
    wider differences take in cells that switch and the curvature, the implicit slope is the local one.)"""
    from lubeviz.rotor.film_bearings import equilibrium_flow_slopes, flooded_thresholds

    machine, rotor, _ = coarse
    ub = _unbalance(machine, 0.5)
    q = np.array(flows_mlmin) / MLMIN_PER_M3S
    thresholds = flooded_thresholds(machine)
    fb = film_bearings(machine, q)
    ob = orbit_balance(rotor, fb, ub, nodes=NODES, tol=1e-10,
                       flow_slopes=equilibrium_flow_slopes(machine, fb, thresholds))
    assert ob.harmonic_ratio(2) > 0.02  # an orbit the linear model does not hold

    def nonlinear(o):
        return np.concatenate([o.x[1] - o.linear_x, o.y[1] - o.linear_y]), np.concatenate([o.x[0].real, o.y[0].real])

    for k in range(2):
        h = 1e-3 * q[k]
        parts = []
        for s in (1, -1):
            qk = q.copy()
            qk[k] += s * h
            parts.append(nonlinear(orbit_balance(rotor, film_bearings(machine, qk), ub, nodes=NODES, tol=1e-10,
                                                 start=ob)))
        fd_1x, fd_0x = ((a - b) / (2 * h) for a, b in zip(*parts))
        an_1x = np.concatenate([ob.flow_slope_x[k, 1], ob.flow_slope_y[k, 1]])
        an_0x = np.concatenate([ob.flow_slope_x[k, 0].real, ob.flow_slope_y[k, 0].real])
        assert np.linalg.norm(an_1x - fd_1x) < 0.02 * np.linalg.norm(fd_1x), (k, an_1x, fd_1x)
        assert np.linalg.norm(an_0x - fd_0x) < 0.02 * np.linalg.norm(fd_0x), (k, an_0x, fd_0x)
    # and in the unbalance's size (its logarithm: every unbalance x (1 +- 1e-3))
    parts = [nonlinear(orbit_balance(rotor, fb, _unbalance(machine, 0.5 * (1 + s * 1e-3)), nodes=NODES, tol=1e-10,
                                     start=ob)) for s in (1, -1)]
    fd_1x, fd_0x = ((a - b) / 2e-3 for a, b in zip(*parts))
    an_1x = np.concatenate([ob.scale_slope_x[1], ob.scale_slope_y[1]])
    an_0x = np.concatenate([ob.scale_slope_x[0].real, ob.scale_slope_y[0].real])
    assert np.linalg.norm(an_1x - fd_1x) < 0.02 * np.linalg.norm(fd_1x)
    assert np.linalg.norm(an_0x - fd_0x) < 0.02 * np.linalg.norm(fd_0x)


def test_an_orbit_on_another_mesh_starts_the_films_from_its_patterns(coarse, half, monkeypatch):
    """Started from an orbit on coarser films, the balance takes that orbit's harmonics and, mapped cell by cell,
    its films' cavitation patterns (`orbit_balance._mapped_film`): the same orbit as from the linear one, in
    fewer Newton steps than with every film started at the equilibrium's pattern (the large-orbit fit's first
    balance on the model's films, from its coarse rounds: 7 -> 3 steps, 7.5 -> 3.5 s on 100 x 100)."""
    import lubeviz.rotor.orbit_balance as ob_module
    from lubeviz.model.machine import load_machine

    machine, rotor, bearings = coarse
    ub = _unbalance(machine, 0.5)
    small = load_machine()
    small.bearings = [b.copy(n_circumferential=40, n_axial=30) for b in small.bearings]
    rough = orbit_balance(rotor_from_machine(small), film_bearings(small, bearings.flows, coefficients="fixed-pattern"),
                          ub, nodes=NODES)
    assert rough.films[0][0].P.shape != bearings.equilibria[0].film.P.shape
    mapped = orbit_balance(rotor, bearings, ub, nodes=NODES, start=rough, tol=1e-8)
    monkeypatch.setattr(ob_module, "_mapped_film", lambda src, like: like)  # every film from the equilibrium
    plain = orbit_balance(rotor, bearings, ub, nodes=NODES, start=rough, tol=1e-8)
    linear = half[0]  # orbit_balance(rotor, bearings, ub, nodes=NODES, tol=1e-8), from the linear orbit
    size = np.abs(linear.x[1]).max()
    for h in range(linear.harmonics + 1):
        np.testing.assert_allclose(mapped.x[h], linear.x[h], rtol=0, atol=1e-6 * size)
        np.testing.assert_allclose(mapped.y[h], linear.y[h], rtol=0, atol=1e-6 * size)
    assert mapped.film_solves < plain.film_solves


# 0.6 x the unbalance (85 s, taken out of CI for its time, session 20) measured 4 % of the correction, covered by
# the term; the bench over 12 time-integration records at 0.5-1 x (BENCHMARKS) covers that range.
@pytest.mark.parametrize("scale", [1.0])
def test_at_the_paper_s_point_the_time_integration_bounds_the_balance_s_truncation(scale):
    """The paper's unbalance at 75 Hz with both bearings at their Q_T, where the film is most
    nonlinear (60 x 40 films: the difference does not need the 100 x 100 mesh). Started on the balance's orbit,
    the time integration of the same films (all harmonics; implicit coupling, its step converged: 2.5e-5 and
    1.25e-5 s agree to 0.1 %) settles within two revolutions on a periodic orbit whose 1X differs from the
    balance's (5 harmonics, 24 points): the correction (1X minus the linear 1X) by 13 % of itself at the paper's
    unbalance, 4 % at 0.6 x (measured). The budget's term for it (`ModelBudget.orbit_truncation`: 0.45 share^2 of
    the correction's norm per real component, share = its size over the 1X's) covers the error's RMS; the older
    3 % of the correction did not."""
    from lubeviz.identify.forward.budget import ModelBudget
    from lubeviz.model.machine import load_machine
    from lubeviz.rotor.film_bearings import flooded_thresholds

    machine = load_machine()
    machine.bearings = [b.copy(n_circumferential=60, n_axial=40) for b in machine.bearings]
    bearings = film_bearings(machine, list(flooded_thresholds(machine)), coefficients="fixed-pattern")
    rotor = rotor_from_machine(machine)
    ub = _unbalance(machine, scale)
    hb = orbit_balance(rotor, bearings, ub, nodes=NODES, tol=1e-8)
    tr = time_response(rotor, bearings, ub, duration=0.08, dt=2.5e-5, nodes=NODES, start=hb.state(0.0),
                       implicit=True)
    w = bearings.omega
    last = tr.t >= tr.t[-1] - 3 * 2 * np.pi / w - 1e-12  # the last three revolutions
    td, ours, lin = [], [], []
    for k, node in enumerate(NODES):
        for sig, mine, linear in zip(tr.node_xy(node), (hb.x, hb.y), (hb.linear_x, hb.linear_y)):
            s = sig[last]
            td.append(amplitude_ratio(tr.t[last], s - s.mean(), w, 1.0))
            ours.append(mine[1, k])
            lin.append(linear[k])
    td, ours, lin = np.array(td), np.array(ours), np.array(lin)
    correction = ours - lin
    size = np.linalg.norm(correction)
    share = size / np.linalg.norm(ours)
    error = np.concatenate([(ours - td).real, (ours - td).imag])  # the correction's error (the linear part is the same)
    rms = np.sqrt(np.mean(error**2))  # per real component, as the budget states it
    budget = ModelBudget()
    term = max(budget.orbit_defect, budget.orbit_truncation * share**2) * size
    assert rms <= term
    assert rms > 0.005 * size  # the truncation is seen
    if scale == 1.0:  # ... and at the paper's unbalance the older 3 % of the correction did not cover it
        assert rms > budget.orbit_defect * size
        assert term < 1.3 * rms  # nor does the term overstate it
    # the harmonics it leaves out: with more (a chain of balances, each started from the last) the balance's 1X
    # comes closer to the time integration's at the paper's unbalance, slowly (the journal's velocity turns sharply
    # where the film is thinnest, its lines fall off as 1/h up to ~15X): 4.8 -> 2.9 % of the correction with 16
    # harmonics (measured). At 0.6 x nothing changes (1.5 / 1.6 %, not run: CI time): what is left there is not the
    # harmonics.
    if scale != 1.0:
        return
    finer = hb
    for harmonics in (8, 12, 16):  # each a start for the next, which needs its orbit to 1e-3 of the 1X only
        finer = orbit_balance(rotor, bearings, ub, nodes=NODES, harmonics=harmonics, points=4 * harmonics,
                              tol=1e-5 if harmonics == 16 else 1e-3, start=finer)
    mine = np.array([finer.x[1, 0], finer.y[1, 0], finer.x[1, 1], finer.y[1, 1]])
    rms_16 = np.sqrt(np.mean(np.concatenate([(mine - td).real, (mine - td).imag]) ** 2))
    print(f"scale {scale}: 1X error RMS / correction: 5 harmonics {rms / size:.3f}, 16 harmonics {rms_16 / size:.3f}")
    assert rms_16 < 0.7 * rms
    # the budget's term for a 16-harmonic balance (`budget.truncation_factor`) covers it, and does not overstate it
    from lubeviz.identify.forward.budget import truncation_factor

    term_16 = max(budget.orbit_defect, truncation_factor(16) * budget.orbit_truncation * share**2) * size
    assert rms_16 <= term_16 < 1.3 * rms_16


def test_a_balance_that_does_not_settle_says_whether_it_came_close_to_an_orbit(coarse):
    """Stopped short, the balance says which failure it is: still far from an orbit (a change above INEXACT_ABOVE
    of the 1X: the orbit too large for one near the linear) or close to one and no closer (a stall, as the
    24-harmonic balance does on some large-orbit records), with its harmonics, last change and tolerance."""
    machine, rotor, bearings = coarse
    ub = _unbalance(machine, 0.2)
    with pytest.raises(ConvergenceError, match=r"5 harmonics did not settle in 0 Newton steps \(last change 7"
                                               r".*too large for a periodic solution"):
        orbit_balance(rotor, bearings, ub, nodes=NODES, max_iter=0)  # the linear orbit: 7 % off
    with pytest.raises(ConvergenceError, match=r"tolerance 1e-14\): it came within 1e-02 of an orbit and no closer"):
        orbit_balance(rotor, bearings, ub, nodes=NODES, max_iter=2, tol=1e-14)  # 0.4 % after two steps
