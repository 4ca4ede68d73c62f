"""`lubeviz bench flows --extra-bearing`: the machine of N + 1 bearings it times is the file's own with its first
constant-coefficient support turned into a sleeve bearing like its first one (the rest of the file unchanged)."""

from lubeviz.bench.flows import with_extra_bearing
from lubeviz.model.files import load_machine
from lubeviz.model.parts import MODELS_DIR


def test_the_extra_bearing_takes_the_support_s_place_and_the_journal_s_radius():
    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    four = load_machine(with_extra_bearing(MODELS_DIR / "three_bearing_fan.toml"))
    assert len(four.bearings) == 4 and not four.supports
    new = next(b for b in four.bearings if b.node == fan.supports[0].node)  # where the support was (node 4)
    assert new.name == "sleeve (in place of the support)"
    assert new.radius == fan.elements[3].diameter / 2  # the journal there: 110 mm
    assert (new.length, new.clearance, new.grooves) == (fan.bearings[0].length, fan.bearings[0].clearance,
                                                        fan.bearings[0].grooves)
    assert [b.node for b in four.bearings if b is not new] == [b.node for b in fan.bearings]
    assert four.elements == fan.elements and four.discs == fan.discs
