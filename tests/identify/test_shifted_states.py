"""The compiled films of a machine on 3+ supports (`identify.forward.shifted`) against the numpy path they replace:
the same loads' Newton steps and turns, point by point, to rounding; points the loaded slices do not serve go to
numpy (which loads them); a chain's copies with effects and its budget's chains share the slices loaded."""

from __future__ import annotations

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.model.machine import MODELS_DIR, load_machine

FAN = MODELS_DIR / "three_bearing_fan.toml"


def _numpy(chain, theta):
    changes = [chain.bearing_changes(k, theta, theta.shape[:-1]) for k in range(chain.n_flows)]
    return chain._numpy_states(theta, changes)


@pytest.mark.parametrize("speed_hz", [24.75, 16.5])
def test_the_compiled_loop_gives_the_numpy_path_s_states_and_loads(speed_hz):
    m = load_machine(FAN)
    chain = ForwardChain(m, speed_hz, (7, 15))
    rng = np.random.default_rng(3)
    theta = np.tile(chain.start(), (40, 1))
    theta[:, :3] = chain.q_threshold * rng.uniform(0.3, 1.8, (40, 3))  # loads shifted beyond the flooded slices
    compiled, loads = chain._states(theta, (40,))  # a fresh chain: part of the points through numpy first
    numpy_path = chain._numpy_states
    chain._numpy_states = lambda *a: pytest.fail("every slice is loaded: no point goes through numpy")
    again, loads_again = chain._states(theta, (40,))
    chain._numpy_states = numpy_path
    reference, loads_ref = _numpy(chain, theta)
    for got in ((compiled, loads), (again, loads_again)):
        np.testing.assert_allclose(got[1], loads_ref, rtol=1e-11, atol=1e-9)
        for (ch, state), (ch_ref, state_ref) in zip(got[0], reference):
            np.testing.assert_allclose(ch.load_factor, ch_ref.load_factor, rtol=1e-12)
            for a, b in zip(state, state_ref):
                np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * np.abs(b).max())
    assert np.ptp(np.linalg.norm(loads_ref[:, 0], axis=-1)) > 100.0  # the loads did move (N)


def test_an_effect_s_changes_per_point_go_through_the_compiled_loop_and_its_copies_share_the_slices():
    m = load_machine(FAN)
    chain = ForwardChain(m, 24.75, (7, 15))
    oil = chain.adding(parse_effect("viscosity"))
    assert oil.sources[0]._held is chain.sources[0]._held  # one bearing, one set of loaded slices
    theta = np.tile(oil.start(), (12, 1))
    theta[:, :3] = oil.q_threshold * np.linspace(0.4, 1.6, 12)[:, None]
    theta[:, 3] = np.linspace(0.8, 1.25, 12)  # the oil's viscosity factor, one per point
    assert oil.names[3] == "viscosity.factor"
    oil._states(theta, (12,))  # loads the slices the changed oil needs
    oil._numpy_states = lambda *a: pytest.fail("every slice is loaded: no point goes through numpy")
    got, loads = oil._states(theta, (12,))
    del oil._numpy_states
    reference, loads_ref = _numpy(oil, theta)
    np.testing.assert_allclose(loads, loads_ref, rtol=1e-11, atol=1e-9)
    for (_, state), (_, state_ref) in zip(got, reference):
        for a, b in zip(state, state_ref):
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * np.abs(b).max())


def test_a_moved_bearing_per_point_goes_through_the_compiled_loop_as_through_numpy():
    """`misalignment`: each point's own move of bearing B (the compiled loop's reference place per point)."""
    m = load_machine(FAN)
    chain = ForwardChain(m, 24.75, (7, 15))
    moved = chain.adding(parse_effect("misalignment:bearing=2,dx_um=3"))
    theta = np.tile(moved.start(), (10, 1))
    theta[:, :3] = moved.q_threshold  # the flows held: only the move changes from point to point
    assert moved.names[3] == "misalignment.dy_um"
    theta[:, 3] = np.linspace(-25.0, 25.0, 10)
    moved._states(theta, (10,))  # loads the slices the moved loads need
    moved._numpy_states = lambda *a: pytest.fail("every slice is loaded: no point goes through numpy")
    got, loads = moved._states(theta, (10,))
    del moved._numpy_states
    changes = [moved.bearing_changes(k, theta, (10,)) for k in range(3)]
    reference, loads_ref = moved._numpy_states(theta, changes, moved.bearing_offsets(theta, (10,)))
    np.testing.assert_allclose(loads, loads_ref, rtol=1e-11, atol=1e-9)
    for (_, state), (_, state_ref) in zip(got, reference):
        for a, b in zip(state, state_ref):
            np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * np.abs(b).max())
    b_load = np.linalg.norm(loads[:, 1], axis=-1)  # B raised takes load from its neighbours, lowered sheds it
    assert np.all(np.diff(b_load) > 0) and b_load[-1] > b_load[0] + 100.0


