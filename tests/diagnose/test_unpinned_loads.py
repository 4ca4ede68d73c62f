"""What a named effect leaves unpinned (issue 36, item 5): from one record at one speed without the static position,
the oil's viscosity and the bearings' static loads along the weight are carried over their plausible range beside
the named effect (`diagnose.loop._unpinned`), unless the effect itself changes them.

A horizontal side load, named alone on the compressor rehearsal's loop case 14 (session 59), moves the loads across
the weight only; the truth was a vertical load of 7 % of a bearing's share with oil 25 % thicker, and the flows'
interval missed Q1 and Q2. Beside a load across the weight, the loads along it are as unpinned as beside any other effect."""

import types

import pytest

from lubeviz.diagnose.loop import LOAD_RANGE, _unpinned
from lubeviz.effects import Misalignment, SideLoad, Viscosity
from lubeviz.identify.forward.chain import ForwardChain

ONE_RECORD = [types.SimpleNamespace(static_names=())]  # one record of the 1X alone (no DC gap)


@pytest.fixture(scope="module")
def chain(machine):
    return ForwardChain(machine, 75.0, (6, 20))


def _free_loads(chain, effects):
    return [e for e in _unpinned([chain], ONE_RECORD, effects) if e.static_load]


@pytest.mark.parametrize("effect, along_weight", [
    (SideLoad(angle_deg=90.0), False),  # given across the weight: the loads along it stay unknown
    (SideLoad(angle_deg=-90.0), False),
    (SideLoad(), True),  # along the weight: it is the load's change there
    (SideLoad(angle_deg=90.0, direction_fitted=True), True),  # in a direction fitted: any, the weight's too
    (SideLoad(angle_deg=45.0), True),  # a given direction with a part along the weight
    (Misalignment(bearing=1), True),  # a bearing out of line moves the loads every way (3+ supports)
    (Viscosity(bearing="both"), False),  # no load at all
])
def test_only_an_effect_that_moves_the_loads_along_the_weight_pins_them(chain, machine, effect, along_weight):
    bound = effect.bind(machine) if isinstance(effect, SideLoad) else effect  # (a move needs 3+ supports to bind)
    assert bound.moves_weight_loads is along_weight
    free = _free_loads(chain, (bound,))
    if along_weight:
        assert free == []
        return
    (load,) = free
    # the load that is free beside it acts along the weight, its force and couple within LOAD_RANGE of each
    # bearing's declared share
    assert float(load.angle_deg) == 0.0 and not load.direction_fitted and set(load.free) == {"force_n", "moment_nm"}
    shares, loads = load._bound()
    for pname, j in (("force_n", 0), ("moment_nm", 1)):
        lo, hi = load.bounds(pname)
        assert lo == pytest.approx(-hi)
        assert max(abs(shares[:, j]) * hi / loads) == pytest.approx(LOAD_RANGE)


def test_with_the_static_position_nothing_is_carried_for_the_loads(chain, machine):
    rich = [types.SimpleNamespace(static_names=("x1_dc",))]
    assert _unpinned([chain], rich, (SideLoad(angle_deg=90.0).bind(machine),)) == []
