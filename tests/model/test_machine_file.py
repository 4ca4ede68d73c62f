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
    ("clearance_um = 120.0", 'clearance_um = "120"', "expected float (a number), got str"),
    ("clearance_um = 120.0", "clearence_um = 120.0", "unknown key(s) ['clearence_um']"),
    ("viscosity_pa_s = 0.094", "viscosity_pa_s = -0.094", "viscosity"),
    ("[unbalance]\nnode = 13", "[unbalance]\nnode = 42", "node 42 outside 1..21"),
    ("young_modulus_pa = 210e9", "young_modulus_pa = nan", "not a finite number"),
    ("[shaft]", "[shaft]\n[oops", "not a valid TOML file"),
    ("mesh_groove_refinement = 4", "mesh_groove_refinement = 0", "groove_refinement"),
    ("mesh_groove_refinement = 4", "mesh_groove_refinement = 2.5", "expected int (an integer), got float"),
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
    assert "paper_machine" in message.split("available: ")[1].split(", ")


@pytest.mark.parametrize("name,phrase", [
    ("../paper_machine.toml", "is a path"), ("/etc/passwd", "is a path"), ("models\\paper_machine", "is a path"),
    ("..", "'..'"), ("paper_machine.py", "ends in '.py'"), ("", "empty"),
])
def test_a_machine_name_that_is_a_path_is_refused(name, phrase):
    with pytest.raises(ModelFileError) as err:
        resolve_machine_name(name, "run7.csv")
    assert str(err.value).startswith(f"run7.csv: machine: {name!r}") and phrase in str(err.value)
    assert "paper_machine" in str(err.value)


ANY_MACHINE = """
[machine]
name = "three bearings"
gravity_m_s2 = 9.81
operating_speed_hz = 50.0
[material]
young_modulus_pa = 2.0e11
poisson_ratio = 0.3
density_kg_m3 = 7850.0
[shaft]
damping_beta_s = 2.0e-5
elements_mm = [[100.0, 80.0], [300.0, 120.0, 40.0], [300.0, 120.0], [200.0, 80.0], [100.0, 80.0]]
[[discs]]
name = "fan"
node = 3
mass_kg = 120.0
polar_inertia_kg_m2 = 6.0
diametral_inertia_kg_m2 = 3.1
[[unbalances]]
node = 3
moment_kg_m = 4.0e-3
[[unbalances]]
name = "coupling"
node = 6
moment_kg_m = 1.0e-3
phase_deg = 90.0
[oil]
iso_vg = 46
temperature_c = 50.0
[[bearings]]
name = "drive end"
node = 2
radius_mm = 40.0
length_mm = 40.0
clearance_um = 60.0
grooves = [{angle_deg = 90.0, length_mm = 10.0, width_mm = 25.0}, {angle_deg = 270.0, length_mm = 10.0, width_mm = 25.0}]
offset_um = [0.0, 25.0]
[[bearings]]
name = "middle"
node = 4
radius_mm = 40.0
length_mm = 40.0
clearance_um = 60.0
groove_angle_deg = 0.0
groove_length_mm = 10.0
groove_width_mm = 25.0
supply_mlmin = 900.0
[[bearings]]
name = "outboard"
node = 5
radius_mm = 40.0
length_mm = 40.0
clearance_um = 60.0
groove_angle_deg = 0.0
groove_length_mm = 10.0
groove_width_mm = 25.0
supply = "flooded"
pedestal_mass_kg = 40.0
pedestal_stiffness_n_m = 3.0e8
pedestal_damping_ns_m = 2.0e4
[[supports]]
name = "ball bearing"
node = 6
stiffness_n_m = [[2.0e8, 0.0], [0.0, 2.0e8]]
damping_ns_m = [[500.0, 0.0], [0.0, 500.0]]
[[planes]]
node = 2
probe_angles_deg = [45.0, 135.0]
[[planes]]
node = 5
"""


