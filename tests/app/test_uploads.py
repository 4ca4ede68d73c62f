"""Uploads in a real browser (Chromium driven by Playwright; see harness.py): issue 13, item 1.

What a user does: load the sample, drop a record file, load the sample again, drop the same file again,
and see the dropped record every time it is dropped (on the Identify and the Diagnose pages); drop a
good record, identify it, then drop a malformed file: the dropper shows that file as rejected, one
message on the page names the problem, and the result on screen is said to belong to the record loaded
before (named), never passed off as the dropped file's.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from playwright.sync_api import expect

from tests.app.harness import open_tab, text

pytestmark = pytest.mark.browser

SLOW_MS = 240_000  # a cold machine builds the coefficient tables first
FILE_Q_MLMIN = (400, 500)  # the dropped record's true flows; the sample's are 420 / 600 ml/min
REJECTED_RED = "rgb(196, 78, 71)"  # FilePond's colour of a failed item (#c44e47)


@pytest.fixture(scope="module")
def records(tmp_path_factory) -> dict[str, Path]:
    """A good record at 75 Hz sampled at 10 kHz (the sample: 5 kHz) and a malformed copy of it."""
    from lubeviz.cli.main import main

    folder = tmp_path_factory.mktemp("records")
    good = folder / "measured-400-500.csv"
    assert main(["simulate", "--q1-mlmin", str(FILE_Q_MLMIN[0]), "--q2-mlmin", str(FILE_Q_MLMIN[1]),
                 "--duration-s", "2", "--seed", "3", "-o", str(good)]) == 0
    bad = folder / "broken-columns.csv"
    bad.write_text(good.read_text().replace("x1,y1,x2,y2", "x1,y1,x2,z2", 1))
    return {"good": good, "bad": bad}


def drop(page, dropper_class: str, path: Path):
    page.locator(f".{dropper_class} input[type=file]").set_input_files(str(path))


def dropped_item(page, dropper_class: str, name: str):
    """The dropper's entry (FilePond's item) for the file `name` once its transfer is over; the droppers
    hold one file at a time (a new drop replaces the last one: wait until the old item is gone)."""
    items = page.locator(f".{dropper_class} .filepond--item")
    expect(items).to_have_count(1, timeout=30_000)
    item = items.first
    expect(item).to_contain_text(name)
    expect(item).to_have_attribute("data-filepond-item-state", "processing-complete", timeout=30_000)
    return item


def test_identify_page_reloads_every_upload_even_the_same_file(app_page, records):
    page, good = app_page, records["good"]
    open_tab(page, "Identify")
    info = page.locator(".lubeviz-record-info")
    for step, source in enumerate(["sample", good, "sample", good], start=1):
        if source == "sample":
            page.get_by_role("button", name="Load the sample record").click()
            expect(info).to_contain_text("sample_record.csv", timeout=SLOW_MS)
            expect(info).to_contain_text("5000 samples/s")
        else:
            drop(page, "lubeviz-upload", good)
            expect(info, f"step {step}: the dropped file is not shown").to_contain_text(good.name, timeout=30_000)
            expect(info).to_contain_text("10000 samples/s")
            dropped_item(page, "lubeviz-upload", good.name)
    # The record shown is the file's indeed: identified near its own flows, not the sample's 420 / 600.
    page.get_by_role("button", name="Identify the supply flows").click()
    result = page.locator(".lubeviz-result")
    expect(result).to_contain_text("Q1 =", timeout=SLOW_MS)
    expect(result).to_contain_text(good.name)
    shown = text(result)
    q1, q2 = (float(re.search(rf"Q{k} = ([0-9.]+)", shown).group(1)) for k in (1, 2))
    assert abs(q1 - FILE_Q_MLMIN[0]) < 15 and abs(q2 - FILE_Q_MLMIN[1]) < 15, shown
    # ... and the sample loaded afterwards clears that result and is named as the sample.
    page.get_by_role("button", name="Load the sample record").click()
    expect(info).to_contain_text("sample record", timeout=SLOW_MS)
    expect(result).not_to_contain_text("Q1 =")


def test_identify_page_rejected_upload_is_marked_and_leaves_no_stale_result(app_page, records, screenshot):
    page, good, bad = app_page, records["good"], records["bad"]
    open_tab(page, "Identify")
    info, result = page.locator(".lubeviz-record-info"), page.locator(".lubeviz-result")
    message = page.locator(".lubeviz-upload-error")
    drop(page, "lubeviz-upload", good)
    expect(info).to_contain_text(good.name, timeout=30_000)
    page.get_by_role("button", name="Identify the supply flows").click()
    expect(result).to_contain_text("Q1 =", timeout=SLOW_MS)
    item = dropped_item(page, "lubeviz-upload", good.name)
    expect(item.locator(".filepond--panel-center")).not_to_have_css("background-color", REJECTED_RED)

    drop(page, "lubeviz-upload", bad)
    expect(message).to_be_visible(timeout=30_000)
    expect(message).to_contain_text(bad.name)
    expect(message).to_contain_text("y2: missing column")
    expect(message).to_contain_text("not loaded")
    # The dropper shows the dropped file as failed, not "Upload complete" in green.
    item = dropped_item(page, "lubeviz-upload", bad.name)
    expect(item.locator(".filepond--panel-center")).to_have_css("background-color", REJECTED_RED)
    expect(item.get_by_text("Upload complete")).to_be_hidden()
    # One place on the page tells the problem (not the alert and the job status both).
    expect(page.get_by_text("missing column")).to_have_count(1)
    # The record and the result still on screen are named as the previous record, never as the dropped file.
    expect(message).to_contain_text(f"still shows the previous record, {good.name}")
    expect(info).to_contain_text(good.name)
    expect(info).not_to_contain_text(bad.name)
    expect(result).to_contain_text(f"of {good.name}")
    expect(result).not_to_contain_text(bad.name)
    screenshot(page, "identify_rejected_upload")

    # A good file dropped afterwards loads, the message goes, and the dropper turns back to "loaded".
    drop(page, "lubeviz-upload", good)
    expect(message).to_be_hidden(timeout=30_000)
    expect(info).to_contain_text(good.name)
    expect(result).not_to_contain_text("Q1 =")  # a new record: the old result is gone
    item = dropped_item(page, "lubeviz-upload", good.name)
    expect(item.locator(".filepond--panel-center")).not_to_have_css("background-color", REJECTED_RED)


def test_diagnose_page_reloads_the_same_file_after_a_sample(app_page, records):
    page, good = app_page, records["good"]
    open_tab(page, "Diagnose")
    info = page.locator(".lubeviz-diagnose-record")
    expect(page.locator(".lubeviz-effect-story")).to_contain_text("The probes of plane 1 turned", timeout=SLOW_MS)
    drop(page, "lubeviz-diagnose-upload", good)
    expect(info).to_contain_text(good.name, timeout=30_000)
    # The file's metadata claims its flows (q1_mlmin, q2_mlmin), but a file may claim anything: no "Truth"
    # is shown but of a sample the page simulated itself (issue 34, item 8).
    expect(info).not_to_contain_text("Truth")
    # under a user's file the sample's controls are folded away (they say nothing about the file): opened here
    sample = page.get_by_role("button", name="Simulate a sample with this effect")
    expect(sample).to_be_hidden()
    page.get_by_text("Or a sample that carries an effect").click()
    sample.click()
    expect(info).to_contain_text("sample: the probes of plane 1 turned", timeout=SLOW_MS)
    expect(info).to_contain_text("Truth (this sample was simulated here): Q1 = 420, Q2 = 600 ml/min")
    dropped_item(page, "lubeviz-diagnose-upload", good.name)
    drop(page, "lubeviz-diagnose-upload", good)
    expect(info, "the same file dropped again is not shown").to_contain_text(good.name, timeout=30_000)
    expect(info).not_to_contain_text("Truth")
