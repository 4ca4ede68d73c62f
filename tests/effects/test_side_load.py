"""A static side load (issue 36, item 1): the shaft's statics share it out, each bearing's film then carries another
load; checked against the lever rule, direct film solves at that load, and records of the independent source."""

import math

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.errors import InputError
from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed
from lubeviz.identify.forward.chain import ForwardChain, bearing_changes
from lubeviz.rotor import rotor_from_machine
from lubeviz.rotor.statics import bearing_static_loads, load_shares, moment_shares
from lubeviz.units import MLMIN_PER_M3S


@pytest.fixture(scope="module")
def rotor(machine):
    return rotor_from_machine(machine)


def test_a_force_shares_out_by_the_lever_rule_and_a_couple_moves_load_between_the_bearings(rotor):
    z = rotor.node_z
    b1, b2 = rotor.bearing_nodes
    span = z[b2 - 1] - z[b1 - 1]
    for node in range(1, rotor.n_nodes + 1):
        s = load_shares(rotor, node)
        lever = np.array([z[b2 - 1] - z[node - 1], z[node - 1] - z[b1 - 1]]) / span  # outboard: one share < 0
        assert s == pytest.approx(lever, abs=1e-9)
        assert moment_shares(rotor, node) == pytest.approx([1 / span, -1 / span], rel=1e-9)


def test_the_bearings_carry_the_declared_load_plus_their_share(machine):
    e = parse_effect("side_load:node=13,force_n=400,moment_nm=-300").bind(machine)
    loads = np.abs(bearing_static_loads(machine)[:, 1])
    changes = e.load_changes()
    assert changes.sum() == pytest.approx(400.0, rel=1e-9)  # the force is carried; the couple only moves load
    factors = [bearing_changes((e,), k, machine.bearings[k].clearance).load_factor for k in range(2)]
    assert np.array(factors) == pytest.approx(1 + changes / loads, rel=1e-12)
    assert "bearing 1" in e.told({}, machine) and "declared 3273 N" in e.told({}, machine)
    assert parse_effect(e.spec()).values() == e.values()  # round trip, the node given
    assert "node" not in parse_effect("side_load:force_n=1").values()  # not given: not written back as None


def test_an_unbound_side_load_says_so_and_a_node_off_the_rotor_is_refused(machine):
    with pytest.raises(InputError, match="not bound"):
        parse_effect("side_load:force_n=100").bearing_change(0, {}, ())
    with pytest.raises(InputError, match="node"):
        parse_effect("side_load:node=99,force_n=100").bind(machine)


@pytest.mark.parametrize("moment_nm", [600.0, -900.0])
def test_the_tables_at_the_changed_load_are_the_film_solved_at_it(machine, moment_nm):
    """K, C, the journal's position and Q_T of a bearing with a side load, from the dimensionless tables (the
    Sommerfeld number moves with the load), against the film solved directly at that load."""
    omega = 2 * math.pi * machine.operating_speed
    chain = ForwardChain(machine, machine.operating_speed, tuple(machine.center_nodes))
    e = parse_effect(f"side_load:force_n=0,moment_nm={moment_nm}").bind(machine)
    loads = bearing_static_loads(machine)
    for k, src in enumerate(chain.sources):
        change = bearing_changes((e,), k, src.bearing.clearance)
        assert change.load_factor != pytest.approx(1.0, abs=0.05)
        load = loads[k] * change.load_factor
        q_t, _ = flooded_threshold(src.bearing, omega, load)
        view = src.view(*change)
        assert view.q_threshold == pytest.approx(q_t, rel=2e-3)
        q = 0.8 * q_t
        K, C, pos = src.evaluate(q, *change)
        eq = find_equilibrium(src.bearing, omega, load, Feed.flow(q))
        scale_k, scale_c = np.abs(eq.coefficients.K).max(), np.abs(eq.coefficients.C).max()
        assert np.abs(K - eq.coefficients.K).max() < 1e-2 * scale_k
        assert np.abs(C - eq.coefficients.C).max() < 1e-2 * scale_c
        assert np.abs(pos - eq.position).max() < 2e-3 * src.bearing.clearance
        # and the load moved the journal: more load, further down
        plain = src.evaluate(q)[2]
        assert np.sign(plain[1] - pos[1]) == np.sign(change.load_factor - 1)


def test_the_independent_source_s_side_load_is_carried_by_its_own_statics(rotor):
    """The record source's side load on its finer rotor (a couple made of two forces there): the vertical loads
    change by the force (equilibrium) and by the lever rule, a couple by +-M / span."""
    from lubeviz.verification import IndependentSpec
    from lubeviz.verification.independent import steady_truth

    def loads(*effects):
        spec = IndependentSpec(speed_hz=75.0, q1_mlmin=500, q2_mlmin=580, snr_db=None, effects=effects)
        return np.asarray(steady_truth(spec)["bearing_loads_n"])

    d = loads("side_load:node=13,force_n=300,moment_nm=400") - loads()
    z = rotor.node_z
    z1, z2 = (z[n - 1] for n in rotor.bearing_nodes)
    lever = np.array([z2 - z[12], z[12] - z1]) / (z2 - z1)
    assert d == pytest.approx(300.0 * lever + 400.0 / (z2 - z1) * np.array([1, -1]), rel=1e-6)
