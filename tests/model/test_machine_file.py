"""The paper's machine file loads with the paper's numbers; broken files are named and explained."""

from pathlib import Path

import pytest

from lubeviz.errors import InputError, ModelFileError
from lubeviz.model.bearing import Bearing
from lubeviz.model.machine import DEFAULT_MACHINE, MODELS_DIR, load_machine, resolve_machine_name


def test_paper_machine_has_the_papers_geometry(machine):
    assert machine.n_nodes == 21 and len(machine.elements) == 20
    assert machine.rotor_length == pytest.approx(2.235)
    assert machine.elements[10].length == pytest.approx(0.045) and machine.elements[10].diameter == pytest.approx(0.2625)
    assert [d.node for d in machine.discs] == [10, 13, 15]
    assert [b.node for b in machine.bearings] == [6, 20]
    b = machine.bearings[0]
    assert (b.radius, b.length, b.clearance, b.viscosity) == pytest.approx((0.045, 0.070, 120e-6, 0.094))
    assert b.groove_length == pytest.approx(16.2e-3) and b.groove_width == pytest.approx(35e-3)
    assert machine.unbalance_moment == pytest.approx(1.24e-2) and machine.unbalance_node == 13


def _broken(tmp_path, old, new):
    text = Path(DEFAULT_MACHINE).read_text()
    assert old in text
    path = tmp_path / "broken.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old,new,expect", [
    ("clearance_um = 120.0", "", "missing key 'clearance_um'"),
    ("clearance_um = 120.0", 'clearance_um = "120"', "expected float, got str"),
    ("clearance_um = 120.0", "clearence_um = 120.0", "unknown key(s) ['clearence_um']"),
    ("viscosity_pa_s = 0.094", "viscosity_pa_s = -0.094", "viscosity"),
    ("[unbalance]\nnode = 13", "[unbalance]\nnode = 42", "node 42 outside 1..21"),
    ("young_modulus_pa = 210e9", "young_modulus_pa = nan", "not a finite number"),
    ("[shaft]", "[shaft]\n[oops", "not a valid TOML file"),
    ("mesh_groove_refinement = 4", "mesh_groove_refinement = 0", "groove_refinement"),
    ("mesh_groove_refinement = 4", "mesh_groove_refinement = 2.5", "expected int, got float"),
])
def test_broken_model_file_is_refused_with_a_clear_message(tmp_path, old, new, expect):
    path = _broken(tmp_path, old, new)
    with pytest.raises(ModelFileError) as err:
        load_machine(path)
    assert expect in str(err.value)
    assert str(path) in str(err.value)


def test_missing_model_file_is_named(tmp_path):
    with pytest.raises(ModelFileError, match="no such model file"):
        load_machine(tmp_path / "nope.toml")


@pytest.mark.parametrize("field,value", [("clearance", 0.0), ("clearance", -1e-6), ("viscosity", float("nan")),
                                         ("radius", float("inf")), ("length", 0.0)])
def test_bearing_rejects_impossible_values(field, value):
    with pytest.raises(ValueError, match=field):
        Bearing(**{field: value})


def test_groove_wider_than_the_bearing_is_refused():
    with pytest.raises(InputError, match="groove width"):
        Bearing(groove_width=0.08)


def test_groove_refinement_is_optional_and_defaults_to_the_bearings(tmp_path):
    from lubeviz.model.bearing import Bearing

    text = Path(DEFAULT_MACHINE).read_text()
    assert text.count("mesh_groove_refinement = 4") == 2
    path = tmp_path / "uniform.toml"
    path.write_text(text.replace("mesh_groove_refinement = 4", "mesh_groove_refinement = 1", 1)
                    .replace("mesh_groove_refinement = 4", ""))
    b1, b2 = load_machine(path).bearings
    assert b1.groove_refinement == 1 and b2.groove_refinement == Bearing.param.groove_refinement.default


@pytest.mark.parametrize("name", ["paper_machine.toml", "paper_machine"])
def test_a_records_machine_name_resolves_under_models(name):
    path = resolve_machine_name(name, "run7.csv")
    assert path == DEFAULT_MACHINE and path.parent == MODELS_DIR and path.is_file()


def test_an_unknown_machine_name_names_the_record_the_value_and_the_models():
    with pytest.raises(ModelFileError) as err:
        resolve_machine_name("rig_b.toml", "data/run7.csv")
    message = str(err.value)
    assert message.startswith("data/run7.csv: machine: 'rig_b.toml' is not a model under")
    assert "available: paper_machine" in message


@pytest.mark.parametrize("name,phrase", [
    ("../paper_machine.toml", "is a path"), ("/etc/passwd", "is a path"), ("models\\paper_machine", "is a path"),
    ("..", "'..'"), ("paper_machine.py", "ends in '.py'"), ("", "empty"),
])
def test_a_machine_name_that_is_a_path_is_refused(name, phrase):
    with pytest.raises(ModelFileError) as err:
        resolve_machine_name(name, "run7.csv")
    assert str(err.value).startswith(f"run7.csv: machine: {name!r}") and phrase in str(err.value)
    assert "paper_machine" in str(err.value)
