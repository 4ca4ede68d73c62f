"""The Rotor page's large-orbit view (issue 11, item 6), without a browser: the page object is built and its
button's handler awaited as the server would.

What a student sees: at a small unbalance the nonlinear orbit is the linear model's (the film is linear in
small motions) and its 2X line is small; the 2X line grows in proportion to the unbalance (a weak
nonlinearity: 2X goes as the square of the orbit) and the static shift as its square; the result says
"stale" when the flows, the node or the unbalance scale move after it was computed, until recomputed; a
balance that fails shows its message beside the button and the page keeps working.

The flows are above Q_T (900 ml/min, Q_T ~ 546): there the film force is smooth in the motion and the
weak-nonlinearity laws hold (at Q_T itself, the film's starved/flooded edge, 2X/1X was seen to stay near
13-16 % from ×0.25 to ×1). Coarse balances (0X-3X, 12 points per revolution) keep the module to about half
a minute; the page's default is the module's HARMONICS, POINTS.
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from lubeviz.app import resources, rotor_page
from lubeviz.identify.forward import explore
from lubeviz.app.rotor_page import RotorPage
from lubeviz.errors import ConvergenceError
from lubeviz.model.operating import operating_point
from lubeviz.rotor.film_bearings import film_bearings
from lubeviz.rotor.orbit_balance import HARMONICS, POINTS
from lubeviz.rotor.response import machine_unbalance, unbalance_response
from lubeviz.units import M3S_PER_MLMIN

FLOODED_MLMIN = 900.0
COARSE = (3, 12)
NODE = 6  # the page's default node, a bearing-centre measurement plane
SCALES = (0.25, 0.5, 1.0)


def run(coroutine):
    """Await a handler as the server would, on its own event loop in a thread: the browser tests' sync
    Playwright keeps a loop running in the main thread for the whole session, where asyncio.run refuses."""
    with ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, coroutine).result()


def make_page() -> RotorPage:
    machine = resources.machine()
    q = FLOODED_MLMIN * M3S_PER_MLMIN
    op = operating_point(machine, flows=(q, q))
    return RotorPage(machine, op, _orbit_resolution=COARSE)


def compute(page: RotorPage, scale: float):
    """Set the unbalance scale and press the button; the OrbitBalance the page now shows."""
    page.unbalance_scale = scale
    run(page._on_large_orbit())
    assert not page._large_orbit_error.visible, page._large_orbit_error.object
    return page._large_orbit_data["result"]


def size_1x(x, y) -> float:
    """The 1X orbit's size sqrt(|X1|^2 + |Y1|^2)."""
    return math.hypot(abs(x), abs(y))


@pytest.fixture(scope="module")
def orbits():
    """That page, {scale: OrbitBalance} from one page at 900 ml/min, node 6, and {scale: its OrbitStability}."""
    page = make_page()
    r, stab = {}, {}
    for s in SCALES:
        r[s] = compute(page, s)
        stab[s] = page._large_orbit_data["orbit_stability"]
    return page, r, stab


@pytest.fixture(scope="module")
def linear_1x():
    """The linear model's 1X size at node 6 under the machine's unbalance (the response module's own solve,
    on the film bearings' K, C at the same flows): the nonlinear orbit must tend to it as the unbalance
    shrinks."""
    machine = resources.machine()
    omega = 2 * math.pi * machine.operating_speed
    q = FLOODED_MLMIN * M3S_PER_MLMIN
    fb = film_bearings(machine, [q, q], omega)
    resp = unbalance_response(resources.rotor(machine), omega, machine_unbalance(machine), fb.coefficients,
                              nodes=(NODE,))
    return size_1x(resp.x[0], resp.y[0])


def test_the_page_default_is_the_modules_resolution():
    machine = resources.machine()
    page = RotorPage(machine, operating_point(machine))
    assert page._orbit_resolution == (HARMONICS, POINTS)
    assert page.unbalance_scale == 1.0 and page.param.unbalance_scale.bounds == (0.25, 2.0)


@pytest.mark.slow  # shares the module's three balances (about 20 s)
def test_a_small_orbit_is_the_linear_models_orbit(orbits, linear_1x):
    _, r, _ = orbits
    small = r[0.25]
    assert small.nodes == (NODE,)
    nonlinear = size_1x(small.x[1, 0], small.y[1, 0])
    assert nonlinear / (0.25 * linear_1x) == pytest.approx(1.0, abs=0.03)  # the film is linear in small motions
    assert small.harmonic_ratio(2, 0) < 0.06  # and its 2X line is small


@pytest.mark.slow  # shares the module's three balances (about 20 s)
def test_2x_grows_in_proportion_to_the_unbalance_and_the_shift_as_its_square(orbits):
    _, r, _ = orbits
    ratio = {s: r[s].harmonic_ratio(2, 0) for s in SCALES}
    assert 1.4 < ratio[0.5] / ratio[0.25] < 2.8  # weak nonlinearity: 2X ~ orbit^2, so 2X/1X ~ orbit
    assert ratio[1.0] > 1.4 * ratio[0.25]
    # the journals' static shift ~ orbit^2: x4 for x2 unbalance (generously)
    shift = {s: np.hypot(r[s].bearing_x[0].real, r[s].bearing_y[0].real) for s in SCALES}
    assert np.all(2.5 < shift[0.5] / shift[0.25]) and np.all(shift[0.5] / shift[0.25] < 6.0)
    # the orbit reaches further into the clearance as the unbalance grows
    assert r[0.25].max_eccentricity < r[0.5].max_eccentricity < r[1.0].max_eccentricity < 0.95


