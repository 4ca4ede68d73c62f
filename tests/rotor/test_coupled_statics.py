"""Statically indeterminate machines (SPEC §8, issue 37): the shaft on three fluid films, on films and a constant
support, with bearing offsets. The loads come from the coupled equilibrium of the shaft on its films
(`statics.coupled_statics`); checked against closed forms in the stiff-bearing limit, against their own
definition (a round trip through the pinned shaft and each film), and against ROSS for the supports' dynamics."""

import math

import numpy as np
import pytest

from lubeviz.model.files import load_machine
from lubeviz.rotor.assembly import rotor_from_machine
from lubeviz.rotor.statics import (bearing_static_loads, coupled_statics, gravity_load, statically_determinate,
                                   support_reactions, weight)

from tests.machines import DIAMETER_MM, E, SPAN_MM, uniform_three_bearing_file


def uniform_machine(tmp_path, *, viscosity=0.03, offset_um=0.0, support=False, name="three"):
    """`tests.machines.uniform_three_bearing_file`, loaded; `support`: a ball bearing of 1e8 / 1.5e8 N/m."""
    return load_machine(uniform_three_bearing_file(tmp_path, viscosity=viscosity, offset_um=offset_um,
                                                   support=(1.0e8, 1.5e8) if support else None, name=name))


def test_three_films_carry_the_weight_where_each_film_puts_its_journal(tmp_path):
    """At the answer the shaft, pinned where the films hold the journals, carries its weight with exactly the films'
    loads (a round trip through another code path), each film puts its journal there under that load, the loads and
    the support forces add up to the weight, and the films' compliance moves load off the middle bearing (it sits
    lowest under the largest load) against the rigid-support answer."""
    from lubeviz.film.equilibrium import find_equilibrium
    from lubeviz.film.feed import Feed

    m = uniform_machine(tmp_path)
    assert not statically_determinate(m)
    cs = coupled_statics(m)
    rotor = rotor_from_machine(m)
    F = gravity_load(rotor, m.gravity)
    again = support_reactions(rotor, F, [b.node for b in m.bearings], cs.positions)
    assert np.allclose(-again, cs.loads, rtol=1e-6, atol=1e-6 * np.abs(cs.loads).max())
    omega = 2 * math.pi * m.operating_speed
    for k, b in enumerate(m.bearings):
        eq = find_equilibrium(b, omega, cs.loads[k], Feed.flooded())
        assert np.allclose(eq.position, cs.positions[k], atol=1e-4 * b.clearance)
    assert -cs.loads[:, 1].sum() == pytest.approx(weight(rotor, m.gravity), rel=1e-9)
    assert abs(cs.loads[1, 1]) < abs(cs.pinned_loads[1, 1])  # compliance moves load off the middle bearing
    assert np.allclose(bearing_static_loads(m), cs.loads)


def test_stiff_films_give_the_continuous_beam_s_reactions_and_a_raised_middle_bearing_takes_6_EI_d_over_L3(tmp_path):
    """Oil 10^4 as viscous makes every film nearly rigid: the loads tend to the pinned (three-moment) reactions.
    Raising the middle support of a two-span continuous beam by d adds 6 E I d / L^3 to its reaction and takes
    half of that from each end (here it is lowered, d < 0): a simply supported beam of span 2L deflects
    P L^3 / (6 E I) under a central load P."""
    stiff = coupled_statics(uniform_machine(tmp_path, viscosity=300.0, name="stiff"))
    assert np.allclose(stiff.loads, stiff.pinned_loads, rtol=2e-3, atol=2e-3 * np.abs(stiff.pinned_loads).max())
    d = -10e-6  # lowered: the ends take more (raised, they would lift off)
    raised = uniform_machine(tmp_path, viscosity=300.0, offset_um=d * 1e6, name="raised")
    cs = coupled_statics(raised)
    inertia = math.pi * (DIAMETER_MM * 1e-3) ** 4 / 64
    extra = 6 * E * inertia * d / (SPAN_MM * 1e-3) ** 3
    change = cs.pinned_loads[:, 1] - stiff.pinned_loads[:, 1]
    assert change == pytest.approx([0.5 * extra, -extra, 0.5 * extra], rel=2e-2)  # shear: Timoshenko, not Euler
    assert np.allclose(cs.loads, cs.pinned_loads, rtol=5e-3, atol=5e-3 * np.abs(cs.pinned_loads).max())


