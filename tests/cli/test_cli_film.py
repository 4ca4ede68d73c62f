"""`lubeviz film` and `lubeviz bearing`: the SPEC §7 contract."""

import json
import math
import subprocess
import sys

import pytest

from lubeviz.cli.main import main

FILM_KEYS = {"force_n", "load_n", "sommerfeld", "attitude_deg", "side_leakage_mlmin", "max_pressure_pa",
             "cavitated_fraction", "iterations", "seconds"}
BEARING_KEYS = {"q_mlmin", "eccentricity_ratio", "attitude_deg", "position_m", "K", "C", "side_leakage_mlmin",
                "q_threshold_mlmin", "max_pressure_pa", "min_film_um", "seconds"}


def run(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_film_json_matches_raimondi_boyd(capsys):
    code, out, _ = run(capsys, "film", "--eccentricity", "0.6", "--attitude-deg", "30", "--no-groove",
                       "--length-mm", "90", "--mesh", "120x40", "--json")
    assert code == 0
    data = json.loads(out)
    assert FILM_KEYS <= set(data)
    assert data["sommerfeld"] == pytest.approx(0.121, rel=0.02)
    assert data["attitude_deg"] == pytest.approx(50.6, abs=1.0)
    assert data["load_n"] == pytest.approx(math.hypot(*data["force_n"]))


def test_bearing_json_reports_equilibrium_and_coefficients(capsys):
    code, out, _ = run(capsys, "bearing", "--bearing", "2", "--q-mlmin", "400", "--json")
    assert code == 0
    data = json.loads(out)
    assert BEARING_KEYS <= set(data)
    assert data["side_leakage_mlmin"] == pytest.approx(400.0, rel=1e-8)
    assert data["q_threshold_mlmin"] == pytest.approx(546.0, rel=0.03)
    assert len(data["K"]) == 2 and len(data["C"][1]) == 2
    assert data["min_film_um"] == pytest.approx(120.0 * (1 - data["eccentricity_ratio"]))
    # default load: bearing 2's share of the rotor weight from the rotor statics (paper: 6545.6 N / 2)
    assert data["load_n"] == pytest.approx(6545.6 / 2, rel=5e-4)


@pytest.mark.parametrize("argv,needle", [
    (["film", "--eccentricity", "1.0", "--flooded"], "--eccentricity"),
    (["film", "--eccentricity", "0.3", "--q-mlmin", "nan"], "not a finite number"),
    (["film", "--eccentricity", "0.3", "--q-mlmin", "-5"], "--q-mlmin"),
    (["film", "--eccentricity", "0.3", "--flooded", "--viscosity-pas", "0"], "--viscosity-pas"),
    (["film", "--eccentricity", "0.3", "--flooded", "--speed-hz", "-1"], "--speed-hz"),
    (["film", "--eccentricity", "0.3", "--flooded", "--mesh", "12x6"], "too coarse"),
    (["film", "--eccentricity", "0.3", "--flooded", "--mesh", "abc"], "NxM"),
    (["bearing", "--q-mlmin", "400", "--machine", "/nonexistent.toml"], "no such model file"),
    (["bearing", "--q-mlmin", "400", "--load-n", "0"], "--load-n"),
    (["bearing", "--q-mlmin", "400", "--groove-refinement", "0"], "groove_refinement"),
    (["bearing"], "required"),
    (["bearing", "--bearing", "3", "--flooded"], "1..2"),
    (["bearing", "--bearing", "sleeve A", "--flooded"], "1 (bearing 1), 2 (bearing 2)"),
    (["film", "--bearing", "4", "--eccentricity", "0.3", "--flooded", "--machine", "models/three_bearing_fan.toml"],
     "1 (sleeve A (drive end)), 2 (sleeve B (middle)), 3 (sleeve C (non-drive end))"),
])
def test_bad_input_exits_2_with_one_line(capsys, argv, needle):
    with pytest.raises(SystemExit) as exc_info:
        code = main(argv)
        raise SystemExit(code)
    assert exc_info.value.code == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_console_script_prints_only_json_on_stdout():
    proc = subprocess.run([sys.executable, "-m", "lubeviz.cli.main", "film", "--eccentricity", "0.4",
                           "--q-mlmin", "400", "--json"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["side_leakage_mlmin"] == pytest.approx(400.0, rel=1e-8)


def test_bearing_takes_any_bearing_of_the_machine_by_number_or_name(capsys):
    """SPEC §8: a bearing is 1..N or its name in the model file. The fan's third bearing by either, with its load
    from the machine's coupled statics (three films share the weight), the same answer both ways."""
    from lubeviz.model.files import load_machine
    from lubeviz.rotor.statics import bearing_static_loads

    fan = "models/three_bearing_fan.toml"
    code, out, _ = run(capsys, "bearing", "--machine", fan, "--bearing", "3", "--flooded", "--json")
    assert code == 0
    by_number = json.loads(out)
    code, out, _ = run(capsys, "bearing", "--machine", fan, "--bearing", "Sleeve C (non-drive end)", "--flooded",
                       "--json")
    assert code == 0
    by_name = json.loads(out)
    assert by_number["bearing"] == by_name["bearing"] == 3 and by_name["bearing_name"] == "sleeve C (non-drive end)"
    assert by_name["q_threshold_mlmin"] == by_number["q_threshold_mlmin"]
    assert by_number["load_n"] == pytest.approx(-bearing_static_loads(load_machine(fan))[2][1], rel=1e-12)
