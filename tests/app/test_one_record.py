"""One record per session (issue 38): loaded once, on the Identify or the Diagnose page, every page shows and
uses it; a new record drops the last one's results everywhere; the Identify page's "Diagnose this record" opens
the Diagnose page, which diagnoses it. The pages are built here without a server (their code, not the browser:
tests/app/test_uploads.py and test_consistency.py drive the same in Chromium)."""

from __future__ import annotations

import html
import re
from types import SimpleNamespace

import panel as pn
import pytest

from lubeviz.app import resources
from lubeviz.app.session import SessionState
from tests.app.threads import run_coro


def shown(pane) -> str:
    """What a reader sees of a Markdown pane (Panel's own rendering, tags dropped)."""
    text = pane.object or ""
    out = pn.pane.Markdown(text)._transform_object(text)["object"]
    return html.unescape(re.sub(r"<[^>]*>", "", html.unescape(out)))


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory) -> str:
    from lubeviz.cli.main import main

    path = tmp_path_factory.mktemp("one-record") / "pump-7 inboard.csv"
    assert main(["simulate", "--q1-mlmin", "400", "--q2-mlmin", "500", "--duration-s", "1", "--seed", "5",
                 "-o", str(path)]) == 0
    return path.read_text()


def pages(state: SessionState):
    from lubeviz.app.diagnose_page import DiagnosePage
    from lubeviz.app.identify_page import IdentifyPage

    machine = resources.machine()
    return IdentifyPage(machine, state), DiagnosePage(machine, state)


def test_a_record_uploaded_on_identify_is_the_diagnose_page_s_with_its_name(record_csv):
    state = SessionState(name="test")
    identify, diagnose = pages(state)
    assert diagnose._run.disabled and "No record yet" in shown(diagnose._record_info)
    run_coro(identify._on_upload(SimpleNamespace(new=("pump-7 inboard.csv", record_csv))))
    assert state.record is not None and state.record_name == "pump-7 inboard.csv" and state.loaded_on == "Identify"
    assert diagnose._record is state.record and not diagnose._run.disabled
    info = shown(diagnose._record_info)
    assert "pump-7 inboard.csv" in info and "loaded on the Identify page" in info, info
    assert "Truth" not in info  # a file's claims are never a truth
    assert diagnose._sample_card.collapsed  # the sample's controls fold away under a user's record
    assert not identify._to_diagnose.disabled


def test_a_page_opened_after_the_upload_shows_the_record(record_csv):
    from lubeviz.app.diagnose_page import DiagnosePage

    state = SessionState(name="test")
    identify, _ = pages(state)
    run_coro(identify._on_upload(SimpleNamespace(new=("pump-7 inboard.csv", record_csv))))
    later = DiagnosePage(resources.machine(), state)  # the Diagnose tab first opened now
    assert later._record is state.record and not later._run.disabled
    assert "pump-7 inboard.csv" in shown(later._record_info)


def test_a_sample_simulated_on_diagnose_is_the_identify_page_s_with_its_truth_in_words(record_csv):
    state = SessionState(name="test")
    identify, diagnose = pages(state)
    run_coro(identify._on_upload(SimpleNamespace(new=("pump-7 inboard.csv", record_csv))))
    diagnose.effect_name = "clearance"
    run_coro(diagnose._on_sample(None))
    assert state.loaded_on == "Diagnose" and state.truth is not None
    info = shown(identify._record_info)
    assert "loaded on the Diagnose page" in info and "Truth" in info, info
    assert "radial clearance" in info and "µm" in info, info  # the effect in words ...
    assert "clearance_um" not in info and "clearance:" not in info, info  # ... not its command-line form
    assert identify._item is None and identify._result.object == ""  # the file's results are gone
    assert not diagnose._sample_card.collapsed


def test_a_new_record_drops_the_identification_and_the_diagnosis_of_the_last(record_csv):
    state = SessionState(name="test")
    identify, diagnose = pages(state)
    run_coro(identify._on_upload(SimpleNamespace(new=("first.csv", record_csv))))
    run_coro(identify._on_run(None))
    assert state.identification is not None and identify._result.object
    # the declared oil is a caveat of every record at one speed: a note under the flows, not a warning (issue 38)
    assert "as viscous as the model file declares" in shown(identify._result)
    assert not (identify._warning.visible and "viscosity" in identify._warning.object)
    run_coro(diagnose._on_upload(SimpleNamespace(new=("second.csv", record_csv))))
    assert state.identification is None and state.record_name == "second.csv"
    assert identify._result.object == "" and identify._download_json.disabled
    assert "second.csv" in shown(identify._record_info)


