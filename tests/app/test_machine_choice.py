"""The dashboard's machine (issue 37, item 7) without a browser: the shipped files offered, an uploaded model
file validated and kept by content, a refused one naming the file, the table, the key and leaving the session's
machine as it was; the drawing made from the file with every name from it shown as text; the template a valid
model file that names every table of SPEC §8. The same in a real browser: test_machine_browser.py."""

from __future__ import annotations

import html
import re
import tomllib

import numpy as np
import pytest

from lubeviz.app.machine_view import (GUIDE, MODEL_LIMIT_BYTES, TEMPLATE, machine_from_upload, machine_svg,
                                      shipped_machines, summary_markdown)
from lubeviz.errors import ModelFileError
from lubeviz.model.files import load_machine
from lubeviz.model.parts import MODELS_DIR
from tests.app.threads import on_a_thread, run_coro

FAN = MODELS_DIR / "three_bearing_fan.toml"
SCRIPT = "<script>window.__xss=1</script>"


def test_the_three_example_machines_are_offered_the_paper_first():
    offered = shipped_machines()
    stems = [p.stem for p in offered.values()]
    assert stems[0] == "paper_machine"
    assert {"paper_machine", "overhung_pump", "three_bearing_fan"} <= set(stems)
    assert any("3 oil-film bearings" in label for label in offered)


def test_an_upload_is_validated_and_kept_by_its_content(tmp_path):
    content = FAN.read_bytes()
    m = machine_from_upload(content, "my fan.toml", tmp_path)
    assert len(m.bearings) == 3 and m.name == "three_bearing_fan"
    again = machine_from_upload(content, "my fan.toml", tmp_path)
    assert again.source == m.source and len(list(tmp_path.iterdir())) == 1  # one copy per content
    changed = machine_from_upload(content.replace(b"operating_speed_hz = 24.75", b"operating_speed_hz = 25.0"),
                                  "my fan.toml", tmp_path)
    assert changed.operating_speed == 25.0 and changed.source != m.source


@pytest.mark.parametrize("edit, expected", [
    ((b"clearance_um = 75.0", b"clearance_um = -75.0"), r"my fan\.toml.*\[\[bearings\]\] 1.*clearance"),
    ((b"[[planes]]", b"[[planez]]"), r"my fan\.toml: unknown section.*planez"),
    ((b"node = 15", b"node = 99"), r"my fan\.toml.*node"),
    ((b"[machine]", b"[machine"), r"my fan\.toml: not a valid TOML file"),
])
def test_a_bad_upload_is_refused_naming_the_file_the_table_and_the_key(tmp_path, edit, expected):
    content = FAN.read_bytes()
    assert edit[0] in content
    with pytest.raises(ModelFileError, match=expected):
        machine_from_upload(content.replace(*edit, 1), "my fan.toml", tmp_path)
    assert not any(tmp_path.iterdir())  # nothing refused is kept


def test_empty_huge_and_binary_uploads_are_refused(tmp_path):
    with pytest.raises(ModelFileError, match="empty"):
        machine_from_upload(b"", "m.toml", tmp_path)
    with pytest.raises(ModelFileError, match="too large"):
        machine_from_upload(b"#" * (MODEL_LIMIT_BYTES + 1), "m.toml", tmp_path)
    with pytest.raises(ModelFileError, match="not a valid TOML"):
        machine_from_upload(b"\xff\xfe\x00binary", "m.toml", tmp_path)


def test_the_drawing_shows_every_part_and_names_from_the_file_only_as_text(tmp_path):
    hostile = FAN.read_bytes().replace(b'name = "sleeve B (middle)"', f'name = "{SCRIPT}"'.encode())
    m = machine_from_upload(hostile, "fan.toml", tmp_path)
    svg = machine_svg(m)
    assert "<script" not in svg and "&lt;script&gt;" in svg
    assert svg.count("<circle") == len(m.bearings) + len(m.measurement_planes)  # one section per bearing, plane
    assert all(f"Q{k + 1}:" in svg for k in range(len(m.bearings)))
    assert "locating spherical-roller bearing" in svg  # the support, named
    assert svg.count("P1") == 2 and "P3" in svg  # each plane marked and drawn across
    text = summary_markdown(m)
    assert "<script" not in text and "Q3:" in text


def test_a_pedestal_is_drawn_as_a_spring_under_its_bearing_and_named_in_the_summary(tmp_path):
    anchor = b'name = "sleeve C (non-drive end)"'
    text = FAN.read_bytes().replace(anchor, anchor + b"\npedestal_mass_kg = 60.0\npedestal_stiffness_n_m = 4.0e8"
                                                     b"\npedestal_damping_ns_m = 2.0e4", 1)
    m = machine_from_upload(text, "fan.toml", tmp_path)
    assert machine_svg(m).count("<polyline") == 1 and "<polyline" not in machine_svg(load_machine(FAN))
    summary = summary_markdown(m)
    assert summary.count("on a pedestal (60 kg, 4e+08 N/m)") == 1 and "Q3:" in summary.split("on a pedestal")[0]


