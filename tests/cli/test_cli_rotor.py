"""`lubeviz response` and `lubeviz simulate`: the SPEC §7 contract."""

import json
import math

import numpy as np
import pytest

from lubeviz.cli.main import main
from lubeviz.signals import record_features
from tests.records import read_record


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_response_with_coefficients_file_matches_the_api(capsys, tmp_path, machine):
    from lubeviz.rotor import isotropic, machine_unbalance, rotor_from_machine, unbalance_response

    K, C = isotropic(1.5e8, 8e5)
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"bearings": [{"K": K.tolist(), "C": C.tolist()}] * 2}))
    code, out, _ = run(capsys, "response", "--coefficients", str(path), "--nodes", "6,20", "--json")
    assert code == 0
    data = json.loads(out)
    assert set(data["nodes"]) == {"6", "20"}
    ref = unbalance_response(rotor_from_machine(machine), 2 * math.pi * 75, machine_unbalance(machine),
                             [(K, C)] * 2, nodes=(6, 20))
    assert data["nodes"]["6"]["x"] == pytest.approx([ref.x[0].real, ref.x[0].imag], rel=1e-12)
    assert data["nodes"]["20"]["fb"] == pytest.approx(ref.fb[1], rel=1e-12)
    assert {"natural_frequencies_hz", "damping_ratios"} <= set(data)
    # isotropic supports: circular orbits at the bearings (fb = inf is reported as null, never NaN)
    assert data["nodes"]["6"]["fb"] is None or data["nodes"]["6"]["fb"] > 1e6


def test_response_on_film_bearings_reports_each_node(capsys):
    code, out, _ = run(capsys, "response", "--q1-mlmin", "450", "--q2-mlmin", "600", "--json")
    assert code == 0
    data = json.loads(out)
    assert set(data["nodes"]) == {"5", "6", "20", "21"}
    node = data["nodes"]["6"]
    zf, zb = complex(*node["zf"]), complex(*node["zb"])
    assert node["fb"] == pytest.approx(abs(zf) / abs(zb), rel=1e-12)
    assert [b["q_mlmin"] for b in data["bearings"]] == pytest.approx([450.0, 600.0])
    assert data["bearings"][0]["eccentricity_ratio"] > data["bearings"][1]["eccentricity_ratio"]  # starved


def test_the_flows_given_as_one_list_in_file_order_are_the_two_flags(capsys):
    """SPEC §8: `--q-mlmin Q1,Q2,...` gives every fluid-film bearing's flow in the file's order."""
    _, listed, _ = run(capsys, "response", "--q-mlmin", "450,600", "--json")
    _, flags, _ = run(capsys, "response", "--q1-mlmin", "450", "--q2-mlmin", "600", "--json")
    a, b = json.loads(listed), json.loads(flags)
    assert a["bearings"] == b["bearings"] and a["nodes"] == b["nodes"]


def test_simulate_writes_a_record_with_the_models_features(capsys, tmp_path):
    path = tmp_path / "rec.npz"
    code, out, _ = run(capsys, "simulate", "--q1-mlmin", "450", "--q2-mlmin", "600", "--snr-db", "none",
                       "--duration-s", "1", "--total-s", "6", "-o", str(path), "--json")
    assert code == 0 and json.loads(out)["n_samples"] == 10_000
    rec = read_record(path)
    code, out, _ = run(capsys, "response", "--q1-mlmin", "450", "--q2-mlmin", "600", "--nodes", "6,20", "--json")
    model = json.loads(out)["nodes"]
    feats = record_features(rec)
    assert [p.fb for p in feats.planes] == pytest.approx([model["6"]["fb"], model["20"]["fb"]], rel=1e-5)
    assert np.degrees([p.phi for p in feats.planes]) == pytest.approx(
        [model["6"]["phi_deg"], model["20"]["phi_deg"]], abs=1e-4)


