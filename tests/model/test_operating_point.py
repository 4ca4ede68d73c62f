"""The operating point of a machine has one flow parameter per fluid-film bearing (SPEC §8), each declared once."""

from __future__ import annotations

import pickle

import pytest

from lubeviz.errors import InputError
from lubeviz.model.files import load_machine
from lubeviz.model.operating import MAX_BEARINGS, OperatingPoint, initial_flows, operating_point
from lubeviz.model.parts import MODELS_DIR
from lubeviz.units import M3S_PER_MLMIN


@pytest.mark.parametrize("stem, n", [("paper_machine", 2), ("overhung_pump", 2), ("three_bearing_fan", 3)])
def test_a_machine_s_operating_point_has_a_declared_flow_per_bearing(stem, n):
    m = load_machine(MODELS_DIR / f"{stem}.toml")
    op = operating_point(m)
    assert op.flow_names == tuple(f"q{k + 1}" for k in range(n))
    for k, name in enumerate(op.flow_names):
        p = op.param[name]
        assert p.doc == f"Oil supply flow of bearing {k + 1}"
        assert p.display_unit == "ml/min" and p.bounds[0] == 0.0
    assert op.speed == m.operating_speed
    assert "q{}".format(n + 1) not in op.param


def test_flows_round_trip_and_a_wrong_count_is_refused():
    op = OperatingPoint.with_bearings(3)(speed=30.0)
    op.flows = [100 * M3S_PER_MLMIN, 200 * M3S_PER_MLMIN, 300 * M3S_PER_MLMIN]
    assert op.flows == pytest.approx((100 * M3S_PER_MLMIN, 200 * M3S_PER_MLMIN, 300 * M3S_PER_MLMIN))
    assert op.q3 == pytest.approx(300 * M3S_PER_MLMIN)
    with pytest.raises(InputError, match="2 flows for an operating point of 3 bearings"):
        op.flows = [1e-6, 2e-6]
    with pytest.raises(ValueError):  # the declaration's bound: a flow is positive
        op.q2 = -1e-6
    with pytest.raises(InputError, match="expected 1-6"):
        OperatingPoint.with_bearings(MAX_BEARINGS + 1)


def test_one_class_per_bearing_count_and_it_pickles():
    assert OperatingPoint.with_bearings(4) is OperatingPoint.with_bearings(4)
    op = OperatingPoint.with_bearings(4)(speed=12.0)
    op.flows = [1e-6, 2e-6, 3e-6, 4e-6]
    back = pickle.loads(pickle.dumps(op))
    assert back.flows == op.flows and type(back).n_bearings == 4


def test_first_flows_known_reference_or_the_couette_guess():
    paper = load_machine(MODELS_DIR / "paper_machine.toml")
    assert initial_flows(paper) == pytest.approx([546.0 * M3S_PER_MLMIN] * 2)  # the paper's own Q_T
    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    guess = initial_flows(fan)
    b = fan.bearings[0]
    couette = 2 * 3.141592653589793 * fan.operating_speed * b.radius * b.clearance * b.length / 2
    assert guess[0] == pytest.approx(0.1 * couette)
    # the same guess on the paper's bearing lands within 5 % of its published Q_T (why a tenth)
    pb = paper.bearings[0]
    paper_guess = 0.1 * 2 * 3.141592653589793 * paper.operating_speed * pb.radius * pb.clearance * pb.length / 2
    assert paper_guess / (546.0 * M3S_PER_MLMIN) == pytest.approx(1.0, abs=0.05)