@pytest.mark.parametrize("raised_um", [10.0, 25.0])
def test_an_offset_that_lifts_a_journal_off_rigid_supports_is_taken_up_by_the_films(tmp_path, raised_um):
    """The middle bearing raised: on rigid supports the end journals would be pulled up (the pinned reactions point
    up, and such a machine was refused before session 67), while the films, far softer than the shaft, let the
    middle journal sink: at 10 um they still press every journal down; at 25 um the end films push their journals
    down (a film carries a load in any direction). Either way the answer is the equilibrium by its definition: the
    shaft pinned where the films hold the journals, offsets included, carries its weight with the films' loads, each
    film puts its journal there under its load, and the loads add up to the weight."""
    from lubeviz.film.equilibrium import find_equilibrium
    from lubeviz.film.feed import Feed

    m = uniform_machine(tmp_path, offset_um=raised_um, name="raised")
    cs = coupled_statics(m)
    assert cs.pinned_loads[0, 1] > 0 and cs.pinned_loads[2, 1] > 0  # rigid supports: the ends pulled up
    assert (cs.loads[0, 1] < 0) == (raised_um == 10.0)  # on the films: pressed down at 10 um, not at 25 um
    rotor = rotor_from_machine(m)
    offsets = np.array([b.offset for b in m.bearings])
    again = support_reactions(rotor, gravity_load(rotor, m.gravity), [b.node for b in m.bearings],
                              offsets + cs.positions)
    assert np.allclose(-again, cs.loads, rtol=1e-6, atol=1e-6 * np.abs(cs.loads).max())
    omega = 2 * math.pi * m.operating_speed
    for k, b in enumerate(m.bearings):  # from where the statics put it (a journal pushed up has no cold start)
        eq = find_equilibrium(b, omega, cs.loads[k], Feed.flooded(), start=cs.positions[k])
        assert eq.converged and np.allclose(eq.position, cs.positions[k], atol=1e-4 * b.clearance)
    assert -cs.loads[:, 1].sum() == pytest.approx(weight(rotor, m.gravity), rel=1e-9)
    cold = find_equilibrium(m.bearings[0], omega, cs.loads[0], Feed.flooded())  # no start: a singular step (a
    assert cold.converged or cold.message  # journal in its groove) is said in the result, not raised by numpy


def test_a_constant_support_shares_the_weight_and_two_bearings_stay_determinate(tmp_path):
    m = uniform_machine(tmp_path, support=True, name="supported")
    cs = coupled_statics(m)
    rotor = rotor_from_machine(m)
    assert cs.support_forces.shape == (1, 2) and cs.support_forces[0, 1] > 0
    assert -cs.loads[:, 1].sum() + cs.support_forces[0, 1] == pytest.approx(weight(rotor, m.gravity), rel=1e-9)
    paper = load_machine()
    assert statically_determinate(paper)


def test_a_machine_with_a_constant_support_matches_ross(tmp_path):
    """The support's stiffness and damping are in the rotor (SPEC §8 [[supports]]): natural frequencies and the
    unbalance response with linear films at the three bearings against ROSS with the support as a bearing."""
    from lubeviz.rotor.modal import modal_analysis
    from lubeviz.rotor.response import machine_unbalance, unbalance_response
    from lubeviz.rotor.ross_model import RossUnavailable, ross_lateral_eigenvalues, ross_rotor, ross_unbalance_response

    m = uniform_machine(tmp_path, support=True, name="ross")
    bearings = [(np.array([[2e8, 5e7], [-3e7, 3e8]]), np.array([[2e4, 1e3], [1e3, 3e4]]))] * 3
    omega = 2 * math.pi * 50.0
    rotor = rotor_from_machine(m)
    try:
        ross = ross_rotor(m, bearings)
    except RossUnavailable as exc:
        pytest.skip(str(exc))
    ours = modal_analysis(rotor, omega, bearings, n_modes=6)
    theirs = ross_lateral_eigenvalues(ross, omega)[:6]
    np.testing.assert_allclose(ours.damped_frequencies, theirs.imag, rtol=5e-3)
    u = machine_unbalance(m)[0]
    nodes = (2, 3, 5, 7)
    mine = unbalance_response(rotor, omega, [u], bearings, nodes=nodes)
    x, y = ross_unbalance_response(ross, omega, u, nodes)
    for a_all, b_all in ((mine.x, x), (mine.y, y)):
        for node, a, b in zip(nodes, a_all, b_all):
            assert abs(a) == pytest.approx(abs(b), rel=1e-2), node
            assert abs(math.degrees(np.angle(a / b))) < 1.0, node
