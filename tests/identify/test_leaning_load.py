"""A static load that leans from the vertical (a bearing out of line, a shaft on three or more supports): the
tables hold vertical loads, so a leaning one is taken in the frame where it is vertical, its grooves turned back
by the lean, and the table turned back to the machine's frame (`identify.tables.cache.film_frame`). Checked
against direct film solves under the leaning load itself, which share nothing with the tables but the film."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed
from lubeviz.identify.tables.cache import bearing_view, film_frame
from lubeviz.model.bearing import Bearing, Groove

OMEGA = 2 * math.pi * 75.0
RATIOS = (0.45, 0.9, 1.15, 1.7)


def coarse(**changes) -> Bearing:
    return Bearing(n_circumferential=40, n_axial=20, **changes)


def leaning(bearing: Bearing, s: float, lean_deg: float) -> np.ndarray:
    """The load of Sommerfeld number s leaning `lean_deg` from -Y towards +X."""
    w = bearing.viscosity * OMEGA / (2 * math.pi) * bearing.length * bearing.diameter / s \
        * (bearing.radius / bearing.clearance) ** 2
    b = math.radians(lean_deg)
    return w * np.array([math.sin(b), -math.cos(b)])


def _worst(view, bearing, load) -> tuple[float, float]:
    """Largest error of K, C (over the largest entry) and of the position (over the clearance) against direct
    equilibria under `load` at RATIOS of the view's Q_T."""
    worst_kc, worst_pos = 0.0, 0.0
    for r in RATIOS:
        q = r * view.q_threshold
        eq = find_equilibrium(bearing, OMEGA, load, Feed.flow(q))
        K, C = view.coefficients(q)
        worst_kc = max(worst_kc, np.abs(K - eq.coefficients.K).max() / np.abs(eq.coefficients.K).max(),
                       np.abs(C - eq.coefficients.C).max() / np.abs(eq.coefficients.C).max())
        worst_pos = max(worst_pos, np.abs(view.journal_position(q) - eq.position).max() / bearing.clearance)
    return worst_kc, worst_pos


@pytest.mark.parametrize("lean_deg", [20.0, -35.0])
def test_a_leaning_load_s_table_is_the_film_under_that_load(lean_deg):
    """K, C, the journal's position and Q_T of the view under a load leaning 20 deg one way or 35 deg the other
    agree with direct solves under that load as a vertical load's view agrees with its own (0.5 % of the largest
    entry, the tables' accuracy on this mesh); the vertical load's view is several times further off. The views come
    from the suite's cache, whose slices are seeds (`tests/seeds`): the direct solves are what is new here."""
    b = coarse()
    load = leaning(b, 1.6, lean_deg)
    view = bearing_view(b, load, OMEGA)
    q_t, _ = flooded_threshold(b, OMEGA, load)
    assert view.q_threshold == pytest.approx(q_t, rel=5e-3)
    kc, pos = _worst(view, b, load)
    assert kc < 5e-3 and pos < 5e-3
    upright = bearing_view(b, np.array([0.0, -np.hypot(*load)]), OMEGA)
    kc_up, pos_up = _worst(upright, b, load)
    assert kc_up > 5 * max(kc, 1e-3) and pos_up > 5 * max(pos, 1e-3)


def test_two_grooves_and_a_lean_of_180_degrees_is_the_same_bearing_upside_down():
    """A bearing with grooves at 0 and 180 deg under a load leaning 180 deg (pressed upwards) is the same film as
    under the vertical load turned by half a turn: K and C equal (R K R^T with R = -I), the position opposite."""
    b = coarse(other_grooves=[Groove(math.pi, 16.2e-3, 35.0e-3)])
    down = leaning(b, 1.6, 0.0)
    seen, load, turn = film_frame(b, -down)
    assert turn is not None and np.allclose(load, down)
    # the lean is taken to 1e-9 rad (`LEAN_DECIMALS`): the grooves within that of 0 and 180 deg
    assert sorted(abs(g.angle) for g in seen.grooves) == pytest.approx([0.0, math.pi], abs=1e-9)
    a = bearing_view(b, down, OMEGA)  # from the suite's cache (seeded slices), as above
    u = bearing_view(b, -down, OMEGA)
    # 1e-8: the half turn is taken as pi to 1e-9 rad, and K, C turn with it (3.5e-9 measured)
    np.testing.assert_allclose(u.K, a.K, rtol=1e-8, atol=1e-8 * np.abs(a.K).max())
    np.testing.assert_allclose(u.C, a.C, rtol=1e-8, atol=1e-8 * np.abs(a.C).max())
    np.testing.assert_allclose(u.position, -a.position, rtol=1e-8, atol=1e-14)


