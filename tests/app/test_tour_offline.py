"""A tour of every page in a real browser asks no outside host for anything (a plant's network is often closed) and
logs no console error (issue 38's acceptance: fonts and scripts served by the app; "cannot find a view for Legend"
72-89 times a session on the Rotor page)."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import urlparse

import pytest
from playwright.sync_api import expect

from lubeviz.effects import EFFECTS
from tests.app.harness import open_tab, wait_for_plot_title, wait_for_plots

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "assets" / "sample_record.csv"
SLOW_MS = 300_000
LOCAL = {"127.0.0.1", "localhost", ""}
# every text the page shows (`skip`: also leave out these elements' text, e.g. CODE: a file's syntax shown as code)
_TEXT_JS = """(skip) => {
  const out = [];
  const left = ["SCRIPT", "STYLE", ...skip];
  const walk = (node) => {
    if (node.nodeType === Node.TEXT_NODE) { out.push(node.textContent); return; }
    if (node.nodeType !== Node.ELEMENT_NODE && node.nodeType !== Node.DOCUMENT_FRAGMENT_NODE) return;
    if (node.nodeType === Node.ELEMENT_NODE && left.includes(node.tagName)) return;
    if (node.shadowRoot) walk(node.shadowRoot);
    for (const child of node.childNodes) walk(child);
  };
  walk(document.body);
  return out.join(" ");
}"""
# characters drawn as emoji, which need an emoji font (the verdicts' coloured circles, U+1F7E0-1F7EB, were these):
# U+1F000-1FAFF and the older symbols whose default presentation is emoji (a star or an arrow drawn as text is fine)
EMOJI = re.compile("[\U0001F000-\U0001FAFF\u2705\u274C\u2753-\u2757\u2B50\u2B55\u231A\u231B\u23E9-\u23F3]")


@pytest.fixture(scope="module")
def tour(browser, app_server):
    """(outside requests [(url, resource type)], console errors, each page's visible text) over a tour of every page:
    the start page, the Bearing page drawn, the Rotor page with an effect switched on, the Maps page, the sample record
    uploaded once on Identify and identified, "Diagnose this record" (the Diagnose page diagnoses it: no second
    upload), and the Maps page again, now of that record."""
    context = browser.new_context(viewport={"width": 1400, "height": 900})
    page = context.new_page()
    outside, errors = [], []

    def request(req):
        url = urlparse(req.url)
        if url.scheme in ("http", "https", "ws", "wss") and url.hostname not in LOCAL:
            outside.append((req.url, req.resource_type))

    texts, prose = {}, {}

    def visible(name):  # every text the page shows, shadow roots included (Panel renders its panes into them)
        texts[name] = page.evaluate(_TEXT_JS, [])
        prose[name] = page.evaluate(_TEXT_JS, ["CODE", "PRE"])  # without what is shown as code

    page.on("request", request)
    page.on("console", lambda msg: errors.append(msg.text) if msg.type == "error" else None)
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.goto(app_server + "/app")
    expect(page.locator(".lubeviz-start")).to_contain_text("Where to start", timeout=SLOW_MS)
    visible("Start")
    open_tab(page, "Bearing")
    wait_for_plot_title(page, "Pressure p(α, z) at Q = ", timeout_ms=SLOW_MS)
    visible("Bearing")
    open_tab(page, "Rotor")
    wait_for_plot_title(page, "Full spectrum at node 6", timeout_ms=SLOW_MS)
    wait_for_plots(page, count=4, timeout_ms=SLOW_MS)
    page.get_by_label("Effect switched on").select_option(label="bearing clearance (wear)")
    expect(page.locator(".lubeviz-rotor-summary")).to_contain_text("With the clearance of bearing 1", timeout=SLOW_MS)
    visible("Rotor")
    open_tab(page, "Maps")
    wait_for_plot_title(page, "fb1 over Q1 × Q2", timeout_ms=SLOW_MS)
    visible("Maps")
    open_tab(page, "Identify")
    page.locator(".lubeviz-upload input[type=file]").set_input_files(str(SAMPLE))
    expect(page.locator(".lubeviz-record-info")).to_contain_text("sample_record.csv", timeout=SLOW_MS)
    page.get_by_role("button", name="Identify the supply flows").click()
    expect(page.locator(".lubeviz-result")).to_contain_text(re.compile(r"Q1 = \d"), timeout=SLOW_MS)
    visible("Identify")
    page.get_by_role("button", name="Diagnose this record").click()  # opens Diagnose, which diagnoses it
    expect(page.locator(".lubeviz-verdict")).to_contain_text(re.compile(r"\w"), timeout=SLOW_MS)
    expect(page.locator(".lubeviz-diagnosis-flows")).to_contain_text("sample_record.csv", timeout=SLOW_MS)
    visible("Diagnose")
    open_tab(page, "Maps")
    expect(page.locator(".lubeviz-maps-summary")).to_contain_text("sample_record.csv", timeout=SLOW_MS)
    visible("Maps of the record")
    context.close()
    return outside, errors, texts, prose


def test_no_page_asks_an_outside_host_for_a_font_or_a_script(tour):
    # Panel's Fast design asked fonts.googleapis.com for Open Sans on every page load (`shell._offline`)
    outside, *_ = tour
    asked = sorted({url for url, kind in outside if kind in ("font", "script") or "font" in url})
    assert asked == []


def test_no_page_asks_an_outside_host_for_anything(tour):
    # Panel's loading.css and markdown.css went to cdn.holoviz.org once the Rotor page was drawn: a design applied to a
    # pane without a document yet fell back to the CDN, and the style sheet objects are shared by the whole page
    # (`shell._stylesheets_from_this_server`)
    outside, *_ = tour
    assert sorted({url for url, _ in outside}) == []


# "cannot find a view for Legend", about 70 a tour: a Rotor plot first drawn empty and unlabelled had no legend, and
# HoloViews added one to a figure the browser had drawn; BokehJS relaid the figure out before the legend had a view,
# and at every update after (the empty frames are labelled now: the legend is in the first drawing)
def test_no_page_logs_a_console_error(tour):
    _, errors, *_ = tour
    assert errors == []


def test_no_page_shows_an_emoji(tour):
    # the verdicts' coloured circles showed as empty boxes without an emoji font (issue 38): badges now
    _, _, texts, _ = tour
    assert set(texts) == {"Start", "Bearing", "Rotor", "Maps", "Identify", "Diagnose", "Maps of the record"}
    found = {name: sorted(set(EMOJI.findall(text))) for name, text in texts.items() if EMOJI.search(text)}
    assert found == {}
    assert "starved" in texts["Identify"] and "over-supplied" in texts["Identify"]  # the sample's verdicts, as words


def test_no_page_sends_the_reader_to_a_spec_they_cannot_open(tour):
    # the Identify page pointed at "SPEC §6 of the README" for the record's format, the machine guide at "SPEC §8"
    # (issue 38): the pages say what a record and a model file look like instead
    _, _, texts, _ = tour
    assert {name for name, text in texts.items() if "SPEC" in text} == set()
    assert "# sample_rate_hz" in texts["Identify"] and "x1, y1, x2, y2" in texts["Identify"]


def test_one_upload_is_the_record_of_identify_diagnose_and_maps(tour):
    # issue 38: "one record, three uploads": the record uploaded on Identify is diagnosed on Diagnose and drawn on Maps
    _, _, texts, _ = tour
    assert "sample_record.csv" in texts["Diagnose"] and "loaded on the Identify page" in texts["Diagnose"]
    assert "No record yet" not in texts["Diagnose"]
    assert re.search(r"Record:\s+sample_record.csv", texts["Maps of the record"])


# A parameter's or an effect's code name where a person reads: `clearance_um`, `angle_deg`, `clearance[bearing=1]`,
# `q_mlmin = [...]` (issue 38). What a file must hold, shown as code (a record's `# speed_hz: 75` header, a model
# file's `supply_mlmin`), is the file's syntax and is left out.
CODE_WORDS = re.compile(r"\b[a-z][a-z0-9]*_(?:um|deg|n|nm|c|hz|mlmin|kg|db)\b|\b[a-z_0-9]+\[[a-z_]+=[^\]]*\]|\b(?:"
                        + "|".join(n for n in EFFECTS if "_" in n or n[-1].isdigit()) + r")\b")


def test_no_page_shows_a_parameter_or_effect_by_its_code_name(tour):
    *_, texts = tour
    found = {name: sorted(set(CODE_WORDS.findall(text))) for name, text in texts.items() if CODE_WORDS.search(text)}
    assert found == {}
    assert "clearance of bearing 1" in texts["Rotor"]  # the effect named in words
