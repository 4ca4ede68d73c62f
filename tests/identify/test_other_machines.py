"""Machines other than the paper's rig (SPEC §8, issue 37): the shipped overhung pump (two-axial-groove bearings at
L/D = 0.5, an overhung impeller, probes at 45/135 deg inboard of the bearings, running above its first critical)
identified from records of the independent source (`lubeviz.verification`: a 200 x 200 film without groove
refinement, another rotor mesh, time integration), given only its model file."""

import numpy as np
import pytest

from lubeviz.identify.batch import identify_record, read_for_machine
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.signals.records import write_record
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification.independent import IndependentSpec, make_record, thresholds_mlmin

PUMP = str(MODELS_DIR / "overhung_pump.toml")


@pytest.fixture(scope="module")
def pump():
    return load_machine(PUMP)


@pytest.mark.parametrize("fractions", [(0.95, 0.8), (1.3, 0.6), (0.9, 1.4)], ids=["both-starved", "1-flooded",
                                                                                   "2-flooded"])
def test_the_pump_s_flows_come_back_from_independent_records(pump, tmp_path, fractions):
    """At the rated speed, flows around each bearing's Q_T: each inside its 95 % interval and within 1.5 %, the
    model explaining the record; the record read from a file that names only the machine (its planes' nodes and
    probe angles come from the model file)."""
    speed = pump.operating_speed
    qt = thresholds_mlmin(speed, PUMP)
    q = np.array(fractions) * qt
    planes = pump.measurement_planes
    spec = IndependentSpec(speed_hz=speed, q1_mlmin=float(q[0]), q2_mlmin=float(q[1]),
                           nodes=tuple(p.node for p in planes),
                           probe_angles_deg=tuple(tuple(p.probe_angles_deg) for p in planes), machine=PUMP, seed=3)
    rec = make_record(spec).record
    assert rec.probe_angles_deg == ((45.0, 135.0), (45.0, 135.0)) and rec.nodes == (7, 13)
    path = tmp_path / "pump.csv"
    write_record(rec, path)
    kept = [line for line in path.read_text().splitlines()
            if not line.startswith(("# node", "# probe_angles_deg", "# machine"))]
    path.write_text("# machine: overhung_pump.toml\n" + "\n".join(kept) + "\n")
    read, machine, notes = read_for_machine(path)
    assert read.nodes == (7, 13) and read.probe_angles_deg == ((45.0, 135.0), (45.0, 135.0))
    assert machine.name == "overhung_pump"
    res = identify_record(read, machine).result
    assert res.p_value > 0.01
    got = np.asarray(res.q) * MLMIN_PER_M3S
    for k in range(2):
        lo, hi = (v * MLMIN_PER_M3S if v is not None else np.inf for v in res.intervals[k])
        assert lo <= q[k] <= hi, (k, q[k], lo, hi)
        assert abs(got[k] / q[k] - 1) < 0.015, (k, got[k], q[k])


def _pump_record(pump, fractions, seed=3):
    qt = thresholds_mlmin(pump.operating_speed, PUMP)
    q = np.array(fractions) * qt
    planes = pump.measurement_planes
    spec = IndependentSpec(speed_hz=pump.operating_speed, q1_mlmin=float(q[0]), q2_mlmin=float(q[1]),
                           nodes=tuple(p.node for p in planes),
                           probe_angles_deg=tuple(tuple(p.probe_angles_deg) for p in planes), machine=PUMP, seed=seed)
    return make_record(spec).record, q


