"""The public API (`lubeviz.api`): what the CLI and the pages call, with settings objects, returning results."""

import json
from pathlib import Path

import numpy as np
import pytest

from lubeviz import api
from lubeviz.units import MLMIN_PER_M3S

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
    title, (q1, q2, chi2), fit, pair = run.maps[0]
    assert title == "plain model" and np.shape(chi2) == (6, 6) and fit is run.diagnosis.before and pair == (0, 1)
    assert np.nanmin(chi2) >= 0.0
    assert api.diagnose([api.read_record(SAMPLE)], machine, candidates=[api.EFFECTS["probe_gain"]]).maps == ()


@pytest.mark.parametrize("shift", [0.0, 0.15], ids=["as fitted", "the oil's range above the answer"])
def test_the_oil_range_interval_holds_its_own_answer(machine, monkeypatch, shift):
    """A record one speed explains with the declared oil and with another as well: the flows over any oil in
    the range are reported, and that interval holds the answer it goes with (issue 36: "Q1 in [429, 509]" was
    printed beside an answer of 414). The second case moves the free-oil fit's intervals above the answer, as
    on that record (this sample's own free-oil intervals happen to hold it)."""
    import dataclasses
    import re

    from lubeviz.diagnose import loop

    fit = loop.fit

    def oil_range_above(*args, **kwargs):
        res = fit(*args, **kwargs)
        if "viscosity.factor" not in res.names or not res.intervals:
            return res
        up = {n: (lo + shift * res.values[k], None if hi is None else hi + shift * res.values[k])
              for k, (n, (lo, hi)) in enumerate(sorted(res.intervals.items()))}
        return dataclasses.replace(res, intervals=up)

    monkeypatch.setattr(loop, "fit", oil_range_above)
    d = api.diagnose([api.read_record(SAMPLE)], machine, candidates=[api.EFFECTS["probe_gain"]]).diagnosis
    assert d.outcome == "explained" and d.set_intervals is not None
    for k, (low, high) in enumerate(d.set_intervals):
        assert low <= d.before.values[k] and (high is None or d.before.values[k] <= high)
    printed = re.findall(r"Q(\d) in \[(\d+), (\d+|open)\]", d.verdict)
    assert len(printed) == 2
    for k, low, high in printed:
        q = d.before.values[int(k) - 1] * MLMIN_PER_M3S
        assert float(low) <= round(q) and (high == "open" or round(q) <= float(high))


def test_a_union_of_intervals_holds_each_and_keeps_an_open_end_open():
    from lubeviz.identify.fit.result import union_interval

    assert union_interval((429.0, 509.0), (410.0, 418.0)) == (410.0, 509.0)  # the answer's own joins the range
    assert union_interval((429.0, None), (410.0, 418.0)) == (410.0, None)
    assert union_interval(None, (1.0, 2.0)) == (1.0, 2.0) and union_interval(None, None) is None