def test_a_load_shifted_off_the_tables_grid_holds_its_film_at_the_grid_s_edge():
    """The fan with a fourth sleeve bearing in place of its roller support (`bench flows --extra-bearing`): with
    bearings A and B over-fed and the fourth starved, the shaft lifts off the fourth (its load 416 N flooded, 22 N
    shifted: S ~160, past the grid's 13.4). Its film is held at the grid's top, where the journal sits near the
    centre and K, C hardly depend on the load; before, the identification stopped with "Sommerfeld number 106.1
    outside the dimensionless table's range" (session 45). The numpy path and the compiled loop hold it alike."""
    from lubeviz.bench.flows import with_extra_bearing
    from lubeviz.identify.tables.dimensionless import sommerfeld_nodes, sommerfeld_number

    m = load_machine(with_extra_bearing(FAN))
    chain = ForwardChain(m, m.operating_speed)
    theta = np.tile(chain.start(), (2, 1))
    theta[:, :4] = chain.q_threshold * np.array([[2.0, 2.0, 0.6, 0.25], [1.0, 1.0, 1.0, 1.0]])
    chain._states(theta, (2,))  # loads the slices
    got, loads = chain._states(theta, (2,))
    reference, loads_ref = _numpy(chain, theta)
    np.testing.assert_allclose(loads, loads_ref, rtol=1e-9, atol=1e-6)
    assert np.linalg.norm(loads[0, 3]) < 0.1 * np.linalg.norm(chain.loads[3])  # the shaft lifts off it
    src = chain.sources[3]
    factor = np.asarray(got[3][0].load_factor)
    s = sommerfeld_number(src._seen, src._seen_load, chain.omega) / factor
    assert s[0] == pytest.approx(sommerfeld_nodes()[-1], rel=1e-6) and s[1] < sommerfeld_nodes()[-1]
    for (_, state), (_, state_ref) in zip(got, reference):
        for a, b in zip(state, state_ref):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max())


def test_on_two_supports_a_load_change_off_the_grid_holds_its_film_at_the_grid_s_edge():
    """The pump (two supports) at 62.9 Hz: its bearing 1 runs at S 8.2, so a side load's couple that lifts 39 % of its
    load off takes it past the grid's top (13.4). A diagnosis of the pump's loop stopped there with an error (case
    134, session 52). Now the film is held at the edge, as on three supports: past it, bearing 1's state no longer
    follows the couple, while bearing 2's still does; before it, both follow."""
    from lubeviz.identify.tables.dimensionless import sommerfeld_nodes, sommerfeld_number

    m = load_machine(MODELS_DIR / "overhung_pump.toml")
    base = ForwardChain(m, 62.9)
    src = base.sources[0]
    edge = sommerfeld_number(src._seen, src._seen_load, base.omega) / sommerfeld_nodes()[-1]  # bearing 1's load factor
    assert 0.5 < edge < 0.7
    chain = base.adding(parse_effect("side_load:force_n=0,moment_nm=0").candidate())
    i = chain.names.index("side_load.moment_nm")
    theta = np.tile(chain.start(), (4, 1))
    theta[:, i] = [-40.0, -55.0, -70.0, -80.0]
    lf = np.array([chain.bearing_changes(0, t).load_factor for t in theta])
    assert lf[0] > lf[1] > edge > lf[2] > lf[3]  # the couple's own load factors on bearing 1
    states = chain.bearing_states(theta, (4,))
    (c1, (K1, C1, p1)), (c2, (K2, C2, _)) = states
    np.testing.assert_allclose(c1.load_factor[2:], edge, rtol=1e-6)  # held at the edge
    np.testing.assert_array_equal(K1[2], K1[3])
    np.testing.assert_array_equal(C1[2], C1[3])
    assert not np.allclose(K1[0], K1[1], rtol=1e-6)  # on the grid: it follows
    assert not np.allclose(K2[2], K2[3], rtol=1e-6)  # bearing 2 still follows the couple
    assert np.all(np.isfinite(chain.features(theta, chain.dynamic_features)))