def test_a_known_supply_is_held_and_a_flooded_one_is_not_an_answer(pump):
    """SPEC §8 supplies: bearing 1's flow given in the model file is held (one degree of freedom more, no interval,
    `identified` false), and bearing 2 declared flooded when it is fed at 1.4 Q_T leaves bearing 1's flow where the
    fully identified fit puts it; the JSON's `flows` names each bearing in file order."""
    from lubeviz.identify.output.export import result_dict
    from lubeviz.units import MLMIN_PER_M3S

    rec, q = _pump_record(pump, (0.9, 1.4))
    free = identify_record(rec, pump)
    known = load_machine(PUMP)
    known.bearings[0] = known.bearings[0].copy(supply="known", supply_flow=float(q[0]) / MLMIN_PER_M3S)
    held = identify_record(rec, known)
    assert held.result.dof == free.result.dof + 1 and held.result.intervals[0] is None
    assert held.result.q[0] * MLMIN_PER_M3S == pytest.approx(q[0], rel=1e-9)
    lo, hi = (v * MLMIN_PER_M3S for v in held.result.intervals[1])
    assert lo <= q[1] <= hi
    flows = result_dict(held)["flows"]
    assert [(f["bearing"], f["node"], f["identified"]) for f in flows] == [
        ("bearing 1 (coupling end)", 5, False), ("bearing 2 (impeller end)", 15, True)]
    flooded = load_machine(PUMP)
    flooded.bearings[1] = flooded.bearings[1].copy(supply="flooded")
    res = identify_record(rec, flooded)
    assert res.result.p_value > 0.01
    assert res.result.q[1] >= res.result.q_threshold[1] * (1 - 1e-9)  # searched above Q_T only
    lo, hi = (v * MLMIN_PER_M3S for v in res.result.intervals[0])
    assert lo <= q[0] <= hi
    assert [f["identified"] for f in result_dict(res)["flows"]] == [True, False]
    # a bearing declared flooded that is starved: the model does not explain the record
    starved, _ = _pump_record(pump, (0.9, 0.7), seed=4)
    assert identify_record(starved, flooded).result.p_value < 0.01


def test_a_known_supply_beyond_the_tables_is_held_at_their_edge_and_said(pump):
    """A known supply of 5 Q_T (a generous feed) is held at the tables' end (3 Q_T), and the fit says so instead of
    taking it silently."""
    from lubeviz.units import MLMIN_PER_M3S

    rec, q = _pump_record(pump, (0.9, 1.4))
    known = load_machine(PUMP)
    big = 5.0 * thresholds_mlmin(pump.operating_speed, PUMP)[1]
    known.bearings[1] = known.bearings[1].copy(supply="known", supply_flow=big / MLMIN_PER_M3S)
    res = identify_record(rec, known).result
    assert res.q[1] == pytest.approx(3.0 * res.q_threshold[1], rel=1e-9)
    assert any("known supply" in w and "tables' edge" in w for w in res.warnings)


def test_large_orbits_take_any_layout_hold_a_known_supply_and_refuse_a_correction_of_another_shape():
    """The large-orbit rounds move every flow of unknown supply, on any number of bearings and planes: the fan (three
    bearings, three planes) is taken; a known supply is held (no slope taken in it); a machine whose every supply is
    known has nothing to fit and is refused by name. The correction is added at the chain's own planes: a constant
    one moves the probes' 1X at its plane by exactly itself and nothing elsewhere, and one of another shape (the
    paper's two planes and two flows) is refused with both counts, not broadcast onto the fan's."""
    from lubeviz.errors import InputError
    from lubeviz.identify.fit.large_orbit import check_orbit_chain, moving_flows
    from lubeviz.identify.forward.chain import ForwardChain, ResponseDefect

    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    chain = ForwardChain(fan, fan.operating_speed, tuple(p.node for p in fan.planes))
    check_orbit_chain(chain)
    assert moving_flows(chain) == [0, 1, 2]
    held = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    held.bearings[1] = held.bearings[1].copy(supply="known", supply_flow=200 / MLMIN_PER_M3S)
    assert moving_flows(ForwardChain(held, fan.operating_speed)) == [0, 2]
    every = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    for k in range(3):
        every.bearings[k] = every.bearings[k].copy(supply="known", supply_flow=200 / MLMIN_PER_M3S)
    with pytest.raises(InputError, match=r"three_bearing_fan\.toml.*known supply"):
        check_orbit_chain(ForwardChain(every, fan.operating_speed))
    theta = chain.start()
    base = chain.output(theta)
    shift = 3e-6 * np.exp(0.4j)
    d = ResponseDefect.constant(x=[0, shift, 0], y=np.zeros(3, complex), static=np.zeros((3, 2)),
                                q0=chain.q_threshold)
    moved = chain.with_defect(d).output(theta)
    assert np.allclose(moved.x - base.x, [0, shift, 0], rtol=1e-9, atol=1e-15)
    assert np.allclose(moved.y, base.y, rtol=1e-12, atol=0)
    paper = load_machine()
    pair = ResponseDefect.constant(x=np.zeros(2, complex), y=np.zeros(2, complex), static=np.zeros((2, 2)),
                                   q0=[1e-5, 1e-5])
    check_orbit_chain(ForwardChain(paper, 75.0, (6, 20)).with_defect(pair))  # the paper's layout: taken
    with pytest.raises(InputError, match=r"2 plane\(s\) and 2 flow\(s\) given to a chain of 3 plane\(s\) and 3"):
        chain.with_defect(pair)


