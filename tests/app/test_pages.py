"""The dashboard's pages in a real browser (Chromium driven by Playwright; see harness.py).

What a user does: open each page and see its plots, drag the supply slider and see the film change,
upload the sample record and read the identified flows, start a long job and keep using the page,
upload broken files and get a clear message while the app keeps serving.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import expect

from tests.app.harness import open_tab, plot_titles, set_slider, text, wait_for_plot_title, wait_for_plots

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "assets" / "sample_record.csv"
SLOW_MS = 240_000  # a cold machine builds the coefficient tables first (about a minute on 2 cores)


def test_start_page_explains_and_leads_to_the_pages(app_page, screenshot):
    expect(app_page.locator(".lubeviz-start")).to_contain_text("Where to start")
    screenshot(app_page, "start")


def test_bearing_page_draws_the_film_and_the_slider_starves_it(app_page, screenshot):
    open_tab(app_page, "Bearing")
    wait_for_plots(app_page, count=2, timeout_ms=SLOW_MS)
    wait_for_plot_title(app_page, "Pressure p(α, z) at Q = ", timeout_ms=SLOW_MS)
    expect(app_page.locator(".lubeviz-bearing-summary")).to_contain_text("eccentricity ratio", timeout=SLOW_MS)
    screenshot(app_page, "bearing")
    before = text(app_page.locator(".lubeviz-bearing-summary"))
    set_slider(app_page, "Supply flow Q1", 300)
    wait_for_plot_title(app_page, "Pressure p(α, z) at Q = 300 ml/min", timeout_ms=SLOW_MS)
    summary = app_page.locator(".lubeviz-bearing-summary")
    expect(summary).to_contain_text("Q = 300 ml/min", timeout=SLOW_MS)
    expect(summary).to_contain_text("starved")
    after = text(summary)

    def eccentricity(shown):
        return float(re.search(r"eccentricity ratio ε\s*([0-9.]+)", shown).group(1))

    assert eccentricity(after) > eccentricity(before)  # starving the bearing sinks the journal
    wait_for_plot_title(app_page, "Mid-plane pressure at Q = 300 ml/min", timeout_ms=SLOW_MS)  # every plot follows
    screenshot(app_page, "bearing_starved_300")


def test_rotor_page_draws_orbit_spectrum_and_responds_during_a_long_job(app_page, screenshot):
    open_tab(app_page, "Rotor")
    summary = app_page.locator(".lubeviz-rotor-summary")
    expect(summary).to_contain_text("Node 6", timeout=SLOW_MS)
    wait_for_plot_title(app_page, "Full spectrum at node 6", timeout_ms=SLOW_MS)
    # every plot of the response drawn (the machine, orbit, signals, spectrum, modes, two centrelines): the
    # browser is done with the first draw before the page's answer during a long job is timed
    wait_for_plots(app_page, count=7, timeout_ms=SLOW_MS)
    # The long job: the Campbell diagram solves the film at 30 speeds (seconds, in a worker process).
    app_page.get_by_role("button", name=re.compile("Compute Campbell diagram")).click()
    # (the job's start is not what is tested: on a fresh clone the server's first calls compile their numba code
    # with the GIL held, and the Cancel button's update waits for it; the page's answer below is what is tested)
    expect(app_page.get_by_role("button", name="Cancel").first).to_be_visible(timeout=SLOW_MS)
    set_slider(app_page, "Node", 13)
    expect(summary).to_contain_text("Node 13", timeout=3_000)  # the page answers while the job runs
    assert "Campbell diagram at Q1/Q2 = " not in " ".join(plot_titles(app_page))  # it was indeed still running
    wait_for_plot_title(app_page, "Campbell diagram at Q1/Q2 = ", timeout_ms=SLOW_MS)
    titles = " ".join(plot_titles(app_page))
    assert "first critical" in titles and "instability threshold" in titles
    screenshot(app_page, "rotor")


def test_maps_page_draws_error_map_and_search(app_page, screenshot):
    open_tab(app_page, "Maps")
    wait_for_plot_title(app_page, "ε_T and the root curves, nodes 6, 20", timeout_ms=SLOW_MS)
    expect(app_page.locator(".lubeviz-maps-summary")).to_contain_text("Identified", timeout=SLOW_MS)
    wait_for_plot_title(app_page, "fb1 over Q1 × Q2", timeout_ms=SLOW_MS)
    screenshot(app_page, "maps")


def upload(page, path: Path):
    page.locator(".lubeviz-upload input[type=file]").set_input_files(str(path))


def test_identify_page_identifies_the_sample_record(app_page, screenshot):
    open_tab(app_page, "Identify")
    upload(app_page, SAMPLE)
    expect(app_page.locator(".lubeviz-record-info")).to_contain_text("sample_record.csv", timeout=SLOW_MS)
    wait_for_plot_title(app_page, "Orbit, plane 1 (node 6)")
    app_page.get_by_role("button", name="Identify the supply flows").click()
    result = app_page.locator(".lubeviz-result")
    expect(result).to_contain_text("Q1 =", timeout=SLOW_MS)
    shown = text(result)
    q1 = float(re.search(r"Q1 = ([0-9.]+)", shown).group(1))
    q2 = float(re.search(r"Q2 = ([0-9.]+)", shown).group(1))
    # The sample was simulated at 420 / 600 ml/min with 12 dB of noise (assets/sample_record.csv).
    assert abs(q1 - 420) < 10 and abs(q2 - 600) < 10
    assert "starved" in shown and "over-supplied" in shown
    # best mode counts its Levenberg-Marquardt steps; the iteration limit on the page is paper mode's (issue 38:
    # "Max iterations 15" beside "converged in 101 iterations")
    steps = int(re.search(r"(\d+) Levenberg-Marquardt steps over all starts", shown).group(1))
    assert steps > 0
    expect(app_page.get_by_text("Paper mode: Newton iterations per start")).to_be_visible()
    expect(app_page.get_by_text("Max iterations")).to_have_count(0)
    expect(app_page.locator(".lubeviz-features")).to_contain_text("fb1")
    screenshot(app_page, "identify")


def _sample_lines():
    return SAMPLE.read_text().splitlines()


def _broken_files(tmp: Path) -> dict[str, tuple[Path, str]]:
    """file -> (path, text the page's message must contain)."""
    lines = _sample_lines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    out = {}

    def write(name, text):
        p = tmp / name
        p.write_text(text)
        return p

    wrong = list(lines)
    wrong[header] = wrong[header].replace("y2", "z2")
    out["wrong_columns.csv"] = (write("wrong_columns.csv", "\n".join(wrong)), "y2")
    nan = list(lines)
    nan[header + 5] = ",".join(["nan"] + nan[header + 5].split(",")[1:])
    out["nan.csv"] = (write("nan.csv", "\n".join(nan)), "nan.csv")
    text = list(lines)
    text[header + 7] = ",".join(["abc"] + text[header + 7].split(",")[1:])
    out["text.csv"] = (write("text.csv", "\n".join(text)), "abc")
    out["empty.csv"] = (write("empty.csv", ""), "empty")
    return out


def test_malformed_uploads_show_a_message_and_the_app_keeps_serving(app_page, tmp_path, screenshot):
    open_tab(app_page, "Identify")
    message = app_page.locator(".lubeviz-upload-error")
    for name, (path, expected) in _broken_files(tmp_path).items():
        upload(app_page, path)
        expect(message).to_contain_text(name, timeout=30_000)
        expect(message).to_contain_text(expected)
        expect(message).to_contain_text("not loaded")
    screenshot(app_page, "identify_bad_upload")
    # A file over the upload limit is refused in the browser, before any byte reaches the server.
    huge = tmp_path / "huge.csv"
    with huge.open("wb") as f:
        f.truncate(60 * 1024 * 1024)
    upload(app_page, huge)
    expect(app_page.get_by_text(re.compile("too large", re.I)).first).to_be_visible(timeout=30_000)
    # ... and the app still serves: the sample loads afterwards.
    app_page.get_by_role("button", name="Load the sample record").click()
    expect(app_page.locator(".lubeviz-record-info")).to_contain_text("sample_record.csv", timeout=SLOW_MS)


def test_two_sessions_do_not_share_flows(page, app_server, browser):
    """One session's slider does not move another's (each session has its own model objects)."""
    other = browser.new_context().new_page()
    for p in (page, other):
        p.goto(app_server + "/app")
        open_tab(p, "Bearing")
        wait_for_plot_title(p, "Pressure p(α, z) at Q = ", timeout_ms=SLOW_MS)
    set_slider(page, "Supply flow Q1", 300)
    wait_for_plot_title(page, "at Q = 300 ml/min", timeout_ms=SLOW_MS)
    titles = " ".join(plot_titles(other))
    assert "at Q = 300 ml/min" not in titles
    assert np.isfinite(float(re.search(r"at Q = ([0-9.]+) ml/min", titles).group(1)))
    other.context.close()