def test_the_two_groove_bearing_is_drawn_with_two_grooves_where_the_file_puts_them():
    m = load_machine(MODELS_DIR / "overhung_pump.toml")
    svg = machine_svg(m)
    arcs = re.findall(r'<path d="M([\d.]+),([\d.]+) A22(?:\.0)?,22(?:\.0)?[^"]*" fill="none" stroke="#1f77b4"', svg)
    assert len(arcs) == 4  # two bearings, two grooves each
    # grooves at 90 and 270 deg (from the top towards -X): the arcs start left and right of the centre
    xs = sorted(float(x) for x, _ in arcs[:2])
    assert xs[1] - xs[0] > 40  # on opposite sides of the 22-unit circle


def test_the_template_is_a_valid_model_file_naming_every_table_of_spec_8():
    m = load_machine(TEMPLATE)
    assert len(m.bearings) == 2 and len(m.measurement_planes) == 2
    assert len(m.bearings[0].grooves) == 2 and len(m.bearings[1].grooves) == 1
    text = TEMPLATE.read_text(encoding="utf-8")
    for table in ("[machine]", "[material]", "[shaft]", "[[discs]]", "[[unbalances]]", "[oil]", "[[bearings]]",
                  "[[supports]]", "[[planes]]"):
        assert table in text, table
    for key in ("supply", "supply_mlmin", "offset_um", "grooves", "probe_angles_deg", "elements_mm",
                "mass_kg", "stiffness_n_m", "damping_ns_m", "pedestal_mass_kg", "pedestal_stiffness_n_m",
                "pedestal_damping_ns_m"):
        assert key in text, key
    tomllib.loads(text)
    for step in ("[machine]", "[shaft]", "[[bearings]]", "[[planes]]"):
        assert step in GUIDE


def test_choosing_a_machine_rebuilds_the_pages_for_it_and_a_refused_upload_keeps_it():
    # on a thread of its own, where no event loop runs: a page is then built as soon as its tab is shown (a browser
    # test before this file in the same worker leaves Playwright's loop running in the main thread)
    on_a_thread(_choose_rebuild_refuse)


def _choose_rebuild_refuse():
    from lubeviz.app import shell

    template = shell.build()
    chooser, pages, tabs = template.lubeviz_chooser, template.lubeviz_pages, template.main[0]
    tabs.active = 2  # the Rotor page of the paper's machine
    assert len(pages["Rotor"].op.flows) == 2
    chooser.select.value = next(k for k in chooser.select.options if "three_bearing_fan" in k)
    assert template.lubeviz_machine.name == "three_bearing_fan"
    assert "Rotor" not in pages  # built afresh for the new machine when next shown
    tabs.active = 1
    tabs.active = 2
    rotor = pages["Rotor"]
    assert rotor.machine.name == "three_bearing_fan"
    assert rotor.op.flow_names == ("q1", "q2", "q3") and rotor.node == 7  # the first plane's node
    assert rotor.op.provisional  # no published Q_T: a first guess, moved to each Q_T once the tables are in
    assert pages["Bearing"].param.bearing.objects == {f"Bearing {k + 1} (node {n})": k
                                                      for k, n in enumerate((7, 15, 23))}
    # a bad model file: refused with the file, table and key named; the fan stays, its pages too
    bad = FAN.read_bytes().replace(b"clearance_um = 75.0", b"clearance_um = 0.0", 1)
    chooser.upload.filename = "broken.toml"
    chooser.upload.value = bad
    assert chooser.message.visible
    shown = html.unescape(chooser.message.object)  # shown as text (escaped for Markdown)
    assert "broken.toml [[bearings]] 1: clearance_um: expected a positive number" in shown
    assert "The pages still use **three_bearing_fan**" in shown
    assert template.lubeviz_machine.name == "three_bearing_fan" and pages["Rotor"] is rotor
    # a good one is taken, offered in the list and chosen
    chooser.upload.filename = "pump.toml"
    chooser.upload.value = (MODELS_DIR / "overhung_pump.toml").read_bytes()
    assert not chooser.message.visible
    assert template.lubeviz_machine.name == "overhung_pump"
    assert any("uploaded: pump.toml" in k for k in chooser.select.options)


def test_the_maps_page_of_machine_c_draws_any_pair_with_the_third_flow_held_at_its_identified_value():
    """The fan's Maps page: the simulated record (direct film solves) identified in best mode, chi^2 and each
    plane's fb, phi over the chosen pair, the third bearing held at its identified flow (said in the title)."""
    from lubeviz.app import resources
    from lubeviz.app.pair_maps_page import PairMapsPage
    from lubeviz.app.session import SessionState
    from lubeviz.model.operating import operating_point

    fan = resources.machine(FAN)
    page = PairMapsPage(fan, operating_point(fan), SessionState(), grid_points=21)
    run_coro(page.start())
    assert not page._error.visible, page._error.object
    r = page._result
    q = r["fit"].flow_values()
    assert np.all(np.abs(q / r["q_ref"] - 1) < 0.03), (q, r["q_ref"])  # the fit's answer on the page's own record
    assert r["map"].names == ("fb1", "phi1", "fb2", "phi2", "fb3", "phi3")
    assert len(page._features.objects) == 6
    assert "Q3 held at" in page._chi2.object.opts.get().kwargs["title"]
    page.param.update(x_flow=2, y_flow=0)
    run_coro(page._recompute())
    assert page._result["map"].pair == (2, 0)
    assert "Q2 held at" in page._chi2.object.opts.get().kwargs["title"]