def test_a_balance_that_stalls_near_an_orbit_gives_way_to_fewer_harmonics_and_says_so(monkeypatch):
    """On the fan's 100 x 60 films a 16-harmonic balance stalls within 1e-2 of the orbit (the films' tangents stop
    leading Newton's method) where 8 harmonics settle: the fit falls back along HARMONIC_LADDER with each count's own
    points per revolution, and its warnings say which counts stalled and which was used. A balance whose orbit is too
    large for a periodic solution is no matter of harmonics and is raised at once; so is a stall at the last rung."""
    import dataclasses

    from lubeviz.errors import ConvergenceError
    from lubeviz.identify.fit import large_orbit as lo
    from lubeviz.identify.forward.chain import ForwardChain
    from lubeviz.rotor.orbit_balance import HarmonicsNotSettled

    @dataclasses.dataclass(frozen=True)
    class _Fit:
        warnings: tuple = ()

    @dataclasses.dataclass(frozen=True)
    class _Orbit:
        harmonics: int

    @dataclasses.dataclass(frozen=True)
    class _OrbitFit:
        fit: _Fit
        orbit: _Orbit
        seconds: float = 0.0

    chain = ForwardChain(load_machine(), 75.0, (6, 20))
    calls = []

    def fake(chain, measured, kw, tol, max_rounds, harmonics, points, *rest):
        calls.append((harmonics, points))
        if harmonics in stalls:
            raise HarmonicsNotSettled(f"{harmonics} stalled")
        if harmonics in fails:
            raise ConvergenceError("the orbit is too large")
        return _OrbitFit(fit=_Fit(warnings=("own",)), orbit=_Orbit(harmonics))

    monkeypatch.setattr(lo, "_fit_at", fake)
    stalls, fails = {16}, set()
    of = lo.fit_large_orbit(chain, None, harmonics=16, points=64)
    assert calls == [(16, 64), (8, lo.orbit_points(8))]
    assert of.orbit.harmonics == 8 and of.fit.warnings[1:] == ("own",)
    assert "did not settle with 16 harmonics" in of.fit.warnings[0] and "fitted with 8 harmonics" in of.fit.warnings[0]
    calls.clear()
    assert lo.fit_large_orbit(chain, None, harmonics=5, points=24).fit.warnings == ("own",)
    assert calls == [(5, 24)]
    calls.clear()
    stalls, fails = set(), {16}
    with pytest.raises(ConvergenceError, match="too large"):
        lo.fit_large_orbit(chain, None, harmonics=16, points=64)
    assert calls == [(16, 64)]
    stalls = {16, 8, 5}
    with pytest.raises(HarmonicsNotSettled, match="5 stalled"):
        lo.fit_large_orbit(chain, None, harmonics=16, points=64)


def test_a_time_round_mirrors_across_q_t_only_the_moving_flows_near_their_kink():
    """A time round integrates at the answer and, for each flow of unknown supply within KINK_BAND of its Q_T, also
    across Q_T (at least KINK_MIRROR from it); a known supply stays where it is given even at its Q_T, and a flow far
    from its kink is not moved. On the fan with bearing B's supply known: A just below Q_T is mirrored above it, B at
    its Q_T and C far above it stay."""
    from types import SimpleNamespace

    from lubeviz.identify.fit.large_orbit import KINK_BAND, KINK_MIRROR, _time_round_flows
    from lubeviz.identify.forward.chain import ForwardChain

    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    qt = ForwardChain(fan, fan.operating_speed).q_threshold
    fan.bearings[1] = fan.bearings[1].copy(supply="known", supply_flow=float(qt[1]))
    chain = ForwardChain(fan, fan.operating_speed)
    at = qt * np.array([1.0 - KINK_BAND / 4, 1.0, 1.0 + 3 * KINK_BAND])
    where, near = _time_round_flows(chain, SimpleNamespace(bearings=SimpleNamespace(flows=tuple(at))))
    assert near == [0]
    assert len(where) == 2 and np.array_equal(where[0], at)
    assert where[1][0] == pytest.approx(qt[0] * (1 + KINK_MIRROR), rel=1e-12)
    assert np.array_equal(where[1][1:], at[1:])
