"""Dimensionless coefficient tables over (S, r): the scaling law they rest on (direct solves), views
that equal direct sweeps on a slice and stay close to direct solves between slices, slices shared by
bearings that differ only in oil or clearance, corrupt slices rebuilt, queries outside the range refused."""

import math

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed
from lubeviz.film.sweep import sweep_supply
from lubeviz.identify.tables import dimensionless
from lubeviz.identify.tables.cache import StaleCacheWarning, bearing_view, geometry_table
from lubeviz.identify.tables.supply import DEFAULT_SPAN
from lubeviz.identify.tables.dimensionless import (flow_scale, geometry_values, lagrange_weights, sommerfeld_nodes,
                                            sommerfeld_number, stencil)
from lubeviz.model.bearing import Bearing

POINTS = 9
OMEGA = 2 * math.pi * 75.0


def coarse_bearing(**changes) -> Bearing:
    """The paper's bearing on a 40 x 20 mesh (fast; the scaling law holds on any mesh)."""
    return Bearing(n_circumferential=40, n_axial=20, **changes)


def load_for(bearing: Bearing, s: float, omega: float = OMEGA) -> np.ndarray:
    """The vertical load that puts `bearing` at Sommerfeld number s."""
    w = bearing.viscosity * omega / (2 * math.pi) * bearing.length * bearing.diameter / s \
        * (bearing.radius / bearing.clearance) ** 2
    return np.array([0.0, -w])


def _dimensionless_state(eq, bearing, omega, w):
    c = bearing.clearance
    return np.concatenate([eq.position / c, eq.coefficients.K.ravel() * c / w,
                           eq.coefficients.C.ravel() * c * omega / w])


def test_equilibrium_and_coefficients_depend_only_on_s_and_the_dimensionless_supply():
    """mu x 1.7, c x 1.3, Omega x 0.8 with W x fm fo / fc^2 (S unchanged) and Q x fo fc (qbar unchanged):
    the same eps, K c / W and C c Omega / W, starved and flooded, to solver tolerance."""
    fm, fc, fo = 1.7, 1.3, 0.8
    a = coarse_bearing()
    b = a.copy(viscosity=fm * a.viscosity, clearance=fc * a.clearance)
    wa = 3270.0
    wb = wa * fm * fo / fc**2
    assert sommerfeld_number(b, [0, -wb], fo * OMEGA) == pytest.approx(sommerfeld_number(a, [0, -wa], OMEGA), rel=1e-14)
    qa = 400e-6 / 60
    for feed_a, feed_b in ((Feed.flow(qa), Feed.flow(qa * fo * fc)), (Feed.flooded(), Feed.flooded())):
        ea = find_equilibrium(a, OMEGA, [0, -wa], feed_a, tol=1e-12)
        eb = find_equilibrium(b, fo * OMEGA, [0, -wb], feed_b, tol=1e-12)
        assert ea.converged and eb.converged
        np.testing.assert_allclose(_dimensionless_state(eb, b, fo * OMEGA, wb), _dimensionless_state(ea, a, OMEGA, wa),
                                   rtol=1e-7, atol=1e-9)
        assert eb.film.side_leakage / flow_scale(b, fo * OMEGA) == pytest.approx(
            ea.film.side_leakage / flow_scale(a, OMEGA), rel=1e-7)


def test_lagrange_weights_reproduce_cubics_and_the_stencil_brackets_s():
    nodes = np.log(sommerfeld_nodes())
    idx = stencil(np.exp(nodes), 1.9)
    x = nodes[idx]
    w = lagrange_weights(x, math.log(1.9))
    f = lambda t: 2 * t**3 - t + 0.5  # noqa: E731
    assert np.dot(w, f(x)) == pytest.approx(f(math.log(1.9)), rel=1e-12)
    assert x[1] <= math.log(1.9) < x[2]