def test_a_model_file_of_another_machine_reads_every_part_of_spec_8(tmp_path):
    import math

    from lubeviz.units import MLMIN_PER_M3S

    path = tmp_path / "fan.toml"
    path.write_text(ANY_MACHINE)
    m = load_machine(path)
    assert [b.name for b in m.bearings] == ["drive end", "middle", "outboard"]
    de, mid, ob = m.bearings
    assert [g.angle for g in de.grooves] == pytest.approx([math.pi / 2, -math.pi / 2])  # 270 deg = -90 deg
    assert de.offset == pytest.approx((0.0, 25e-6)) and de.supply == "unknown"
    assert mid.supply == "known" and mid.supply_flow * MLMIN_PER_M3S == pytest.approx(900.0)
    assert ob.supply == "flooded" and ob.pedestal.stiffness == pytest.approx(3e8)
    # the viscosity comes from the [oil] when the bearings do not give it: VG 46 at 50 °C, about 0.026 Pa s
    assert de.viscosity == pytest.approx(float(m.oil.dynamic_viscosity(50.0)))
    assert 0.02 < de.viscosity < 0.035
    assert m.elements[1].inner_diameter == pytest.approx(0.04) and m.discs[0].lumped and m.discs[0].name == "fan"
    assert (m.unbalance_node, m.unbalance_moment) == (3, pytest.approx(4e-3))
    assert [(u.node, u.name) for u in m.other_unbalances] == [(6, "coupling")]
    assert m.supports[0].stiffness[0][0] == pytest.approx(2e8) and m.supports[0].node == 6
    assert [(p.node, p.probe_angles_deg) for p in m.measurement_planes] == [(2, (45.0, 135.0)), (5, (0.0, 90.0))]
    assert m.center_nodes == [2, 5] and m.outside_nodes == []


def test_a_machine_the_numerics_cannot_take_is_refused_naming_the_file_and_a_pedestal_is_taken(tmp_path):
    from lubeviz.rotor.assembly import rotor_from_machine

    path = tmp_path / "fan.toml"
    path.write_text(ANY_MACHINE)
    m = load_machine(path)
    # what the numerics take (issue 37): 3 bearings, two grooves, probes at 45/135 deg, known and flooded supplies,
    # vertical offsets, constant supports, and (session 46) the pedestal under bearing 3: two DOFs of the rotor
    assert m.not_yet_modelled() == []
    rotor = rotor_from_machine(m)
    (h,) = rotor.housings
    assert (h.part, h.index, h.node) == ("bearing", 2, m.bearings[2].node)
    assert rotor.n_dof == rotor.shaft_dofs + 2 and h.dofs == (rotor.shaft_dofs, rotor.shaft_dofs + 1)
    assert rotor.M[h.dofs[0], h.dofs[0]] == pytest.approx(m.bearings[2].pedestal.mass)
    assert load_machine().not_yet_modelled() == []
    alone = load_machine(path)  # a shaft on one support cannot stand: refused naming the file
    alone.bearings[:] = alone.bearings[:1]
    alone.supports[:] = []
    with pytest.raises(ModelFileError) as err:
        rotor_from_machine(alone)
    assert str(path) in str(err.value) and "two supports at least" in str(err.value)
    sideways = load_machine(path)  # a sideways offset leans the film's load: taken in the film's own frame
    sideways.bearings[0] = sideways.bearings[0].copy(offset=(10e-6, 0.0))
    assert sideways.not_yet_modelled() == []


def test_the_measurement_planes_come_from_the_file_never_from_a_default_node_number(tmp_path, machine):
    """SPEC §8: planes declared in the file are the chain's planes; none declared: one at each bearing."""
    from lubeviz.identify.forward.chain import ForwardChain

    assert ForwardChain(machine, 75.0).nodes == tuple(b.node for b in machine.bearings)
    text = Path(DEFAULT_MACHINE).read_text()
    path = tmp_path / "planes.toml"
    path.write_text(text + "\n[[planes]]\nnode = 5\n\n[[planes]]\nnode = 21\n")
    other = load_machine(path)
    assert other.not_yet_modelled() == []
    assert ForwardChain(other, 75.0).nodes == (5, 21)
