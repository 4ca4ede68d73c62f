"""The identification's CSV export: every number with its unit, angles in degrees as the pages show them,
the flows' 1 sigma and 95 % interval in their own columns (no Q_T where a sigma belongs)."""

import csv
import io
import math
from pathlib import Path

import pytest

from lubeviz.identify.batch import identify_file
from lubeviz.identify.output.export import CSV_COLUMNS, result_csv, result_dict

SAMPLE = Path(__file__).resolve().parents[2] / "assets" / "sample_record.csv"


@pytest.fixture(scope="module")
def item():
    return identify_file(SAMPLE)


def test_csv_rows_carry_units_and_the_json_values(item):
    d = result_dict(item)
    rows = list(csv.DictReader(io.StringIO(result_csv(item))))
    assert tuple(rows[0].keys()) == CSV_COLUMNS
    flows = [r for r in rows if r["quantity"] == "supply_flow"]
    assert [r["bearing_or_feature"] for r in flows] == ["1", "2"]
    for k, r in enumerate(flows, start=1):
        assert r["unit"] == "ml/min"
        assert float(r["value"]) == pytest.approx(d[f"q{k}_mlmin"], rel=1e-5)
        assert float(r["sigma"]) == pytest.approx(d[f"q{k}_std_mlmin"], rel=1e-5)
        low, high = d[f"q{k}_interval_mlmin"]
        assert float(r["low_95"]) == pytest.approx(low, rel=1e-5)
        assert r["high_95"] == "open" if high is None else float(r["high_95"]) == pytest.approx(high, rel=1e-5)
        assert float(r["low_95"]) <= float(r["value"])
    thresholds = [r for r in rows if r["quantity"] == "flow_threshold_Q_T"]
    assert [float(r["value"]) for r in thresholds] == pytest.approx(d["q_threshold_mlmin"], rel=1e-5)
    assert all(r["sigma"] == "" for r in thresholds)  # Q_T is not an uncertainty of anything


def test_angles_in_degrees_and_sigmas_with_the_model_budget(item):
    d = result_dict(item)
    feats = {r["bearing_or_feature"]: r for r in csv.DictReader(io.StringIO(result_csv(item)))
             if r["quantity"] == "feature"}
    assert set(feats) == set(d["features_measured"])
    for name, r in feats.items():
        angle = name.startswith(("phi", "arg"))
        f = 180 / math.pi if angle else 1.0
        assert r["unit"] == ("deg" if angle else "-")
        assert float(r["value"]) == pytest.approx(d["features_measured"][name] * f, rel=1e-6)
        assert float(r["model"]) == pytest.approx(d["features_model"][name] * f, rel=1e-6)
    # the fit's sigma includes the model budget: above the record's noise alone, feature by feature
    from lubeviz.identify.forward.model import ALL_FEATURES
    from lubeviz.identify.forward.measured import measure
    from tests.records import read_record

    names = list(item.result.features_names)
    noise = measure(read_record(SAMPLE), ALL_FEATURES).subset(names).std
    for name, s in zip(names, noise):
        f = 180 / math.pi if name.startswith(("phi", "arg")) else 1.0
        assert float(feats[name]["sigma"]) > s * f * 1.01, name


def test_the_cli_text_shows_intervals_and_verdicts_a_person_reads(capsys):
    from lubeviz.cli.main import main

    assert main(["identify", str(SAMPLE)]) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    assert lines[0].startswith(str(SAMPLE)) and "75 Hz" in lines[0]
    assert "Q1 = " in lines[1] and "95 % interval" in lines[1] and "Q_T" in lines[1]
    assert "starved" in lines[1] and "over-supplied" in lines[2]
    assert "the model explains the record" in text
    assert "±" not in text and "std" not in text  # no +- from noise alone; every number stays in --json


def test_held_effect_parameters_are_listed_with_units_in_the_text_the_csv_and_the_json():
    """A fit report lists every parameter: an effect declared with all its values (nothing left to fit) shows
    each one, marked held, with its unit, in the text; the CSV has a row for each; the JSON's `effects` holds
    them as given."""
    from lubeviz.effects import parse_effects
    from lubeviz.identify.output.export import result_text

    held = identify_file(SAMPLE, effects=parse_effects(["probe_rotation:plane=1,angle_deg=0"]))
    assert [p.key for p in held.result.params if p.free] == ["q1", "q2"]  # only the flows are fitted
    text = result_text(held)
    assert "  probe_rotation: plane = 1 (held); angle_deg = 0 deg (held)" in text
    rows = [r for r in csv.DictReader(io.StringIO(result_csv(held))) if r["quantity"].startswith("effect")]
    assert {(r["quantity"], r["bearing_or_feature"], r["unit"]) for r in rows} == {
        ("effect_parameter_held", "probe_rotation.plane", ""), ("effect_parameter_held", "probe_rotation.angle_deg", "deg")}
    assert result_dict(held)["effects"] == {"probe_rotation": {"plane": 1, "angle_deg": 0.0}}


def test_every_plane_s_static_position_is_written_in_micrometres():
    """Static features of any plane (sx1 ... syP, SPEC §8), as of the paper's two, are micrometres in the CSV."""
    from lubeviz.identify.forward.model import static_features
    from lubeviz.identify.output.export import feature_unit

    for name in static_features(3):
        assert feature_unit(name) == ("um", 1e6) and feature_unit(f"60Hz:{name}") == ("um", 1e6)
    assert feature_unit("zf3")[0] == "-" and feature_unit("phi3")[0] == "deg"


def test_the_text_names_every_flow_of_a_large_orbit_fit_and_of_an_alternative_on_any_machine():
    """The linear model's flows and an alternative's, in the text a person reads, name as many flows as were given:
    'Q1, Q2, Q3 = ...' on a machine of three bearings (the text once said 'Q1, Q2' before any number of them)."""
    from lubeviz.identify.output.export import _flows_mlmin_text, _large_orbit_lines

    assert _flows_mlmin_text([410.2, 599.6]) == "Q1, Q2 = 410, 600 ml/min"
    assert _flows_mlmin_text([136.0, 379.4, 131.7]) == "Q1, Q2, Q3 = 136, 379, 132 ml/min"
    lo = {"ratio_2x_model": [0.25, 0.11, 0.19], "plain_q_mlmin": [154.0, 390.0, 150.0], "rounds": 4, "harmonics": 5,
          "plain_chi2": 17726.0, "unbalance_scale": 3.95}
    line = _large_orbit_lines(lo)[0]
    assert "the linear model alone gives Q1, Q2, Q3 = 154, 390, 150 ml/min, chi2 17726" in line
    assert "2X/1X at the planes: 0.25, 0.11, 0.19" in line and "3.95 x the declared unbalance" in line
