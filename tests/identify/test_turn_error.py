"""What a rigid turn of a film leaves out, measured on each bearing's own film (`identify.forward.turn`), and how the
model budget carries it (session 68). A film whose load leans off its table's line is the table's film turned rigidly;
beside a supply groove the film is not round. Checked against the film solved at the leaning load itself, and, for the
loads of a shaft on three supports, against the coupled statics of a machine whose bearing is moved that much."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed
from lubeviz.identify.forward import turn
from lubeviz.model.bearing import Bearing
from lubeviz.units import MLMIN_PER_M3S

OMEGA = 2 * math.pi * 50.0
LOAD = np.array([0.0, -2000.0])


def coarse(**changes) -> Bearing:
    """The paper's bearing (one top groove, L/D 0.78) on a 40 x 20 mesh, to keep the film solves quick."""
    return Bearing(n_circumferential=40, n_axial=20, **changes)


@pytest.fixture(scope="module")
def measured():
    b = coarse()
    q_t, _ = flooded_threshold(b, OMEGA, LOAD)
    return b, q_t, turn.turn_error(b, OMEGA, LOAD, q_t)


def _rotation(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def test_a_starved_film_turns_with_its_load_and_a_flooded_one_does_not(measured):
    """Below Q_T the film lies in its own wedge, which turns with the load: the rigid turn is all but exact. Above Q_T
    the groove's pressure holds the film where the groove is: turning the load moves the journal off the turned
    position, more the further the flow is past Q_T (the model mesh's study: 0 at 0.7 Q_T, 0.03-0.07 c per radian at
    1.3-2 Q_T on this bearing)."""
    _, _, t = measured
    starved, flooded, far = (t.at(r)[0] for r in (0.7, 1.3, 2.0))
    # at 0.7 Q_T every measured lean leaves the position within the coarse mesh's own steps (0.2 % of c)
    assert np.abs(t.errors[turn.TURN_RATIOS.index(0.7), :, 8:10]).max() < 2e-3
    assert far > flooded > 3 * starved
    assert far > 0.02
    # the interpolation between the measured flows, held past their ends
    assert t.at(1.45)[0] == pytest.approx(0.5 * (t.at(1.3)[0] + t.at(1.6)[0]))
    assert t.at(0.2) == t.at(0.5) and t.at(5.0) == t.at(3.0)
    # the correction holds the errors themselves, signs included: at the outer leans far flooded the position's is
    # the size the budget quotes per radian
    outer = np.radians(turn.TURN_LEANS_DEG[-1])
    assert np.hypot(*t.errors[-1, -1, 8:10]) == pytest.approx(t.position[-1] * outer, rel=0.5)


@pytest.mark.parametrize("ratio,deg", [(1.15, 4.0), (1.6, -13.0), (0.5, 11.0)])
def test_the_measurement_bounds_the_turn_at_other_flows_and_leans(measured, ratio, deg):
    """At flows between the measured ones and leans other than the measured one, the rigid turn's error against the
    film solved at the leaning load stays within 1.5 x the per-radian sizes the measurement gives there (the errors
    are close to linear in the lean), with what the budget adds to them."""
    b, q_t, t = measured
    q = ratio * q_t
    a = math.radians(deg)
    R = _rotation(a)
    upright = find_equilibrium(b, OMEGA, LOAD, Feed.flow(q))
    exact = find_equilibrium(b, OMEGA, R @ LOAD, Feed.flow(q))
    assert upright.converged and exact.converged
    position, stiffness, damping = t.at(ratio)
    dp = np.linalg.norm(exact.position - R @ upright.position) / b.clearance
    K0, C0 = upright.coefficients.K, upright.coefficients.C
    dK = np.abs(exact.coefficients.K - R @ K0 @ R.T).max() / np.abs(K0).max()
    dC = np.abs(exact.coefficients.C - R @ C0 @ R.T).max() / np.abs(C0).max()
    # what the budget adds to it: the mesh's 0.001 c on the position (`static_position`), and below Q_T at least the
    # paper bearing's starved share on K and C (`TURN_ERROR_PER_RAD_STARVED`)
    from lubeviz.identify.forward.budget import STATIC_POSITION, TURN_ERROR_PER_RAD_STARVED

    assert dp <= math.hypot(1.5 * position * abs(a), STATIC_POSITION)
    floor = TURN_ERROR_PER_RAD_STARVED if ratio < 1.0 else 0.0
    assert dK <= 1.5 * max(stiffness, floor) * abs(a) + 2e-3 and dC <= 1.5 * max(damping, floor) * abs(a) + 2e-3


def test_a_measurement_is_kept_and_a_bad_file_is_measured_again(tmp_path, monkeypatch, measured):
    """The measurement is kept on disk under a key of every input; a file that is not exactly that (cut short, for
    other inputs, values out of range, a symbolic link) is measured again with a warning, never used."""
    b, q_t, t = measured
    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(turn, "_memo", {})
    calls = []
    real = turn._measure
    monkeypatch.setattr(turn, "_measure", lambda *a: calls.append(a) or real(*a))
    said = []
    first = turn.turn_error(b, OMEGA, LOAD, q_t, progress=lambda *a: said.append(a))
    np.testing.assert_allclose(first.position, t.position)
    n = len(turn.TURN_RATIOS)  # progress at each flow, up to the whole (this bearing's groove is too narrow for the
    # coarser mesh: the measurement starts again on its own, from 0)
    done = [d for d, _, _ in said]
    assert done[-1] == n and set(done) == set(range(n + 1)) and all(total == n for _, total, _ in said)
    key = turn._key(b, OMEGA, LOAD, q_t)
    path = turn._path(key)
    assert path.is_file() and len(calls) == 1
    monkeypatch.setattr(turn, "_memo", {})
    again = turn.turn_error(b, OMEGA, LOAD, q_t)  # from the file
    np.testing.assert_array_equal(again.stiffness, first.stiffness)
    assert len(calls) == 1
    good = path.read_bytes()
    for bad in (good[:len(good) // 2], b"not a file of ours"):
        path.write_bytes(bad)
        monkeypatch.setattr(turn, "_memo", {})
        with pytest.warns(UserWarning, match="turn error cache"):
            turn.turn_error(b, OMEGA, LOAD, q_t)
    # a symbolic link in the file's place is not followed (read as the slices are)
    path.unlink()
    target = tmp_path / "elsewhere.npz"
    target.write_bytes(good)
    path.symlink_to(target)
    monkeypatch.setattr(turn, "_memo", {})
    with pytest.warns(UserWarning, match="not a regular file"):
        turn.turn_error(b, OMEGA, LOAD, q_t)
    assert len(calls) == 4
    # another load is another key: its own measurement
    monkeypatch.setattr(turn, "_memo", {})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        turn.turn_error(b, OMEGA, 1.1 * LOAD, q_t)
    assert len(calls) == 5 and turn._key(b, OMEGA, 1.1 * LOAD, q_t) != key


def test_the_flows_measured_side_by_side_give_the_one_thread_answer_and_a_cancel_stops_them(monkeypatch, measured):
    """The flows are measured on two threads: each flow alone, so the numbers are those of one thread, bit for bit;
    progress comes in the caller's thread, once per flow; a cancel raised by progress ends the measurement and leaves
    no thread behind (a thread left would make the slices' builds start their processes by spawn)."""
    import threading

    from lubeviz.progress import Cancelled

    b, q_t, _ = measured
    monkeypatch.setattr(turn, "THREADS", 1)
    serial = turn._measure(b, OMEGA, LOAD, q_t)
    monkeypatch.setattr(turn, "THREADS", 2)
    callers = []
    side = turn._measure(b, OMEGA, LOAD, q_t, progress=lambda *a: callers.append(threading.get_ident()))
    for name in ("errors", "position", "stiffness", "damping"):
        np.testing.assert_array_equal(getattr(side, name), getattr(serial, name))
    assert set(callers) == {threading.get_ident()} and len(callers) >= len(turn.TURN_RATIOS) + 1
    before = threading.active_count()

    def cancel(done, total, label=""):
        if done >= 2:
            raise Cancelled("stop")

    with pytest.raises(Cancelled):
        turn._measure(b, OMEGA, LOAD, q_t, progress=cancel)
    assert threading.active_count() == before


def test_a_journal_held_off_its_film_moves_the_loads_as_the_bearing_moved_would():
    """On three supports the loads follow the journals: a journal held 2 um further from its bearing's centre than its
    film puts it (the budget's position error, `ForwardChain.with_position_error`) moves the loads as the bearing
    moved 2 um does (the `misalignment` effect, whose loads the independent source's coupled statics check:
    tests/effects/test_misalignment.py), tens of newtons beside the fan's middle bearing; on two supports the loads do
    not follow the journals and nothing moves."""
    from lubeviz.effects import parse_effect
    from lubeviz.identify.forward.chain import ForwardChain
    from lubeviz.model.machine import MODELS_DIR, load_machine

    machine = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    chain = ForwardChain(machine, machine.operating_speed, (7, 15))
    theta = chain.start()
    theta[:3] = chain.q_threshold * np.array([1.2, 0.8, 1.0])
    error = np.zeros((3, 2))
    error[1, 1] = 2e-6
    base = chain.static_loads(theta)
    moved = chain.with_position_error(error).static_loads(theta)
    effect = chain.adding(parse_effect("misalignment:bearing=2,dy_um=2").hold())
    want = effect.static_loads(np.concatenate([theta, effect.start()[3:]]))
    assert np.abs(moved - base).max() > 20.0  # the shift is real: ~13 N per micrometre on bearing A here
    np.testing.assert_allclose(moved, want, rtol=1e-12, atol=1e-9)
    # a batch of errors, one per point, as the budget asks for them: each point its own
    both = chain.with_position_error(np.stack([error, -error])).static_loads(np.tile(theta, (2, 1)))
    np.testing.assert_allclose(both[0], moved, rtol=1e-12, atol=1e-9)
    assert np.all(np.sign(both[1] - base)[np.abs(moved - base) > 1] == -np.sign(moved - base)[np.abs(moved - base) > 1])

    paper = load_machine()
    two = ForwardChain(paper, 75.0, (6, 20))
    flows = np.array([400.0, 600.0]) / MLMIN_PER_M3S
    np.testing.assert_array_equal(two.with_position_error(np.full((2, 2), 3e-6)).features(flows, two.dynamic_features),
                                  two.features(flows, two.dynamic_features))


def test_on_two_supports_the_turn_s_size_is_measured_once_at_the_operating_speed(monkeypatch):
    """On two supports the turn is only a budget size (a side load's lean, not corrected): it is measured once per
    bearing, at the machine's operating speed and at that speed's Q_T, and carried at every record's speed (measured
    at each, a diagnosis at a new speed took 5-6 s longer). The sizes it gives are the measurement's with the margin
    for the speed it was not measured at, above the floors."""
    from lubeviz.identify.forward.budget import TURN_SPEED_MARGIN as m, turn_errors
    from lubeviz.identify.forward.chain import ForwardChain
    from lubeviz.model.machine import load_machine

    n = len(turn.TURN_RATIOS)
    fake = turn.TurnError(np.asarray(turn.TURN_RATIOS), np.zeros((n, len(turn.TURN_LEANS_DEG), 10)), np.full(n, 0.05),
                          np.full(n, 0.9), np.full(n, 0.7))
    calls = []
    monkeypatch.setattr(turn, "_memo", {})
    monkeypatch.setattr(turn, "_read", lambda key: None)
    monkeypatch.setattr(turn, "_write", lambda key, t: None)
    monkeypatch.setattr(turn, "_measure", lambda b, omega, load, q_t, progress=None: calls.append((omega, q_t)) or fake)
    paper = load_machine()
    at_speed = ForwardChain(paper, paper.operating_speed, (6, 20))
    lean = 0.1
    for hz in (60.0, 90.0, paper.operating_speed):
        chain = ForwardChain(paper, hz, (6, 20))
        theta = chain.start()
        theta[:2] = 1.5 * chain.q_threshold  # flooded: the floor there is TURN_ERROR_PER_RAD (0.45), below 0.7 m
        position, k, c = turn_errors(chain, 0, theta[0], chain.bearing_changes(0, theta, ()).as_floats(), lean)
        assert (k, c) == pytest.approx((m * 0.9 * lean, m * 0.7 * lean))  # the measured sizes, with the speed's margin
        assert position == pytest.approx(m * 0.05 * lean * paper.bearings[0].clearance)
    omega = 2 * math.pi * paper.operating_speed
    assert len(calls) == 2  # 60 Hz asked for the operating speed's (its Q_T the film's own, solved), 90 Hz found it;
    # at the operating speed the chain's own measurement, with its table's Q_T, is the one asked for
    assert calls[0][0] == pytest.approx(omega) and calls[1][0] == pytest.approx(omega)
    assert calls[0][1] == pytest.approx(at_speed.q_threshold[0], rel=2e-3) and calls[1][1] == at_speed.q_threshold[0]


def test_the_budget_carries_the_turn_on_three_supports_and_not_without_a_lean():
    """The model budget's columns of the films' positions through the loads are there on three supports and empty on
    two; on the paper's two supports without a side load no film leans and nothing of the turn is added."""
    from lubeviz.identify.forward.budget import ModelBudget, _position_columns, model_sensitivity
    from lubeviz.identify.forward.chain import ForwardChain
    from lubeviz.model.machine import MODELS_DIR, load_machine

    machine = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    chain = ForwardChain(machine, machine.operating_speed, (7, 15))
    theta = chain.start()
    theta[:3] = chain.q_threshold * np.array([1.4, 0.5, 1.2])  # the middle one starved: it sinks, the loads lean
    assert np.abs(np.degrees(chain.film_turns(theta))).max() > 0.5
    S = model_sensitivity(chain, theta, chain.dynamic_features, ModelBudget())
    assert np.abs(S[:, _position_columns(3, 2)]).max() > 0
    assert not np.any(model_sensitivity(chain, theta, chain.dynamic_features, ModelBudget.none()))  # the noise alone
    paper = load_machine()
    two = ForwardChain(paper, 75.0, (6, 20))
    flows = np.array([400.0, 600.0]) / MLMIN_PER_M3S
    assert not np.any(two.film_turns(flows))
    S2 = model_sensitivity(two, flows, two.dynamic_features, ModelBudget())
    assert not np.any(S2[:, _position_columns(2, 2)])


@pytest.mark.parametrize("ratio,load_factor,deg", [(1.45, 1.0, 12.0), (0.9, 1.15, -13.0), (2.5, 0.9, 5.0)])
def test_a_corrected_turn_is_nearer_the_film_at_the_leaning_load(ratio, load_factor, deg):
    """The chain's film of a bearing whose load leans: the table's film corrected for the turn (`_lean_corrected`,
    from the bearing's measured turn error) and turned, against the film solved at the leaning load, at a lean, a flow
    and a load none of the measurements was made at (the fan's bearing A). The position and K come several times
    nearer than the rigid turn's where that one is off, and within the budget's share of what is left
    (`TURN_RESIDUAL_POSITION`, `TURN_RESIDUAL`)."""
    from lubeviz.identify.forward.budget import TURN_RESIDUAL, TURN_RESIDUAL_POSITION
    from lubeviz.identify.forward.chain import ForwardChain, _lean_corrected, _turned, bearing_changes
    from lubeviz.model.machine import MODELS_DIR, load_machine

    machine = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    chain = ForwardChain(machine, machine.operating_speed, (7, 15))
    src = chain.sources[0]
    q = np.array(ratio * src.nominal.q_threshold)
    a = math.radians(deg)
    change = bearing_changes((), 0, src.bearing.clearance)._replace(load_factor=load_factor)
    state = src.evaluate(q, 1.0, None, load_factor)
    rigid = _turned(state, a)
    corrected = _turned(_lean_corrected(src, state, q, change, np.array(a)), a)
    exact = find_equilibrium(src.bearing, chain.omega, _rotation(a) @ (load_factor * np.asarray(src.load)),
                             Feed.flow(float(q)))
    assert exact.converged
    c = src.bearing.clearance

    def off(s):
        K, _, p = s
        return (np.linalg.norm(p - exact.position) / c,
                np.abs(K - exact.coefficients.K).max() / np.abs(exact.coefficients.K).max())

    (p_rigid, k_rigid), (p_corr, k_corr) = off(rigid), off(corrected)
    position, stiffness, _ = src.turn_error().at(ratio)
    assert p_corr <= max(0.3 * p_rigid, 2e-3)
    assert p_corr <= 2.0 * max(TURN_RESIDUAL_POSITION * position * abs(a), 1e-3)
    assert k_corr <= max(0.7 * k_rigid, 0.01)
    assert k_corr <= 2.0 * max(TURN_RESIDUAL * stiffness * abs(a), 0.01)
