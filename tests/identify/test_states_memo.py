"""The load shift's remembered states (`chain._StatesMemo`) and a repeated point's single evaluation
(`ForwardChain.bearing_states`): the answers are the ones computed afresh, bit for bit, and an effect that changes the
bearings is never served another chain's films."""

from __future__ import annotations

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.forward.budget import model_sensitivity
from lubeviz.identify.forward.chain import ForwardChain, _StatesMemo
from lubeviz.identify.forward.model import plane_features
from lubeviz.model.machine import load_machine

FAN = "models/three_bearing_fan.toml"


@pytest.fixture(scope="module")
def fan():
    m = load_machine(FAN)
    planes = m.measurement_planes
    return m, [p.node for p in planes], [p.probe_angles_deg for p in planes]


def _chain(fan, effects=()):
    m, nodes, angles = fan
    return ForwardChain(m, m.operating_speed, nodes, effects, probe_angles_deg=angles)


def _lattice(chain, points=300, seed=3):
    theta = np.tile(chain.start(), (points, 1))
    rng = np.random.default_rng(seed)
    theta[:, :chain.n_flows] = np.asarray(chain.q_threshold) * rng.uniform(0.4, 1.6, (points, chain.n_flows))
    return theta


def test_a_lattice_served_from_the_memo_is_the_lattice_computed_afresh(fan):
    plain = _chain(fan)
    names = plane_features(plain.n_planes)
    pts = _lattice(plain)
    assert len(pts) >= _StatesMemo.POINTS
    first = plain.features(pts, names)
    probe = plain.with_effects((parse_effect("probe_gain:channel=y2,gain=1.1"),))
    assert probe._states_memo is plain._states_memo  # shared by the chains made from one another
    stored = len(plain._states_memo._store)
    theta = np.tile(probe.start(), (len(pts), 1))
    theta[:, :probe.n_flows] = pts[:, :plain.n_flows]
    served = probe.features(theta, names)
    assert len(plain._states_memo._store) == stored  # a hit, nothing new stored
    fresh = _chain(fan, (parse_effect("probe_gain:channel=y2,gain=1.1"),)).features(theta, names)
    np.testing.assert_array_equal(served, fresh)
    # the plain chain's own second call: the same bits, and the arrays handed out are copies
    states = plain.bearing_states(pts, pts.shape[:1])
    states[0][1][0][:] = np.nan
    np.testing.assert_array_equal(plain.features(pts, names), first)


def test_an_effect_that_changes_the_bearings_gets_its_own_films(fan):
    plain = _chain(fan)
    names = plane_features(plain.n_planes)
    pts = _lattice(plain, seed=4)
    before = plain.features(pts, names)
    oil = plain.with_effects((parse_effect("viscosity:factor=0.9"),))
    theta = np.tile(oil.start(), (len(pts), 1))
    theta[:, :oil.n_flows] = pts[:, :plain.n_flows]
    thinner = oil.features(theta, names)
    fresh = _chain(fan, (parse_effect("viscosity:factor=0.9"),)).features(theta, names)
    np.testing.assert_array_equal(thinner, fresh)
    assert np.max(np.abs(thinner - before)) > 1e-3 * np.max(np.abs(before))  # thinner oil moves the features


def test_one_point_repeated_is_evaluated_once_with_the_same_bits(fan):
    chain = _chain(fan, (parse_effect("clearance:bearing=1,clearance_um=95"),))
    theta = chain.start()
    theta[:chain.n_flows] = 0.7 * np.asarray(chain.q_threshold)
    repeated = np.broadcast_to(theta, (5, theta.size))
    assert repeated.strides[0] == 0
    one = chain.bearing_states(repeated, (5,))
    tiled = chain.bearing_states(np.tile(theta, (5, 1)), (5,))
    for (c1, s1), (c2, s2) in zip(one, tiled):
        for a, b in zip(s1, s2):
            np.testing.assert_array_equal(a, b)
        for a, b in zip(c1, c2):
            np.testing.assert_array_equal(np.broadcast_to(a, (5,)), np.broadcast_to(b, (5,)))
    # the model budget perturbs that one point's dynamic stiffness in one batch: each term is a finite difference
    names = plane_features(chain.n_planes)
    S = model_sensitivity(chain, theta, names)
    assert S.shape[0] == len(names) and np.all(np.isfinite(S)) and np.any(S != 0)
