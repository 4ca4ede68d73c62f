"""The effect library and the forward chain, each effect against a reference outside the chain's own path.

References: the assembled rotor with the housing's mass DOFs (pedestals, vs the chain's series formula),
`rotor.response.unbalance_response` with two unbalances (unbalance2), the static limit of a bowed shaft
on rigid supports (bow: the shaft takes its bent line), plane geometry (probe rotation and gain), and
the plain table model `identify.forward.model.ForwardModel` (no effect).
"""

import math

import numpy as np
import pytest

from lubeviz.effects import EFFECTS, bow_shape, parse_effect, parse_effects
from lubeviz.errors import InputError
from lubeviz.identify.tables.cache import machine_tables
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.identify.forward.model import ALL_FEATURES, ForwardModel
from lubeviz.rotor.assembly import bearing_matrices, isotropic, rotor_from_machine
from lubeviz.rotor.directional import directional_components
from lubeviz.rotor.elements import X, Y, node_dofs
from lubeviz.rotor.response import Unbalance, dynamic_stiffness, machine_unbalance, unbalance_response
from lubeviz.units import MLMIN_PER_M3S

Q = np.array([420.0, 600.0]) / MLMIN_PER_M3S


@pytest.fixture(scope="module")
def tables(machine):
    return machine_tables(machine)


def chain_with(machine, tables, *specs, nodes=(6, 20), **kw):
    effects = tuple(parse_effect(s).hold() for s in specs)
    return ForwardChain(machine, 75.0, nodes, effects, tables=tables, **kw)


# --- the registry ------------------------------------------------------------------------------------

def test_every_effect_of_spec_7_is_registered():
    assert {"viscosity", "clearance", "unbalance2", "pedestals", "probe_rotation", "probe_gain", "bow"} <= set(EFFECTS)


@pytest.mark.parametrize("text, fragment", [
    ("viscosty:factor=0.8", "did you mean 'viscosity'"),
    ("viscosity:facto=0.8", "did you mean 'factor'"),
    ("viscosity:factor=9", "out of bounds"),
    ("viscosity:factor=abc", "not a number"),
    ("viscosity:factor=nan", "not finite"),
    ("probe_gain:channel=z1,gain=1.1", "expected one of x1, y1, x2, y2"),
    ("pedestals:bearing=7", "expected one of both, all, 1, 2, 3, 4, 5, 6"),
    ("bow:amplitude_um", "not key=value"),
    ("probe_gain:gain=1.1,gain=1.2", "given twice"),
])
def test_bad_effect_text_names_what_is_wrong(text, fragment):
    with pytest.raises(InputError, match=fragment):
        parse_effect(text)


def test_given_parameters_are_held_and_the_rest_free():
    e = parse_effect("pedestals:bearing=1,mass_kg=80")
    assert e.free == ("stiffness_n_m", "damping_ns_m")
    assert parse_effect(e.spec()).free == ()  # the full spec holds everything
    assert parse_effect(e.spec()).values() == e.values()


def test_placements_cover_each_bearing_plane_and_channel():
    assert {p.bearing for p in parse_effect("pedestals").placements(n_bearings=2, n_planes=2)} == {"both", 1, 2}
    assert {p.channel for p in parse_effect("probe_gain").placements(n_bearings=2, n_planes=2)} == {"x1", "y1", "x2", "y2"}
    assert {p.plane for p in parse_effect("probe_rotation").placements(n_bearings=2, n_planes=2)} == {1, 2}
    # another machine's own parts (SPEC §8): three bearings ("all" of them), three planes
    assert [p.bearing for p in parse_effect("viscosity").placements(n_bearings=3, n_planes=3)] == ["all", 1, 2, 3]
    assert [p.bearing for p in parse_effect("clearance").placements(n_bearings=3, n_planes=3)] == [1, 2, 3]
    assert {p.channel for p in parse_effect("probe_gain").placements(n_bearings=3, n_planes=3)} == {
        "x1", "y1", "x2", "y2", "x3", "y3"}
    assert {p.fault for p in parse_effect("wiring").placements(n_bearings=3, n_planes=3)} >= {
        "planes1_3_swapped", "x3_y3_swapped", "y3_inverted", "plane3_inverted"}  # the record's own planes


