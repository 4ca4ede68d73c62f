"""The start page, the glossary and the layout of every page in a real browser (Chromium via Playwright).

What a newcomer does: read the start page (the machine and a bearing drawn, what each page is for, the
glossary), press a button that opens a page, open the glossary from any page. What a narrow window must
not do: make the page wider than the window (a horizontal scrollbar hides the right edge of plots and
tables). And the dark theme (`?theme=dark`, the template's theme switch) is pictured page by page.
"""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from lubeviz.app.glossary import GLOSSARY
from lubeviz.app.shell import PAGE_PURPOSES
from tests.app.harness import elements_past_right_edge, open_tab, wait_for_panel, wait_for_plot_title, wait_for_plots

pytestmark = pytest.mark.browser

SLOW_MS = 240_000  # a cold machine builds the coefficient tables first (about a minute on 2 cores)
SWEEP_MS = 600_000  # the Bearing page's film over 93 supply flows, once per server
WIDTHS = (1400, 800)
PAGES = ("Start", *PAGE_PURPOSES)  # Start, Bearing, Rotor, Maps, Identify, Diagnose


def active_tab(page) -> str:
    return page.locator(".bk-tab.bk-active").first.inner_text().strip()


# --- each page shown with its plots drawn (the waits of test_pages.py) ------------------------------------

def _start(page):
    expect(page.locator(".lubeviz-start")).to_contain_text("Where to start")


def _bearing(page):
    wait_for_plots(page, count=2, timeout_ms=SLOW_MS)
    wait_for_plot_title(page, "Pressure p(α, z) at Q = ", timeout_ms=SLOW_MS)
    expect(page.locator(".lubeviz-bearing-summary")).to_contain_text("eccentricity ratio", timeout=SLOW_MS)
    # The locus and coefficient plots fill in when the sweep over Q is done (a minute per server, then shared).
    page.locator(".lubeviz-pages").get_by_text("flows ready", exact=False).first.wait_for(timeout=SWEEP_MS)


def _rotor(page):
    expect(page.locator(".lubeviz-rotor-summary")).to_contain_text("Node 6", timeout=SLOW_MS)
    wait_for_plot_title(page, "Full spectrum at node 6", timeout_ms=SLOW_MS)
    wait_for_plots(page, count=4, timeout_ms=SLOW_MS)


def _maps(page):
    wait_for_plot_title(page, "ε_T and the root curves, nodes 6, 20", timeout_ms=SLOW_MS)
    expect(page.locator(".lubeviz-maps-summary")).to_contain_text("Identified", timeout=SLOW_MS)
    wait_for_plot_title(page, "fb1 over Q1 × Q2", timeout_ms=SLOW_MS)


def _identify(page):
    # With a record loaded the page shows its widest content: signals, orbits and spectra.
    page.get_by_role("button", name="Load the sample record").click()
    expect(page.locator(".lubeviz-record-info")).to_contain_text("sample_record.csv", timeout=SLOW_MS)
    wait_for_plot_title(page, "Orbit, plane 1 (node 6)", timeout_ms=SLOW_MS)


def _diagnose(page):
    expect(page.locator(".lubeviz-effect-story")).to_contain_text("The probes of plane 1 turned", timeout=SLOW_MS)
    wait_for_plots(page, count=1, timeout_ms=SLOW_MS)


SHOWN = {"Start": _start, "Bearing": _bearing, "Rotor": _rotor, "Maps": _maps, "Identify": _identify,
         "Diagnose": _diagnose}


def show(page, name: str):
    """Open the page `name` from the start page and wait until its plots are drawn and Bokeh is idle."""
    if name != "Start":
        open_tab(page, name)
    SHOWN[name](page)
    wait_for_panel(page, SLOW_MS)
    page.evaluate("() => new Promise(done => requestAnimationFrame(() => requestAnimationFrame(done)))")


# --- the start page ----------------------------------------------------------------------------------------

def test_start_page_draws_the_machine_and_a_bearing_inline(app_page):
    figures = app_page.locator(".lubeviz-start-figures")
    svgs = figures.locator("svg")
    expect(svgs).to_have_count(2)
    titles = " ".join(svgs.nth(k).locator("title").first.text_content() for k in range(2))
    for part in ("three discs", "two grooved", "probe", "axial groove", "cavitated", "clearance"):
        assert part in titles, f"{part!r} not in the pictures' titles: {titles}"
    for k in range(2):  # drawn, not an empty box
        box = svgs.nth(k).bounding_box()
        assert box["width"] > 250 and box["height"] > 150, box
    # Works offline: the pictures are the page's own markup, and refer only to their own parts (#id).
    assert figures.evaluate("e => (e.shadowRoot || e).querySelectorAll('img, object, iframe').length") == 0
    refs = figures.evaluate("e => [...(e.shadowRoot || e).querySelectorAll('svg [href], svg [src]')]"
                            ".map(x => x.getAttribute('href') || x.getAttribute('src'))")
    assert all(r.startswith("#") for r in refs), refs


def test_start_page_explains_each_page_and_its_button_opens_it(app_page):
    start = app_page.locator(".lubeviz-start")
    expect(start).to_contain_text("Where to start")
    for name in PAGE_PURPOSES:
        expect(start).to_contain_text(PAGE_PURPOSES[name][:40])
        app_page.get_by_role("button", name=f"Open {name}").click()
        expect(app_page.locator(".bk-tab.bk-active").first).to_have_text(name)
        open_tab(app_page, "Start")
        expect(app_page.locator(".bk-tab.bk-active").first).to_have_text("Start")