@pytest.mark.parametrize("argv, words", [
    (["response", "--q1-mlmin", "450"], "--q2-mlmin"),
    (["response", "--q1-mlmin", "0", "--q2-mlmin", "450"], "--q1-mlmin 0"),
    (["response", "--coefficients", "/nonexistent.json"], "no such file"),
    (["response", "--q1-mlmin", "450", "--q2-mlmin", "450", "--speed-hz", "900"], "range"),
    (["response", "--q1-mlmin", "450", "--q2-mlmin", "450", "--nodes", "6,x"], "--nodes"),
    (["response", "--q1-mlmin", "450", "--q2-mlmin", "450", "--nodes", "6,99"], "node 99"),
    (["simulate", "--q1-mlmin", "450", "--q2-mlmin", "450", "-o", "rec.txt"], ".csv, .npz or .mat"),
    (["simulate", "--q1-mlmin", "450", "--q2-mlmin", "450", "--snr-db", "loud", "-o", "r.csv"], "--snr-db"),
    (["simulate", "--q1-mlmin", "450", "--q2-mlmin", "450", "--nodes", "6", "-o", "r.csv"], "2 to 12 measurement planes"),
    (["response", "--q-mlmin", "450"], "1 value(s) for 2 fluid-film bearings"),
    (["response", "--q-mlmin", "450,600,700"], "expected one per bearing in file order (bearing 1, bearing 2)"),
    (["response", "--q-mlmin", "450,x"], "--q-mlmin"),
    (["response", "--q-mlmin", "450,-1"], "--q-mlmin value 2 -1"),
    (["response", "--q-mlmin", "450,600", "--q1-mlmin", "450"], "not both"),
    (["simulate", "--q-mlmin", "450,0", "-o", "r.csv"], "--q-mlmin value 2 0"),
])
def test_bad_rotor_cli_input_exits_2_with_one_line(capsys, argv, words):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and words in err


def test_bad_coefficient_file_is_named(capsys, tmp_path):
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"bearings": [{"K": [[1, 2], [3]], "C": [[0, 0], [0, 0]]}]}))
    code, _, err = run(capsys, "response", "--coefficients", str(path))
    assert code == 2 and "c.json" in err and "K" in err


@pytest.mark.parametrize("name, flows, planes", [("three_bearing_fan", "180,300,120", 3),
                                                 ("overhung_pump", "44,140", 2)])
def test_every_example_machine_simulates_a_record_of_its_own_planes(capsys, tmp_path, name, flows, planes):
    """SPEC §8 item 6: the shipped machines run; the record holds the model file's planes and probe angles."""
    from lubeviz.model.machine import MODELS_DIR, load_machine
    from tests.records import read_record

    path = MODELS_DIR / f"{name}.toml"
    out = tmp_path / "r.csv"
    code, _, err = run(capsys, "simulate", "--machine", str(path), "--q-mlmin", flows, "--method", "steady",
                       "-o", str(out))
    assert code == 0, err
    rec = read_record(out)
    m = load_machine(path)
    assert rec.nodes == tuple(p.node for p in m.measurement_planes) and rec.n_planes == planes
    assert rec.probe_angles_deg == tuple(tuple(p.probe_angles_deg) for p in m.measurement_planes)


def test_a_machine_on_a_pedestal_simulates_and_its_probes_ride_the_housing(capsys, tmp_path):
    """SPEC §8 pedestal keys: the rotor gains the housing; the probes riding it read the shaft relative to it."""
    from lubeviz.model.machine import MODELS_DIR, load_machine

    text = (MODELS_DIR / "three_bearing_fan.toml").read_text()
    anchor = 'name = "sleeve C (non-drive end)"'
    path = tmp_path / "fan_on_pedestal.toml"
    path.write_text(text.replace(anchor, anchor + "\npedestal_mass_kg = 60.0\npedestal_stiffness_n_m = 4.0e8"
                                           "\npedestal_damping_ns_m = 2.0e4", 1))
    recs = {}
    for name, machine in (("pedestal", path), ("plain", MODELS_DIR / "three_bearing_fan.toml")):
        out = tmp_path / f"{name}.csv"
        code, _, err = run(capsys, "simulate", "--machine", str(machine), "--q-mlmin", "180,300,120", "--method",
                           "steady", "--snr-db", "none", "-o", str(out))
        assert code == 0, err
        recs[name] = read_record(out)
    a, b = (np.abs(recs[n].displacement).max(axis=-1) for n in ("pedestal", "plain"))  # (plane, probe)
    planes = [p.node for p in load_machine(path).measurement_planes]
    at_c = planes.index(load_machine(path).bearings[2].node) if load_machine(path).bearings[2].node in planes \
        else None
    assert np.max(np.abs(a / b - 1.0)) > 0.01  # the housing changes what the probes read
    if at_c is not None:
        assert np.max(np.abs(a[at_c] / b[at_c] - 1.0)) > 0.01
    code, out, err = run(capsys, "simulate", "--machine", str(path), "--q-mlmin", "180,300,120", "--effect",
                         "large_orbit", "-o", str(tmp_path / "orbit.csv"))
    assert code == 2 and out == "" and "pedestal" in err and "bearing(s) [3]" in err  # not on pedestals yet
