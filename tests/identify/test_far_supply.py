"""A supply far above the flooded threshold: the tables hold the film there, not the film at 2 Q_T.

An oil thicker than declared lowers a bearing's Q_T (the journal sits nearer the centre). On the fan, bearing B at
682 ml/min is 1.78 Q_T with the declared oil and 2.16 Q_T with oil x1.27: the tables ended at 2 Q_T, and the
compiled lookup held the film at 2 Q_T, so its K and C were 6 % off at x1.27 and 15 % at x1.5 (the fan loop's two
thick-oil records, unexplained: chi2 71 for 10 dof at the truth, session 54). The tables now reach 3 Q_T
(`supply.BASE_TOP`, `FAR_STEP`). Checked against direct film solves of the same bearings (the film at its own
supply and load, the loads shifted as the chain shifts them: `film_bearings`)."""

import numpy as np
import pytest

from lubeviz.effects import Clearance, Viscosity
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.rotor.film_bearings import film_bearings, flooded_thresholds
from lubeviz.units import MLMIN_PER_M3S

FAN = str(MODELS_DIR / "three_bearing_fan.toml")
SPEED = 28.375507906017244  # the fan loop's case 92
Q = np.array([306.5133223021016, 682.194949336611, 160.40404158803798]) / MLMIN_PER_M3S


@pytest.mark.slow
@pytest.mark.parametrize("factor", [1.267, 1.5])
def test_bearing_b_far_above_its_threshold_is_the_film_s_own(factor):
    thick = load_machine(FAN)
    thick.bearings = [b.copy(viscosity=b.viscosity * factor) for b in thick.bearings]
    ratio = Q / flooded_thresholds(thick, 2 * np.pi * SPEED)
    assert ratio[1] > 2.1  # past the old tables' end
    oil = Viscosity(bearing="all", factor=factor).hold()
    chain = ForwardChain(load_machine(FAN), SPEED, (7, 15, 23), effects=(oil,))
    theta = chain.start()
    theta[:3] = Q
    direct = film_bearings(thick, Q, 2 * np.pi * SPEED).equilibria
    for k in range(3):
        _, (K, C, pos) = chain.bearing_states(theta)[k]
        Kd, Cd = direct[k].coefficients.K, direct[k].coefficients.C
        # the tables' own accuracy over the operating range is about 2 % of the largest entry (BENCHMARKS,
        # "Dimensionless tables"); held at 2 Q_T, bearing B was 6.4 % (x1.267) and 14.8 % (x1.5) off
        assert np.abs(K - Kd).max() <= 0.03 * np.abs(Kd).max(), k
        assert np.abs(C - Cd).max() <= 0.03 * np.abs(Cd).max(), k
        assert np.hypot(*(pos - direct[k].position)) <= 0.03 * np.hypot(*direct[k].position), k


@pytest.mark.slow
@pytest.mark.parametrize("clearance_um", [100.0, 107.7])
def test_a_worn_bearing_far_below_its_threshold_is_the_film_s_own(clearance_um):
    """A worn bearing's Q_T grows faster than its clearance: the fan's bearing B at 0.34 Q_T with its declared 75 um
    is at 0.14 Q_T worn to 107.7 um (the fan loop's case 152, unexplained). The tables ended at 0.25 Q_T, and the
    lookup held the film there: K 11-16 % and C 28-38 % off. They now reach 0.1 Q_T."""
    speed = 25.80572962914144
    q = np.array([191.3729365123831, 127.58710089698707, 211.77420196559328]) / MLMIN_PER_M3S  # case 152
    worn = load_machine(FAN)
    worn.bearings[1] = worn.bearings[1].copy(clearance=clearance_um * 1e-6)
    ratio = q / flooded_thresholds(worn, 2 * np.pi * speed)
    assert ratio[1] < 0.2  # past the old tables' end
    chain = ForwardChain(load_machine(FAN), speed, (7, 15, 23),
                         effects=(Clearance(bearing=2, clearance_um=clearance_um).hold(),))
    theta = chain.start()
    theta[:3] = q
    _, (K, C, pos) = chain.bearing_states(theta)[1]
    d = film_bearings(worn, q, 2 * np.pi * speed).equilibria[1]
    assert np.abs(K - d.coefficients.K).max() <= 0.01 * np.abs(d.coefficients.K).max()
    assert np.abs(C - d.coefficients.C).max() <= 0.01 * np.abs(d.coefficients.C).max()
    assert np.hypot(*(pos - d.position)) <= 0.01 * np.hypot(*d.position)