def test_an_open_button_switches_the_tab_while_the_server_is_busy(page, app_server):
    # On a loaded machine the server may take tens of seconds to answer (building a page opened before): the
    # start page's buttons switch the tab in the browser (its content, the spinner then the page, comes from the
    # server: the tabs are dynamic), and the server builds the page when it gets the message. Here the page's messages to the server are held back while it clicks.
    held, hold, server = [], [False], []

    def route(ws):
        server.append(ws.connect_to_server())
        ws.on_message(lambda message: held.append(message) if hold[0] else server[-1].send(message))

    page.route_web_socket(re.compile(r".*/app/ws.*"), route)
    page.goto(app_server + "/app")
    wait_for_panel(page)
    assert server, "the page's websocket was not routed"
    hold[0] = True
    page.get_by_role("button", name="Open Diagnose").click()
    expect(page.locator(".bk-tab.bk-active").first).to_have_text("Diagnose", timeout=5_000)
    expect(page.locator(".lubeviz-diagnose-run")).to_have_count(0)  # not built yet: the server has not heard
    assert held, "the tab switch was not sent to the server"
    hold[0] = False
    for message in held:
        server[-1].send(message)
    expect(page.locator(".lubeviz-diagnose-run").first).to_be_visible(timeout=SLOW_MS)  # then built


def test_glossary_is_on_the_start_page_with_tooltips(app_page):
    glossary = app_page.locator(".lubeviz-start-glossary")
    for term, text in GLOSSARY.items():
        expect(glossary).to_contain_text(term)
        expect(glossary).to_contain_text(text[:60])
    # The intro's symbols carry their explanation as a tooltip.
    tooltips = app_page.locator(".lubeviz-start abbr[title]")
    expect(tooltips.first).to_be_attached()
    titles = tooltips.evaluate_all("els => els.map(e => e.getAttribute('title'))")
    assert any(t.startswith("The oil flow a bearing leaks") for t in titles), titles  # Q_T


@pytest.mark.parametrize("tab", ["Start", "Identify"])
def test_glossary_opens_from_the_header_on_any_page(app_page, tab):
    if tab != "Start":
        open_tab(app_page, tab)
        expect(app_page.locator(".bk-tab.bk-active").first).to_have_text(tab)
    dialog = app_page.locator(".lubeviz-glossary-dialog")
    expect(dialog).not_to_be_visible()
    app_page.get_by_role("button", name="Glossary").click()
    expect(dialog).to_be_visible()
    for term in GLOSSARY:
        expect(dialog).to_contain_text(term)


# --- layout: no page wider than the window --------------------------------------------------------------

@pytest.mark.parametrize("width", WIDTHS)
def test_no_page_is_wider_than_the_window(page, app_server, width):
    """Every page in turn, opened from the start page of one session as a reader goes through them (one page load
    per width, not one per page: the pages' layouts do not depend on which was opened first)."""
    page.set_viewport_size({"width": width, "height": 900})
    page.goto(app_server + "/app")
    wait_for_panel(page)
    too_wide = []
    for name in PAGES:
        show(page, name)
        assert active_tab(page) == name
        scroll_width, inner_width = page.evaluate("() => [document.documentElement.scrollWidth, window.innerWidth]")
        past = elements_past_right_edge(page)
        # The template scrolls inside #main and Panel's layouts clip what overflows them, so a page can cut a
        # plot off at the window's edge with the document no wider than the window: both are checked.
        if scroll_width > inner_width + 1 or past:
            too_wide.append(f"{name} at {width} px: the document is {scroll_width} px wide in a {inner_width} px "
                            f"window; {len(past)} element(s) reach past its right edge:\n" + "\n".join(past[:25]))
    assert not too_wide, "\n".join(too_wide)


@pytest.mark.parametrize("width", WIDTHS)
def test_the_header_title_is_read_whole(page, app_server, width):
    """At 800 px the title's letters get smaller rather than cut (an ellipsis only below that)."""
    page.set_viewport_size({"width": width, "height": 600})
    page.goto(app_server + "/app")
    wait_for_panel(page)
    title = page.locator("#header .title").first
    expect(title).to_contain_text("bearing lubrication from shaft vibration")
    scroll, client = title.evaluate("e => [e.scrollWidth, e.clientWidth]")
    assert scroll <= client, f"the header title is cut at {width} px: {scroll} px of text in {client} px"


# --- dark theme --------------------------------------------------------------------------------------------

def test_dark_theme_screenshots_of_every_page(page, app_server, screenshot):
    page.goto(app_server + "/app?theme=dark")
    wait_for_panel(page)
    background = page.evaluate("() => getComputedStyle(document.body).backgroundColor")
    rgb = [int(v) for v in background[background.index("(") + 1:background.index(")")].split(",")[:3]]
    assert sum(rgb) < 3 * 100, f"?theme=dark shows a light page: body background {background}"
    for name in PAGES:
        show(page, name)
        path = screenshot(page, f"dark_{name.lower()}")
        assert path.stat().st_size > 10_000, path  # a picture, not an empty frame