def test_view_on_a_grid_slice_equals_the_direct_sweep(tmp_path):
    b = coarse_bearing()
    s = float(sommerfeld_nodes()[40])  # S = 1.82, next to the paper's 1.9
    load = load_for(b, s)
    view = bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path)
    q_t, _ = flooded_threshold(b, OMEGA, load)
    assert view.q_threshold == pytest.approx(q_t, rel=1e-7)
    direct = sweep_supply(b, OMEGA, load, view.q)
    np.testing.assert_allclose(view.K, direct.K, rtol=1e-6, atol=1e-6 * np.abs(direct.K).max())
    np.testing.assert_allclose(view.C, direct.C, rtol=1e-6, atol=1e-6 * np.abs(direct.C).max())
    np.testing.assert_allclose(view.position, direct.position, rtol=1e-6, atol=1e-9 * b.clearance)
    assert view.q_min == pytest.approx(DEFAULT_SPAN[0] * q_t, rel=1e-6) and view.q_max == pytest.approx(DEFAULT_SPAN[1] * q_t, rel=1e-6)


def test_bearings_differing_in_viscosity_share_the_slices(tmp_path, builds):
    b = coarse_bearing()
    load = load_for(b, 1.9)
    bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path, workers=1)
    assert len(builds) == 4
    # a slightly thinner oil stays inside the same interval of S: no film solve at all
    thinner = bearing_view(b.copy(viscosity=0.99 * b.viscosity), load, OMEGA, points=POINTS, directory=tmp_path)
    assert len(builds) == 4
    assert thinner.key != bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path).key
    # an oil thicker by one node step moves the stencil by one slice: one new solve, three shared
    step = math.exp(dimensionless.COARSE_STEP)
    bearing_view(b.copy(viscosity=step * b.viscosity), load, OMEGA, points=POINTS, directory=tmp_path, workers=1)
    assert len(builds) == 5
    # a clearance or a speed that give an S already covered cost nothing either
    bearing_view(b.copy(clearance=b.clearance / math.sqrt(step)), load, OMEGA, points=POINTS, directory=tmp_path)
    bearing_view(b, load, OMEGA * step, points=POINTS, directory=tmp_path)
    assert len(builds) == 5


def test_the_paper_machine_at_its_operating_speed_needs_one_slice_for_both_bearings(tmp_path, builds):
    """The S grid is anchored at the paper's operating point: both bearings (loads 3e-5 apart) sit within
    SNAP_LN of that node and are served by its slice alone."""
    from lubeviz.identify.tables.cache import machine_tables
    from lubeviz.model.machine import load_machine

    m = load_machine()
    m.bearings = [b.copy(n_circumferential=40, n_axial=20) for b in m.bearings]
    t1, t2 = machine_tables(m, points=POINTS, directory=tmp_path, workers=1)
    assert len(builds) == 1 and builds[0] == pytest.approx(dimensionless.S_ANCHOR, rel=1e-12)
    from lubeviz.rotor.statics import bearing_static_loads

    w1, w2 = (-load[1] for load in bearing_static_loads(m))
    np.testing.assert_allclose(t2.K, t1.K * (w2 / w1), rtol=1e-13)  # one slice, scaled by each bearing's load


def test_corrupt_slice_file_is_rebuilt_with_a_warning(tmp_path, builds):
    b = coarse_bearing()
    load = load_for(b, 1.9)
    good = bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path, workers=1)
    path = sorted((tmp_path / "slices").glob("*.npz"))[2]
    path.write_bytes(path.read_bytes()[:100])
    with pytest.warns(StaleCacheWarning, match=path.name):
        again = bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path, workers=1)
    assert len(builds) == 5
    np.testing.assert_array_equal(again.K, good.K)
    np.testing.assert_array_equal(again.C, good.C)


