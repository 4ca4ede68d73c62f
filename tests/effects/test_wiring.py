"""A mixed-up measurement (`wiring`): its record is the plain record's columns exchanged or negated, whatever
the probes' angles; the chain's direct solve agrees."""

import numpy as np
import pytest

from lubeviz.effects import EFFECTS, parse_effect
from lubeviz.effects.wiring import FAULTS
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.units import MLMIN_PER_M3S

Q = np.array([450.0, 600.0]) / MLMIN_PER_M3S
ANGLES = ((45.0, 135.0), (0.0, 90.0))  # plane 1 turned: a fault across planes must carry the angles
COLUMNS = ("x1", "y1", "x2", "y2")


@pytest.fixture(scope="module")
def plain(machine):
    chain = ForwardChain(machine, 75.0, (6, 20), probe_angles_deg=ANGLES)
    return chain, simulate(chain, Q, snr_db=None, duration_s=0.2).displacement.reshape(4, -1)


def _expected(columns, source, sign):
    """The columns a fault writes, from the plain record: column i holds sign[i] x channel source[i]."""
    return np.array([sign[i] * columns[source[i]] for i in range(4)])


CASES = {  # by hand, from what each fault means (not from the effect's table)
    "planes_swapped": ((2, 3, 0, 1), (1, 1, 1, 1)),
    "x_y_swapped": ((1, 0, 3, 2), (1, 1, 1, 1)),
    "x1_y1_swapped": ((1, 0, 2, 3), (1, 1, 1, 1)),
    "y2_inverted": ((0, 1, 2, 3), (1, 1, 1, -1)),
    "plane1_inverted": ((0, 1, 2, 3), (-1, -1, 1, 1)),
}


@pytest.mark.parametrize("fault", sorted(CASES))
def test_a_wiring_fault_writes_the_plain_records_columns_mixed_up(plain, fault):
    chain, columns = plain
    rec = simulate(chain.adding(parse_effect(f"wiring:fault={fault}")), Q, snr_db=None, duration_s=0.2)
    got = rec.displacement.reshape(4, -1)
    np.testing.assert_allclose(got, _expected(columns, *CASES[fault]), atol=1e-12 * np.abs(columns).max())


def test_every_fault_is_a_placement_a_diagnosis_tries():
    assert {e.fault for e in EFFECTS["wiring"]().placements(n_bearings=2, n_planes=2)} == set(FAULTS)
    assert EFFECTS["wiring"].diagnosed and not EFFECTS["wiring"]().free  # nothing to fit: a discrete choice


@pytest.mark.parametrize("fault", ["planes_swapped", "x2_inverted"])
def test_chain_equals_the_direct_solve_with_a_wiring_fault(plain, fault):
    chain = plain[0].adding(parse_effect(f"wiring:fault={fault}"))
    a, b = chain.output(Q), chain.direct_output(Q)
    scale = np.abs(b.x).max()
    np.testing.assert_allclose(a.x, b.x, atol=1e-10 * scale)
    np.testing.assert_allclose(a.y, b.y, atol=1e-10 * scale)


FAN_CASES = {  # three planes, by hand: column i holds sign[i] x channel source[i]
    "planes1_3_swapped": ((4, 5, 2, 3, 0, 1), (1,) * 6),
    "x_y_swapped": ((1, 0, 3, 2, 5, 4), (1,) * 6),
    "x3_y3_swapped": ((0, 1, 2, 3, 5, 4), (1,) * 6),
    "y3_inverted": ((0, 1, 2, 3, 4, 5), (1, 1, 1, 1, 1, -1)),
    "plane2_inverted": ((0, 1, 2, 3, 4, 5), (1, 1, -1, -1, 1, 1)),
}


@pytest.mark.parametrize("fault", sorted(FAN_CASES))
def test_a_record_of_three_planes_has_its_own_mix_ups(fault):
    """The fan's three planes (one turned): any two exchanged, one plane's probes, a third plane's probe reversed."""
    from lubeviz.model.machine import MODELS_DIR, load_machine

    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    angles = ((0.0, 90.0), (45.0, 135.0), (0.0, 90.0))
    chain = ForwardChain(fan, fan.operating_speed, (7, 15, 23), probe_angles_deg=angles)
    q = chain.q_threshold * np.array([0.9, 1.1, 0.8])
    columns = simulate(chain, q, snr_db=None, duration_s=1.0).displacement.reshape(6, -1)
    got = simulate(chain.adding(parse_effect(f"wiring:fault={fault}")), q, snr_db=None, duration_s=1.0)
    source, sign = FAN_CASES[fault]
    want = np.array([sign[i] * columns[source[i]] for i in range(6)])
    np.testing.assert_allclose(got.displacement.reshape(6, -1), want, atol=1e-12 * np.abs(columns).max())


def test_a_diagnosis_tries_every_mix_up_of_the_record_s_planes():
    from lubeviz.effects.wiring import fault_names
    from lubeviz.errors import InputError
    from lubeviz.model.machine import MODELS_DIR, load_machine

    three = [e.fault for e in EFFECTS["wiring"]().placements(n_bearings=3, n_planes=3)]
    assert len(three) == len(set(three)) == 3 + 1 + 3 + 6 + 3 and "planes2_3_swapped" in three
    assert "planes_swapped" not in three  # two planes' name for their one pair
    with pytest.raises(InputError, match=r"fault='planes_sawpped'; expected one of planes_swapped, .*\(116 in all\)"):
        parse_effect("wiring:fault=planes_sawpped")
    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")  # the pages offer the machine's own planes' mix-ups
    assert EFFECTS["wiring"]().demo(fan).param.fault.objects == fault_names(3)
    assert EFFECTS["wiring"]().demo(load_machine()).param.fault.objects == fault_names(2) == list(FAULTS)
    chain = ForwardChain(*_paper_chain_args())
    with pytest.raises(InputError, match="a record of 2 planes has"):
        chain.adding(parse_effect("wiring:fault=x3_inverted")).output(Q)


def _paper_chain_args():
    from lubeviz.model.machine import load_machine

    return load_machine(), 75.0, (6, 20)