@pytest.mark.slow
def test_a_flow_past_the_tables_end_is_found_and_the_fit_says_so():
    """Past 3 Q_T (oil x1.5 and bearing B fed 1.3 x the case's flow: 3.2 x the thick oil's Q_T) the lookups hold the
    film at the tables' end. The chain finds such a bearing (`past_tables`, its Q_T the thick oil's own, as the film
    has it), finds none inside, and a fit whose answer lies there says its flow is not to be trusted."""
    from lubeviz.identify.fit.least_squares import fit
    from lubeviz.identify.forward.chain import simulate
    from lubeviz.identify.forward.measured import measure

    factor = 1.5
    thick = load_machine(FAN)
    thick.bearings = [b.copy(viscosity=b.viscosity * factor) for b in thick.bearings]
    q_t = flooded_thresholds(thick, 2 * np.pi * SPEED)
    oil = Viscosity(bearing="all", factor=factor).hold()
    chain = ForwardChain(load_machine(FAN), SPEED, (7, 15, 23), effects=(oil,))
    theta = chain.start()
    theta[:3] = Q
    assert chain.past_tables(theta) == []  # 2.49 Q_T: inside
    theta[1] = 1.3 * Q[1]
    past = chain.past_tables(theta)
    assert [p[0] for p in past] == [1]
    k, q, threshold, end = past[0]
    assert q == theta[1]
    assert threshold == pytest.approx(q_t[1], rel=0.01)  # the thick oil's Q_T, not the declared oil's
    assert end == pytest.approx(3.0 * threshold, rel=1e-6)
    assert q / threshold > 3.0
    res = fit(chain, measure(simulate(chain, theta, snr_db=30.0, rng=np.random.default_rng(2))), upper=2.5)
    assert res.flow_values()[1] / threshold > 3.0
    said = [w for w in res.warnings if "past the tables' end" in w]
    assert len(said) == 1 and said[0].startswith("bearing 2's flow") and "not to be trusted" in said[0]
    # ... and a diagnosis's verdict carries it (`diagnose.loop` adds the final fit's sentence)
    from lubeviz.diagnose.loop import _past_tables_words

    assert _past_tables_words(res) == f" {said[0][:1].upper()}{said[0][1:]}."


def test_a_film_past_the_sommerfeld_grid_is_found_on_two_supports_and_on_three():
    """`ForwardChain.off_grid`: the lookups hold a film's Sommerfeld number at the tables' grid ends (`_on_grid`,
    `_within_grid`) as they hold a flow at its table's; the chain finds such a bearing. On the paper's machine,
    bearing 1's oil x2 and clearance halved (S x8, past the grid's top); on the fan, a couple that leaves bearing C a
    fifth of its load (on three supports the shifted load sets S)."""
    from lubeviz.effects import SideLoad
    from lubeviz.identify.tables.dimensionless import sommerfeld_nodes

    top = sommerfeld_nodes()[-1]
    paper = load_machine()
    chain = ForwardChain(paper, 75.0, (6, 20), effects=(Viscosity(bearing=1, factor=2.0).hold(),
                                                        Clearance(bearing=1, clearance_um=60.0).hold()))
    found = chain.off_grid(chain.start())
    assert [k for k, _s, _end in found] == [0] and found[0][1] > top and found[0][2] == top
    assert ForwardChain(paper, 75.0, (6, 20), effects=(Viscosity(bearing=1, factor=2.0).hold(),)).off_grid(
        chain.start()) == []
    fan = load_machine(FAN)
    side = SideLoad(node=18, force_n=0.0).bind(fan)
    shares, loads = side._bound()
    for share, past in ((0.8, True), (0.2, False)):  # the couple that takes this share of bearing C's load away
        held = side.copy(moment_nm=-share * loads[2] / shares[2, 1]).hold()
        c = ForwardChain(fan, SPEED, (7, 15, 23), effects=(held,))
        got = c.off_grid(c.start())
        assert ([k for k, _s, _end in got] == [2]) is past, (share, got)


def test_a_load_turned_far_off_its_declared_line_is_found_and_said():
    """`ForwardChain.turned_loads`: a film whose static load leans off its table's line is the table's film turned
    rigidly, whose error was measured up to 10 deg (`budget.TURN_ERROR_PER_RAD`); past TURN_SAID_DEG, or reversed, a
    fit says its flows are not to be trusted. On the paper's machine (two supports) a horizontal force shares out by
    the lever rule, so the bearings' horizontal reactions, each its load times the tangent of its turn, add up to
    the force. On the fan (three), the couple of its loop's case 138 lifts bearing A past its film's zero load: its
    load reverses, which half that couple does not do."""
    from lubeviz.effects import SideLoad
    from lubeviz.identify.fit.least_squares import _past_tables_text
    from lubeviz.identify.forward.budget import TURN_SAID_DEG

    paper = load_machine()
    plain = ForwardChain(paper, 75.0, (6, 20))
    assert plain.turned_loads(plain.start()) == []
    weights = np.linalg.norm(plain.loads, axis=-1)
    for force, turned in ((1500.0, []), (6000.0, [0, 1])):
        held = SideLoad(angle_deg=90.0, force_n=force).bind(paper).hold()
        chain = ForwardChain(paper, 75.0, (6, 20), effects=(held,))
        turns = np.array([float(chain.bearing_changes(k, chain.start()).lean) for k in range(2)])  # rad
        assert np.sum(weights * np.tan(turns)) == pytest.approx(force, rel=1e-9)
        got = chain.turned_loads(chain.start())
        assert [k for k, _t in got] == turned and all(abs(t) > TURN_SAID_DEG for _k, t in got)
    fan = load_machine(FAN)
    q = np.array([310.5124909817522, 548.9886053875956, 47.33789881994849]) / MLMIN_PER_M3S
    for share, reversed_a in ((0.5, False), (1.0, True)):
        held = SideLoad(node=4, force_n=0.0, moment_nm=-1039.0 * share).bind(fan).hold()
        chain = ForwardChain(fan, 20.92976121520923, (7, 23), effects=(held,))
        got = chain.turned_loads(q)
        assert ([k for k, t in got if abs(t) > 90.0] == [0]) is reversed_a, got
        if reversed_a:
            (said,) = [w for w in _past_tables_text([chain], q) if "static load" in w]
            assert said.startswith("bearing 1's static load") and "(reversed)" in said
            assert said.endswith("not to be trusted")
