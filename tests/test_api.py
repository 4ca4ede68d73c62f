"""The public API (`lubeviz.api`): what the CLI and the pages call, with settings objects, returning results."""

import json
from pathlib import Path

import numpy as np
import pytest

from lubeviz import api

SAMPLE = Path(__file__).resolve().parents[1] / "assets" / "sample_record.csv"


@pytest.fixture(scope="module")
def machine():
    return api.load_machine()


def test_the_api_and_the_cli_give_the_same_identification(machine, capsys):
    """One path: `lubeviz identify --json` and `api.identify_record` give the same flows, intervals and
    parameters (the CLI is a client of the API, not a second pipeline)."""
    from lubeviz.cli.main import main

    item = api.identify_record(api.read_record(SAMPLE), machine)
    assert main(["identify", str(SAMPLE), "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    mine = api.result_dict(item)
    for key in ("q1_mlmin", "q2_mlmin", "chi2"):
        assert mine[key] == pytest.approx(cli[key], rel=1e-9), key
    for key in ("q1_interval_mlmin", "q2_interval_mlmin"):
        assert [v is None for v in mine[key]] == [v is None for v in cli[key]]
        assert [v for v in mine[key] if v is not None] == pytest.approx([v for v in cli[key] if v is not None])
    assert mine["effects"] == cli["effects"] == {}
    assert [p.key for p in item.result.params] == ["q1", "q2"]
    assert api.result_text(item)[1].startswith("  Q1 = ")


def test_settings_are_objects_that_refuse_what_they_cannot_mean():
    with pytest.raises(ValueError):
        api.DiagnosisSettings(level=0.7)  # a test at 70 % would call every record unexplained
    with pytest.raises(ValueError):
        api.IdentificationSettings(orbit_harmonics=3)
    assert api.DiagnosisSettings().level == 0.01 and api.DiagnosisSettings().map_points == 0


def test_a_diagnosis_draws_its_maps_when_its_settings_ask(machine):
    run = api.diagnose([api.read_record(SAMPLE)], machine, api.DiagnosisSettings(map_points=6),
                       candidates=[api.EFFECTS["probe_gain"]])
    assert run.diagnosis.outcome in ("explained", "effect added", "ambiguous")
    title, (q1, q2, chi2), fit = run.maps[0]
    assert title == "plain model" and np.shape(chi2) == (6, 6) and fit is run.diagnosis.before
    assert np.nanmin(chi2) >= 0.0
    assert api.diagnose([api.read_record(SAMPLE)], machine, candidates=[api.EFFECTS["probe_gain"]]).maps == ()
