"""Any machine on the dashboard, in a real browser (issue 37's acceptance): choose machine (c), the three-bearing
fan, on the start page; move its third bearing's flow on the Rotor page; identify and diagnose one of its records;
upload a bad model file and see the refusal with the previous machine still shown."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from playwright.sync_api import expect

from tests.app.harness import open_tab, set_slider, slider_value

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[2]
FAN = REPO / "models" / "three_bearing_fan.toml"
FAN_RECORD = REPO / "assets" / "samples" / "three_bearing_fan.csv"  # direct film solves at 170 / 450 / 120 ml/min
SLOW_MS = 300_000  # the fan's tables, when the cache is cold (built before the page is opened: see the fixture)


@pytest.fixture(scope="module")
def fan_tables():
    """The fan's coefficient tables in the user cache first, so the page timeouts measure the app."""
    from lubeviz.identify.tables.cache import machine_tables
    from lubeviz.model.machine import load_machine

    m = load_machine(FAN)
    machine_tables(m, 2 * 3.141592653589793 * m.operating_speed)


def choose_machine(page, stem: str) -> None:
    select = page.locator(".lubeviz-machine-select select")
    label = next(o for o in select.locator("option").all_inner_texts() if stem in o)
    select.select_option(label=label)
    expect(page.locator(".lubeviz-machine-summary")).to_contain_text(stem, timeout=30_000)


def test_machine_c_chosen_moved_identified_diagnosed_and_a_bad_file_refused(app_page, fan_tables, tmp_path,
                                                                            screenshot):
    page = app_page
    choose_machine(page, "three_bearing_fan")
    summary = page.locator(".lubeviz-machine-summary")
    expect(summary).to_contain_text("3 oil-film bearings")
    drawing = page.locator(".lubeviz-machine-drawing svg").first
    expect(drawing).to_contain_text("Q3: sleeve C")
    expect(drawing).to_contain_text("locating spherical-roller bearing")
    screenshot(page, "machine_fan_start")

    # the Rotor page: one flow per bearing; the third moves the response
    open_tab(page, "Rotor")
    rotor = page.locator(".lubeviz-rotor-summary")
    expect(rotor).to_contain_text("Node 7", timeout=SLOW_MS)
    expect(page.locator(".lubeviz-q3")).to_be_visible(timeout=SLOW_MS)
    title = "Supply flow Q3"
    before = slider_value(page, title)
    target = float(round(before * 0.6))
    set_slider(page, title, target)
    expect(rotor).to_contain_text(f"Q3 = {target:.0f} ml/min", timeout=SLOW_MS)
    screenshot(page, "machine_fan_rotor")

    # Identify one of its records (made by direct film solves, not the identification's model)
    open_tab(page, "Identify")
    page.locator(".lubeviz-upload input[type=file]").set_input_files(str(FAN_RECORD))
    expect(page.locator(".lubeviz-record-info")).to_contain_text("3 planes at nodes 7, 15, 23", timeout=SLOW_MS)
    page.get_by_role("button", name="Identify the supply flows").click()
    result = page.locator(".lubeviz-result")
    expect(result).to_contain_text("Q3 =", timeout=SLOW_MS)
    # read with the slow timeout: the page draws its three planes' orbits and spectra meanwhile
    shown = result.evaluate("e => (e.shadowRoot || e).textContent", timeout=SLOW_MS)
    flows = [float(re.search(rf"Q{k} = ([0-9.]+)", shown).group(1)) for k in (1, 2, 3)]
    for got, true in zip(flows, (170.0, 450.0, 120.0)):
        assert abs(got / true - 1) < 0.05, (flows, shown)
    screenshot(page, "machine_fan_identify")

    # Diagnose the same record: the session's one record, no second upload (issue 38)
    open_tab(page, "Diagnose")
    record = page.locator(".lubeviz-diagnose-record")
    expect(record).to_contain_text("three_bearing_fan.csv", timeout=SLOW_MS)
    expect(record).to_contain_text("loaded on the Identify page")
    page.locator(".lubeviz-diagnose-run button").click()
    verdict = page.locator(".lubeviz-verdict")
    expect(verdict).to_be_visible(timeout=SLOW_MS)
    expect(page.locator(".lubeviz-diagnosis-flows")).to_contain_text("Q3 =", timeout=SLOW_MS)
    screenshot(page, "machine_fan_diagnose")

    # a bad model file: refused, naming the file, the table and the key; the fan stays
    open_tab(page, "Start")
    bad = tmp_path / "broken.toml"
    bad.write_bytes(FAN.read_bytes().replace(b"clearance_um = 75.0", b"clearance_um = -75.0", 1))
    page.locator(".lubeviz-machine-upload input[type=file]").set_input_files(str(bad))
    error = page.locator(".lubeviz-machine-error")
    expect(error).to_contain_text("broken.toml", timeout=30_000)
    expect(error).to_contain_text("[[bearings]] 1")
    expect(error).to_contain_text("clearance_um")
    expect(error).to_contain_text("The pages still use three_bearing_fan")
    expect(summary).to_contain_text("3 oil-film bearings")
    open_tab(page, "Rotor")  # its page is the fan's, as it was
    expect(page.locator(".lubeviz-rotor-summary")).to_contain_text(f"Q3 = {target:.0f} ml/min", timeout=SLOW_MS)
    screenshot(page, "machine_fan_refused")