def test_diagnose_this_record_opens_the_diagnose_page_which_diagnoses_it(record_csv):
    state = SessionState(name="test")
    identify, diagnose = pages(state)
    asked = []
    state.param.watch(lambda e: asked.append(e.new), "open_page")
    run_coro(identify._on_upload(SimpleNamespace(new=("pump-7 inboard.csv", record_csv))))
    identify._to_diagnose.clicks += 1
    assert asked[-1] == "Diagnose" and state.diagnosis_asked
    run_coro(diagnose.start())  # what the dashboard does when the tab is shown
    assert not state.diagnosis_asked  # asked once, done once
    assert diagnose._result is not None and diagnose._result["name"] == "pump-7 inboard.csv"
    assert diagnose._verdict.visible and not diagnose._download.disabled


def test_the_maps_page_opens_on_the_session_s_record_and_names_it(record_csv):
    from lubeviz.app.maps_page import SOURCES, MapsPage
    from lubeviz.model.operating import operating_point

    state = SessionState(name="test")
    identify, _ = pages(state)
    machine = resources.machine()
    maps = MapsPage(machine, operating_point(machine), state)
    assert maps.source == "simulated"  # no record yet
    run_coro(identify._on_upload(SimpleNamespace(new=("pump-7 inboard.csv", record_csv))))
    assert maps.source == "uploaded"  # the new record becomes the maps' source
    assert MapsPage(machine, operating_point(machine), state).source == "uploaded"  # and a page opened later's
    line = shown(pn.pane.Markdown(maps._record_line({"source": "uploaded", "record_name": state.record_name})))
    assert "pump-7 inboard.csv" in line and "Identify" in line, line
    assert {v: k for k, v in SOURCES.items()}["uploaded"].startswith("the session's record")


def test_a_map_that_cannot_be_computed_leaves_no_plot_of_the_last_under_its_message():
    import holoviews as hv

    from lubeviz.app.maps_page import NO_RECORD, MapsPage
    from lubeviz.model.operating import operating_point

    machine = resources.machine()
    maps = MapsPage(machine, operating_point(machine), SessionState(name="test"))
    stale = hv.Curve([(0, 0), (1, 1)])
    maps._errors.object = stale  # what an earlier record's search left
    for pane in maps._feature_panes:
        pane.object = stale
    maps._summary.object = "#### Identified (paper mode): Q1 = 1.0, Q2 = 2.0 ml/min"
    maps._ready = True
    import param

    with param.parameterized.discard_events(maps):
        maps.source = "uploaded"  # the session's record, which it has not
    run_coro(maps._recompute())
    assert maps._error.visible and NO_RECORD.split(":")[0] in maps._error.object
    assert maps._errors.object is None and all(p.object is None for p in maps._feature_panes)
    assert maps._summary.object == "" and maps._result is None


def test_a_hidden_maps_page_waits_to_be_shown_before_it_maps_a_new_record(record_csv):
    """A record loaded on Identify while the Maps page is hidden only marks its maps stale (no computing beside the
    identification); shown again, it maps the session's record."""
    from lubeviz.app.maps_page import MapsPage
    from lubeviz.model.operating import operating_point

    state = SessionState(name="test")
    identify, _ = pages(state)
    machine = resources.machine()
    maps = MapsPage(machine, operating_point(machine), state)
    maps._ready = maps._starting = True  # started earlier, on a simulated record
    computed = []

    async def recompute(*events):
        computed.append(maps.source)

    maps._recompute = recompute
    maps.on_screen = False  # the shell: another tab is shown
    run_coro(identify._on_upload(SimpleNamespace(new=("pump-7 inboard.csv", record_csv))))
    assert computed == [] and maps.source == "uploaded" and maps._stale
    run_coro(identify._on_run(None))  # the identification changes nothing on a hidden page either
    assert computed == []
    maps.on_screen = True
    run_coro(maps.start())  # the tab shown again
    assert computed == ["uploaded"] and not maps._stale