def test_queries_outside_the_sommerfeld_range_are_refused(tmp_path):
    b = coarse_bearing()
    lo, hi = dimensionless.S_RANGE
    for s in (0.5 * sommerfeld_nodes()[0], 2.0 * sommerfeld_nodes()[-1]):
        with pytest.raises(InputError, match="outside the dimensionless table's range"):
            bearing_view(b, load_for(b, s), OMEGA, points=POINTS, directory=tmp_path)
    assert sommerfeld_nodes()[0] <= lo and sommerfeld_nodes()[-1] >= hi
    with pytest.raises(InputError, match="non-zero load"):  # a leaning load is taken (test_leaning_load.py)
        bearing_view(b, [0.0, 0.0], OMEGA, points=POINTS, directory=tmp_path)
    with pytest.raises(InputError, match="vertical loads"):  # the dimensionless tables themselves hold -Y only
        dimensionless._check_load([100.0, -3000.0])


def test_evaluate_matches_the_views(tmp_path):
    b = coarse_bearing()
    s = [1.7, 2.3]
    table = geometry_table(b, s, points=POINTS, directory=tmp_path)
    r = np.array([0.3, 0.9, 1.0, 1.2, 1.9])
    for sv in s:
        load = load_for(b, sv)
        view = bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path)
        w, c = -load[1], b.clearance
        v = table.evaluate(sv, r)
        K, C = view.coefficients(r * view.q_threshold)
        np.testing.assert_allclose(v[:, 0:4] * w / c, K.reshape(-1, 4), rtol=1e-10)
        np.testing.assert_allclose(v[:, 4:8] * w / (c * OMEGA), C.reshape(-1, 4), rtol=1e-10)
        assert table.q_threshold(sv) * flow_scale(b, OMEGA) == pytest.approx(view.q_threshold, rel=1e-12)


@pytest.mark.slow
def test_views_between_slices_stay_close_to_direct_solves():
    """10 seeded (S, Q) points between slices (S in 1-3, Q 30-190 % Q_T; coarse mesh, default ratio grid):
    the table's K, C against direct equilibria. The error (cubic in ln S, spline in r, and the coarse
    film's own roughness) stays below 0.5 % of the largest entry. The views come from the suite's cache, whose
    slices are seeds (`tests/seeds`): the direct solves are what is new here."""
    rng = np.random.default_rng(7)
    b = coarse_bearing()
    worst = 0.0
    for s, ratio in zip(np.exp(rng.uniform(math.log(1.0), math.log(3.0), 10)), rng.uniform(0.3, 1.9, 10)):
        load = load_for(b, s)
        view = bearing_view(b, load, OMEGA)
        q = ratio * view.q_threshold
        eq = find_equilibrium(b, OMEGA, load, Feed.flow(q))
        K, C = view.coefficients(q)
        worst = max(worst, np.abs(K - eq.coefficients.K).max() / np.abs(eq.coefficients.K).max(),
                    np.abs(C - eq.coefficients.C).max() / np.abs(eq.coefficients.C).max())
    assert worst < 5e-3


@pytest.mark.parametrize("workers", [1, 2])
def test_a_cancelled_build_keeps_its_finished_slices(tmp_path, builds, workers):
    """Resumable: slices finished before `Cancelled` are on disk and not solved again."""
    from lubeviz.progress import Cancelled

    b = coarse_bearing()
    load = load_for(b, 1.9)

    per = dimensionless.ratio_grid(DEFAULT_SPAN, POINTS).size  # a slice's equilibria (more than POINTS: the span's
    # ends past 0.25 and 2 Q_T)

    def cancel_after_two_slices(done, total, label=""):
        if done > 2 * per + 1:
            raise Cancelled("stop")

    with pytest.raises(Cancelled):
        bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path, workers=workers,
                     progress=cancel_after_two_slices)
    kept = len(list((tmp_path / "slices").glob("*.npz")))
    assert 1 <= kept < 4 and not list(tmp_path.rglob("*.tmp"))
    before = len(builds)
    bearing_view(b, load, OMEGA, points=POINTS, directory=tmp_path, workers=1)
    assert len(builds) - before == 4 - kept
