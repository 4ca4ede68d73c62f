"""SPEC §8: an effect places itself on a bearing, plane or support by its number or by its name in the model file
(`parse_effect(text, machine)`); a name the machine does not have, or shares between two parts, is refused with the
parts listed."""

import dataclasses

import pytest

from lubeviz.effects import parse_effect
from lubeviz.errors import InputError
from lubeviz.model.files import load_machine

FAN = "models/three_bearing_fan.toml"


def test_a_bearing_plane_or_support_named_is_the_one_with_that_number():
    fan = load_machine(FAN)
    named = parse_effect("clearance:bearing=sleeve B (middle),clearance_um=90", fan)
    numbered = parse_effect("clearance:bearing=2,clearance_um=90")
    assert named.spec() == numbered.spec() == "clearance:bearing=2,clearance_um=90"
    assert parse_effect("probe_rotation:plane=SLEEVE C,angle_deg=5", fan).plane == 3  # the case is not read
    assert parse_effect("support_stiffness:support=locating spherical-roller bearing", fan).support == 1
    assert parse_effect("viscosity:bearing=all,factor=0.8", fan).bearing == "all"


def test_a_name_the_machine_lacks_or_shares_is_refused_with_its_parts_listed():
    fan = load_machine(FAN)
    with pytest.raises(InputError, match=r"effect clearance: bearing 'sleeve D': expected the number \(1..3\) or the "
                                         r"name of a bearing of .*three_bearing_fan.toml: "
                                         r"1 \(sleeve A \(drive end\)\), 2 \(sleeve B"):
        parse_effect("clearance:bearing=sleeve D", fan)
    with pytest.raises(InputError, match="expected one of both, all, 1"):  # no machine: numbers only, as before
        parse_effect("clearance:bearing=sleeve B (middle)")
    twins = load_machine(FAN)  # two planes of one name: the number must say which
    twins.planes = [dataclasses.replace(p, name="probe") for p in fan.planes]
    with pytest.raises(InputError, match=r"plane 'probe' names planes 1, 2, 3 of .*; give the number \(1..3\)"):
        parse_effect("probe_rotation:plane=probe,angle_deg=2", twins)


def test_simulate_with_a_named_bearing_writes_the_record_of_its_number(tmp_path, capsys):
    from lubeviz.cli.main import main

    paths = []
    for k, bearing in enumerate(("sleeve B (middle)", "2")):
        path = tmp_path / f"r{k}.csv"
        assert main(["simulate", "--machine", FAN, "--q-mlmin", "300,320,340", "--effect",
                     f"clearance:bearing={bearing},clearance_um=90", "--seed", "3", "--duration-s", "1",
                     "--sample-rate-hz", "2000", "-o", str(path)]) == 0
        paths.append(path)
    capsys.readouterr()
    assert paths[0].read_text() == paths[1].read_text().replace(str(paths[1]), str(paths[0]))