def test_an_effect_placed_on_a_bearing_the_machine_lacks_is_refused_by_name(machine):
    from lubeviz.errors import InputError

    with pytest.raises(InputError, match="bearing 3, but the machine has 2 fluid-film bearings"):
        ForwardChain(machine, 75.0, (6, 20), (parse_effect("clearance:bearing=3,clearance_um=150"),))


# --- the chain without effects is the table model -------------------------------------------------------

def test_chain_without_effects_equals_the_table_model(machine, tables):
    chain = ForwardChain(machine, 75.0, (6, 20), tables=tables)
    model = ForwardModel(machine, tables, (6, 20))
    grid = np.stack(np.meshgrid(np.linspace(0.3, 1.9, 5) * chain.q_threshold[0],
                                np.linspace(0.3, 1.9, 5) * chain.q_threshold[1], indexing="ij"), -1)
    np.testing.assert_allclose(chain.features(grid, ALL_FEATURES),
                               model.features(grid[..., 0], grid[..., 1], ALL_FEATURES), rtol=1e-9, atol=1e-12)
    # 1e-9, not 1e-11: the two paths solve the rotor in other orders, and on another CPU's BLAS a phase of 0.0187
    # rad came out 7e-11 apart (session 60); a model that differed would be off by far more than 1e-9


# --- each effect against its reference ------------------------------------------------------------------

@pytest.mark.parametrize("spec", ["pedestals:bearing=1,mass_kg=80,stiffness_n_m=3e8,damping_ns_m=2e4",
                                  "pedestals:bearing=both,mass_kg=200,stiffness_n_m=1e8,damping_ns_m=0",
                                  "unbalance2:node=15,ratio=0.7,phase_deg=-120",
                                  "bow:node=13,amplitude_um=25,phase_deg=40",
                                  "probe_rotation:plane=2,angle_deg=-7", "probe_gain:channel=y2,gain=0.9"])
def test_chain_equals_the_assembled_system(machine, tables, spec):
    """The chain's rank-4 update (series pedestal, forcing shapes) against a direct solve of the whole system,
    with the housing as its own mass DOFs."""
    chain = chain_with(machine, tables, spec)
    a, b = chain.output(Q), chain.direct_output(Q)
    scale = np.abs(b.x).max()
    np.testing.assert_allclose(a.x, b.x, atol=1e-10 * scale)
    np.testing.assert_allclose(a.y, b.y, atol=1e-10 * scale)


def test_rigid_massless_pedestal_changes_nothing(machine, tables):
    plain = ForwardChain(machine, 75.0, (6, 20), tables=tables).features(Q, ALL_FEATURES)
    rigid = chain_with(machine, tables, "pedestals:mass_kg=0,stiffness_n_m=1e12,damping_ns_m=0")
    np.testing.assert_allclose(rigid.features(Q, ALL_FEATURES), plain, atol=2e-3)
    soft = chain_with(machine, tables, "pedestals:mass_kg=100,stiffness_n_m=5e7,damping_ns_m=0")
    assert np.max(np.abs(soft.features(Q, ALL_FEATURES) - plain)) > 0.05