@pytest.mark.slow  # shares the module's three balances (about 20 s)
def test_the_page_shows_orbit_lines_and_numbers(orbits):
    page, r, stab = orbits
    shown = r[SCALES[-1]]
    plot = page._large_orbit_pane.object
    labels = {el.label for el in plot}
    assert {"linear model (K, C at equilibrium)", "nonlinear film (static shift included)"} <= labels
    assert f"Orbit at node {NODE}, unbalance ×1" in plot.opts.get().kwargs["title"]
    lines = page._large_orbit_lines.object
    spikes = next(el for el in lines if el.label == "nonlinear film")
    orders = spikes.dimension_values(0)
    assert sorted(orders) == list(range(-COARSE[0], COARSE[0] + 1))  # 0X and ±1X … ±3X
    amp = dict(zip(orders, spikes.dimension_values(1)))
    assert amp[1] == max(amp.values())  # the forward 1X dominates
    summary = page._large_orbit_summary.object
    for item in ("2X / 1X at node 6", "1X\\| nonlinear / linear", "static shift (0X), journal 1",
                 "static shift (0X), journal 2", "largest eccentricity", "Newton steps", "stability of this orbit"):
        assert item in summary, (item, summary)
    # the orbit's Floquet multipliers: a small orbit damps a 0.5X disturbance faster than a large one
    assert stab[1.0].describe() in summary  # the orbit shown
    assert stab[0.25].state == "stable"
    small, large = (stab[s].half_order_multiplier for s in (0.25, 1.0))
    assert small is None or (large is not None and small < large)
    assert not page._large_orbit_stale.visible


def test_the_orbit_is_stale_after_a_change_until_recomputed(orbits, monkeypatch):
    """The page's bookkeeping, not the balance: its computation answers with the module's orbits (at the scale and
    the node asked for), as the page's own would, without solving them again (2 balances, 15-28 s)."""
    _, r, stab = orbits
    with_equilibrium = orbits[0]._large_orbit_data  # the module page's last answer holds the equilibrium's stability
    asked = []

    def known(machine, rotor, flows, speed_hz, node, scale, resolution, progress):
        asked.append((node, scale, resolution))
        return dataclasses.replace(r[scale], nodes=(node,)), with_equilibrium["stability"], stab[scale]

    monkeypatch.setattr(rotor_page, "large_orbit", known)
    page = make_page()
    compute(page, 0.25)
    assert not page._large_orbit_stale.visible

    async def move_flow():
        page.op.q1 = (FLOODED_MLMIN - 30.0) * M3S_PER_MLMIN
        await asyncio.sleep(0)

    run(move_flow())
    stale = page._large_orbit_stale
    assert stale.visible and "the flows have changed" in stale.object
    assert "(stale)" in page._large_orbit_pane.object.opts.get().kwargs["title"]
    page.unbalance_scale = 0.5
    page.node = 5
    assert "the unbalance scale has changed" in stale.object and "the node has changed" in stale.object
    compute(page, 0.5)
    assert not stale.visible
    assert "(stale)" not in page._large_orbit_pane.object.opts.get().kwargs["title"]
    assert page._large_orbit_data["result"].nodes == (5,)  # computed at the node shown
    assert asked == [(NODE, 0.25, COARSE), (5, 0.5, COARSE)]


def test_a_failed_balance_shows_its_message_and_the_page_keeps_working(monkeypatch):
    page = make_page()

    def wall(*args, **kwargs):
        raise ConvergenceError("bearing 1: the orbit reaches 0.96 of the clearance")

    monkeypatch.setattr(explore, "orbit_balance", wall)  # the headless computation the page runs
    page.unbalance_scale = 2.0
    run(page._on_large_orbit())  # does not raise
    error = page._large_orbit_error
    assert error.visible and "reaches 0.96 of the clearance" in error.object
    assert "smaller unbalance scale" in error.object
    assert page._large_orbit_data is None and "failed" in page.large_orbit_jobs.status
    assert not page._large_orbit_button.disabled


def test_the_numbers_state_the_equilibrium_s_stability_and_no_whirl_below_the_threshold(orbits):
    """75 Hz, 900 ml/min: below the instability threshold (BENCHMARKS "stability")."""
    page, _, _ = orbits
    assert "below the instability threshold" in page._large_orbit_summary.object
    assert not page._large_orbit_whirl.visible


@pytest.mark.slow
def test_above_the_threshold_the_page_says_the_periodic_orbit_is_not_what_the_machine_shows():
    """100 Hz at 1.25 Q_T (threshold 88.6 Hz): the equilibrium is unstable (checked on its own: an eigenvalue
    problem), and the page says so beside the orbit, with the whirl's order."""
    from lubeviz.rotor.film_bearings import flooded_thresholds
    from lubeviz.rotor.whirl import equilibrium_stability

    machine = resources.machine()
    omega = 2 * math.pi * 100.0
    q = 1.25 * flooded_thresholds(machine, omega)
    assert equilibrium_stability(resources.rotor(machine), film_bearings(machine, list(q), omega)).unstable
    op = operating_point(machine, speed=100.0, flows=(float(q[0]), float(q[1])))
    page = RotorPage(machine, op, _orbit_resolution=COARSE)
    page.unbalance_scale = 0.25
    run(page._on_large_orbit())
    assert not page._large_orbit_error.visible, page._large_orbit_error.object
    whirl = page._large_orbit_whirl
    assert whirl.visible and "Oil whirl" in whirl.object and "above the instability threshold" in whirl.object
    assert "not what the machine shows" in whirl.object