@pytest.mark.parametrize("lean_deg", [0.0, 0.08, -0.09])
def test_a_vertical_load_and_a_lean_below_a_tenth_of_a_degree_are_not_turned(lean_deg):
    """Below 0.1 deg a lean moves K and C by less than the tables' own error (2.3 % per degree, measured on the
    fan's bearing A): the bearing's own table, under the load's magnitude."""
    b = coarse()
    load = leaning(b, 1.6, lean_deg)
    seen, vertical, turn = film_frame(b, load)
    assert seen is b and turn is None and vertical[0] == 0.0 and vertical[1] == pytest.approx(-np.hypot(*load))
    assert film_frame(b, leaning(b, 1.6, 0.12))[2] is not None


def test_a_changed_leaning_bearing_from_the_slices_in_memory_is_the_cached_view():
    """A fit with the oil or the loads free asks a bearing under a leaning load for its values at other
    viscosities, clearances and loads: from the slices in memory (`SliceStack`, `scaled_view`) the same numbers
    as `bearing_view` of the changed bearing under its leaning load."""
    from lubeviz.identify.forward.chain import BearingSource
    from lubeviz.model.machine import load_machine

    m = load_machine()
    m.bearings = [b.copy(n_circumferential=40, n_axial=20) for b in m.bearings]
    src = BearingSource(m, 0, OMEGA, load=leaning(m.bearings[0], 1.2, 12.0))
    b = src.bearing
    first = src.view(0.9)  # the slow path: loads the slices (of the turned bearing) and keeps them
    assert src._table is not None and src._turn is not None
    f = np.array([0.9031, 0.897, 0.92])
    c = b.clearance * np.array([1.0, 1.004, 0.998])
    lf = np.array([1.0, 1.02, 0.97])
    qs = first.q_threshold * np.array([0.7, 1.0, 1.6])
    K, C, pos = src.evaluate(qs, f, c, lf)
    for k in range(f.size):
        slow = bearing_view(b.copy(viscosity=b.viscosity * f[k], clearance=c[k]), src.load * lf[k], OMEGA)
        q = np.clip(qs[k], slow.q_min, slow.q_max)
        K0, C0 = slow.coefficients(q)
        np.testing.assert_allclose(K[k], K0, rtol=1e-9, atol=1e-9 * np.abs(K0).max())
        np.testing.assert_allclose(C[k], C0, rtol=1e-9, atol=1e-9 * np.abs(C0).max())
        np.testing.assert_allclose(pos[k], slow.journal_position(q), rtol=1e-9, atol=1e-15)
        fast = src.view(f[k], c[k], lf[k])
        np.testing.assert_allclose(fast.coefficients(q)[0], K0, rtol=1e-9, atol=1e-9 * np.abs(K0).max())


@pytest.mark.parametrize("lean_deg", [-1.08289, 5.0841, 20.0])
def test_a_lean_s_last_bits_do_not_change_its_table(lean_deg):
    """A lean is a computed angle whose last bits are the host's (another CPU moved the rig's -1.08 deg by 1.4e-14
    rad, and every slice of its turned table had to be built again): loads a few ulps apart see the same bearing, so
    the same slices' keys; a lean 1e-6 rad away is another bearing."""
    from lubeviz.identify.tables import dimensionless

    b = coarse(other_grooves=[Groove(math.pi, 0.01, 0.04)])
    load = leaning(b, 1.6, lean_deg)
    seen, _, turn = film_frame(b, load)
    for ulps in (1, -3, 40):
        nudged = load * np.array([1.0 + ulps * 2.2e-16, 1.0])
        seen2, _, turn2 = film_frame(b, nudged)
        assert dimensionless.geometry_values(seen2) == dimensionless.geometry_values(seen)
        np.testing.assert_array_equal(turn2, turn)
    turned = film_frame(b, leaning(b, 1.6, lean_deg + math.degrees(1e-6)))[0]
    assert dimensionless.geometry_values(turned) != dimensionless.geometry_values(seen)