def test_second_unbalance_matches_the_two_unbalance_response(machine, tables):
    chain = chain_with(machine, tables, "unbalance2:node=10,ratio=0.4,phase_deg=60")
    rotor = chain.rotor
    coeffs = [s.nominal.coefficients(q) for s, q in zip(chain.sources, Q)]
    main = machine_unbalance(machine)[0]
    both = [main, Unbalance(10, 0.4 * main.moment, main.phase + math.radians(60))]
    ref = unbalance_response(rotor, chain.omega, both, coeffs, nodes=(6, 20))
    out = chain.output(Q)
    np.testing.assert_allclose(out.x, ref.x, rtol=1e-9)
    np.testing.assert_allclose(out.y, ref.y, rtol=1e-9)
    zero = chain_with(machine, tables, "unbalance2:node=10,ratio=0,phase_deg=60")
    np.testing.assert_allclose(zero.features(Q, ALL_FEATURES),
                               ForwardChain(machine, 75.0, (6, 20), tables=tables).features(Q, ALL_FEATURES), atol=1e-12)


def test_bowed_shaft_on_rigid_supports_takes_its_bent_line(machine):
    """Statics: with rigid supports at the bearings (where the bow is zero) and no speed effects, the
    shaft driven by K_shaft q_bow sits exactly on its unstressed bent line."""
    rotor = rotor_from_machine(machine)
    q_bow = bow_shape(rotor, 13)
    Kt, Ct = bearing_matrices(rotor, [isotropic(1e14), isotropic(1e14)])
    omega = 2 * math.pi * 1e-3
    D = dynamic_stiffness(rotor, omega, Kt, 0 * Ct)
    q = np.linalg.solve(D, rotor.K @ q_bow)
    i13 = node_dofs(13)
    assert abs(q_bow[i13[X]]) == pytest.approx(1.0)
    np.testing.assert_allclose(q, q_bow, atol=1e-5)
    with pytest.raises(InputError, match="outside the ends of its span"):
        bow_shape(rotor, 21)


def test_probe_rotation_turns_the_orbit_and_keeps_its_shape(machine, tables):
    plain = ForwardChain(machine, 75.0, (6, 20), tables=tables).output(Q)
    rot = chain_with(machine, tables, "probe_rotation:plane=1,angle_deg=6").output(Q)
    zf0, zb0 = directional_components(plain.x, plain.y)
    zf1, zb1 = directional_components(rot.x, rot.y)
    # R(-a): x + iy and conj(x - iy) both turn by e^{-ia}, so |Zf|, |Zb| are kept and the major axis
    # phi = (arg Zf + arg Zb)/2 turns by -a
    a = math.radians(6)
    np.testing.assert_allclose(zf1[0], zf0[0] * np.exp(-1j * a), rtol=1e-12)
    np.testing.assert_allclose(zb1[0], zb0[0] * np.exp(-1j * a), rtol=1e-12)
    np.testing.assert_allclose([zf1[1], zb1[1]], [zf0[1], zb0[1]], rtol=1e-12)


def test_probe_gain_scales_its_own_probe_only(machine, tables):
    plain = ForwardChain(machine, 75.0, (6, 20), tables=tables).output(Q)
    g = chain_with(machine, tables, "probe_gain:channel=x2,gain=1.15").output(Q)
    np.testing.assert_allclose(g.x, plain.x * np.array([1.0, 1.15]), rtol=1e-12)
    np.testing.assert_allclose(g.y, plain.y, rtol=1e-12)
    # probes at 45 / 135 deg: a gain on probe a stretches the orbit along 45 deg
    angled = chain_with(machine, tables, "probe_gain:channel=x1,gain=2.0",
                        probe_angles_deg=((45.0, 135.0), (0.0, 90.0))).output(Q)
    u, v = np.array([1, 1]) / math.sqrt(2), np.array([-1, 1]) / math.sqrt(2)
    d0 = np.array([plain.x[0], plain.y[0]])
    d1 = np.array([angled.x[0], angled.y[0]])
    assert d1 @ u == pytest.approx(2.0 * (d0 @ u), rel=1e-12)
    assert d1 @ v == pytest.approx(d0 @ v, rel=1e-12)


