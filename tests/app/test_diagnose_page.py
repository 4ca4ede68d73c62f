"""The Diagnose page and the Rotor page's effects in a real browser (Chromium driven by Playwright).

What a user does: simulate a sample record that carries an effect (a probe pair turned 5°), diagnose it
and read the named effect and the flows before and after, keep using the page while the diagnosis runs,
download the report; on the Rotor page, switch an effect on and see the orbit's fb and φ change.
"""

from __future__ import annotations

import re
import time

import pytest
from playwright.sync_api import expect

from tests.app.harness import open_tab, plot_titles, text, wait_for_plot_title

pytestmark = pytest.mark.browser

SLOW_MS = 240_000  # a cold machine builds the coefficient tables first
TRUE_MLMIN = (420.0, 600.0)  # the page's default sample flows


def test_diagnose_page_names_the_effect_and_downloads_the_report(app_page, screenshot):
    page = app_page
    open_tab(page, "Diagnose")
    story = page.locator(".lubeviz-effect-story")
    expect(story).to_contain_text("The probes of plane 1 turned", timeout=SLOW_MS)
    page.get_by_role("button", name="Simulate a sample with this effect").click()
    expect(page.locator(".lubeviz-diagnose-record")).to_contain_text("sample: the probes of plane 1 turned",
                                                                     timeout=SLOW_MS)
    page.get_by_role("button", name="Diagnose").click()
    verdict = page.locator(".lubeviz-verdict")
    # The page answers while the diagnosis runs: another widget changes what it shows at once.
    expect(page.get_by_role("button", name="Cancel").first).to_be_visible(timeout=30_000)
    t0 = time.perf_counter()
    page.get_by_label("Effect in the sample").select_option(label="a bowed shaft")
    expect(story).to_contain_text("A residual bow", timeout=5_000)
    answered = time.perf_counter() - t0
    running = page.get_by_role("button", name="Cancel").first.is_visible()
    expect(verdict).to_contain_text("Effect added: the probes of plane 1 turned", timeout=SLOW_MS)
    assert answered < 5.0 and running, f"the page answered in {answered:.1f} s (diagnosis still running: {running})"

    flows_pane = page.locator(".lubeviz-diagnosis-flows")
    expect(flows_pane).to_contain_text(re.compile(r"Q2 = [0-9.]+ ± .*Q2 = [0-9.]+ ± ", re.S), timeout=30_000)
    flows = text(flows_pane)
    q1 = [float(v) for v in re.findall(r"Q1 = ([0-9.]+) ± ", flows)]
    q2 = [float(v) for v in re.findall(r"Q2 = ([0-9.]+) ± ", flows)]
    assert len(q1) == len(q2) == 2, flows  # before and after
    assert abs(q1[1] - TRUE_MLMIN[0]) < 10 and abs(q2[1] - TRUE_MLMIN[1]) < 10  # with the effect: right
    assert abs(q1[1] - TRUE_MLMIN[0]) < abs(q1[0] - TRUE_MLMIN[0])  # ... and closer than the plain fit
    assert "starved" in flows and "over-supplied" in flows
    expect(page.locator(".lubeviz-candidates")).to_contain_text("the probes of plane 1 turned")
    wait_for_plot_title(page, "before and after the probes of plane 1 turned", timeout_ms=SLOW_MS)
    wait_for_plot_title(page, "χ² over Q1 × Q2, with the probes of plane 1 turned", timeout_ms=SLOW_MS)

    # the work order's fields, typed on the page, go into the report (issue 38)
    page.locator(".lubeviz-report-asset input").fill("P-101 B feed pump")
    page.locator(".lubeviz-report-operator input").fill("A. Engineer")
    page.locator(".lubeviz-report-comment textarea").fill("seen at the weekly round")
    page.locator(".lubeviz-report-comment textarea").press("Tab")  # a text area sends its value when left
    page.wait_for_timeout(500)
    with page.expect_download(timeout=60_000) as download:
        page.get_by_role("button", name=re.compile("Download report")).click()
    report = open(download.value.path(), encoding="utf-8").read()
    # named after the record (the sample) and the date, not "lubeviz-diagnosis.html"
    assert re.fullmatch(r"lubeviz-sample-the-probes-of-plane-1-turned-\d{4}-\d\d-\d\d\.html",
                        download.value.suggested_filename), download.value.suggested_filename
    assert "P-101 B feed pump" in report and "A. Engineer" in report and "seen at the weekly round" in report
    assert report.lstrip().lower().startswith("<!doctype html>")
    assert report.count("<svg") >= 2 and "the probes of plane 1 turned" in report and "probe_rotation" not in report
    assert "http" not in report.lower()
    screenshot(page, "diagnose")


def test_rotor_page_effect_moves_the_orbit_features(app_page, screenshot):
    page = app_page
    open_tab(page, "Rotor")
    summary = page.locator(".lubeviz-rotor-summary")
    expect(summary).to_contain_text("Node 6", timeout=SLOW_MS)
    wait_for_plot_title(page, "Shaft centreline, bearing 1", timeout_ms=SLOW_MS)
    before = text(summary)
    page.get_by_label("Effect switched on").select_option(label="oil viscosity")
    expect(summary).to_contain_text("With the oil's viscosity in every bearing", timeout=SLOW_MS)
    after = text(summary)

    def fb(shown):
        return float(re.search(r"fb = \|Zf\|/\|Zb\|\s*\|?\s*([0-9.]+)", shown).group(1))

    assert fb(after) != fb(before)  # hotter oil (factor 0.7) changes the orbit's shape
    assert re.search(r"fb [0-9.]+ → [0-9.]+, φ -?[0-9.]+° → -?[0-9.]+°", after)
    wait_for_plot_title(page, "Shaft centreline, bearing 1: ε", timeout_ms=SLOW_MS)
    assert any("with viscosity" in t or "Full spectrum" in t for t in plot_titles(page))
    screenshot(page, "rotor_effect")