def test_effects_compose(machine, tables):
    one = chain_with(machine, tables, "probe_gain:channel=x1,gain=1.1", "unbalance2:node=15,ratio=0.5,phase_deg=30")
    a = one.output(Q)
    b = one.direct_output(Q)
    np.testing.assert_allclose(a.x, b.x, rtol=1e-9)
    assert one.names == ("q1", "q2")
    free = ForwardChain(machine, 75.0, (6, 20), parse_effects(["probe_gain:channel=x1", "unbalance2:node=15"]),
                        tables=tables)
    assert free.names == ("q1", "q2", "probe_gain.gain", "unbalance2.ratio", "unbalance2.phase_deg")


def test_a_bearing_has_at_most_one_pedestal(machine, tables):
    """Two pedestals on one bearing would put two housings in series with one film (the fast and the
    assembled paths disagreed by 2x): refused, naming the bearing."""
    with pytest.raises(InputError, match="bearing 2 is given a pedestal twice"):
        chain_with(machine, tables, "pedestals:bearing=both,mass_kg=50,stiffness_n_m=2e8,damping_ns_m=1e4",
                   "pedestals:bearing=2,mass_kg=30,stiffness_n_m=8e7,damping_ns_m=1e4")
    chain_with(machine, tables, "pedestals:bearing=1", "pedestals:bearing=2")  # one each is fine


def test_a_response_defect_is_added_affinely_before_the_probes(machine, tables):
    """The large-orbit correction (`ResponseDefect`): added to the 1X and the static offsets in the X/Y frame,
    linear in the flows about its own point, then read by the probes like the rest of the response; the
    fast path and the assembled system agree with it."""
    from lubeviz.identify.forward.chain import ResponseDefect

    chain = chain_with(machine, tables, "probe_gain:channel=x1,gain=1.1")
    q = np.asarray(Q)
    d = ResponseDefect(x=np.array([1e-6 + 2e-6j, -3e-6j]), y=np.array([2e-6, 1e-6 + 1e-6j]),
                       static=np.array([[1e-6, -2e-6], [0.0, 3e-6]]), q0=q,
                       dx=np.array([[1e-2, 0.0], [0.0, 2e-2j]]), dy=np.zeros((2, 2), complex),
                       dstatic=np.zeros((2, 2, 2)))
    corrected = chain.with_defect(d)
    assert chain.defect is None  # the original is untouched
    a, b = chain.output(q), corrected.output(q)
    np.testing.assert_allclose(b.x - a.x, [1.1 * d.x[0], d.x[1]], rtol=1e-12)  # the gain acts on it too
    np.testing.assert_allclose(b.y - a.y, d.y, rtol=1e-12)
    step = np.array([1e-6, 2e-6])
    c = corrected.output(q + step).x - chain.output(q + step).x
    np.testing.assert_allclose(c, [1.1 * (d.x[0] + 1e-2 * 1e-6), d.x[1] + 2e-2j * 2e-6], rtol=1e-12)
    direct = corrected.direct_output(q + step)
    np.testing.assert_allclose(direct.x, corrected.output(q + step).x, rtol=1e-9)


def test_large_orbit_is_a_response_model_setting_not_a_chain_stage():
    """`--effect large_orbit` names a response model: it leaves the effects the chain carries and sets the
    settings' `response`, on a copy (the caller's settings, e.g. a page's, are not changed)."""
    from lubeviz.effects import parse_effects
    from lubeviz.identify.batch import response_setting
    from lubeviz.identify.fit.settings import IdentificationSettings

    mine = IdentificationSettings(orbit_harmonics=7)
    effects, settings = response_setting(parse_effects(["large_orbit", "probe_rotation:plane=1"]), mine)
    assert [e.effect_name for e in effects] == ["probe_rotation"]
    assert settings.response == "large orbit" and settings.orbit_harmonics == 7
    assert mine.response == "linear"
    plain, same = response_setting(parse_effects(["probe_gain:channel=x1"]), mine)
    assert same is mine and [e.effect_name for e in plain] == ["probe_gain"]
