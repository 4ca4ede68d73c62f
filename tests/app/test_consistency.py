"""One record, one answer; a plot says which inputs it shows (issue 13, items 2, 3 and 5) — in a real browser.

- The Maps page, drawing the Identify page's record, shows the Identify page's answer with the same numbers:
  labelled with its mode when the Maps page searches in another mode, and as its own result in the same mode.
- The Campbell diagram says when the flows have moved since it was computed ("stale") until recomputed, and
  its job panel keeps describing the Campbell job while other jobs of the Rotor page run.
- The Maps page fits a 1400 px wide window: no element reaches past its right edge.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from playwright.sync_api import expect

from tests.app.harness import elements_past_right_edge, open_tab, plot_titles, text, wait_for_plot_title

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "assets" / "sample_record.csv"
SLOW_MS = 240_000  # a cold machine builds the coefficient tables first; a 2-core machine under load is slow


_LEGEND_LABELS_JS = """() => {
  const out = [];
  for (const doc of Bokeh.documents) for (const m of doc.all_models)
    if (m.type === "LegendItem" && m.label !== null) out.push(typeof m.label === "object" ? m.label.value : m.label);
  return out;
}"""


def legend_labels(page) -> list[str]:
    """The labels of the legend entries of the plots on the page (drawn on the canvas, read from BokehJS)."""
    return page.evaluate(_LEGEND_LABELS_JS)


def flows_after(shown: str, prefix: str) -> tuple[float, float]:
    """(Q1, Q2) in ml/min from the first "Q1 = a … Q2 = b" after `prefix` in `shown`."""
    m = re.search(re.escape(prefix) + r".*?Q1 = ([0-9.]+).*?Q2 = ([0-9.]+)", shown, re.S)
    assert m, f"no {prefix!r} followed by Q1 and Q2 in: {shown!r}"
    return float(m.group(1)), float(m.group(2))


def identify_the_sample(page) -> tuple[float, float]:
    """Load the sample record on the Identify page, identify it (the page's default mode, best) and return
    the flows the page shows (ml/min)."""
    open_tab(page, "Identify")
    page.get_by_role("button", name="Load the sample record").click()
    expect(page.locator(".lubeviz-record-info")).to_contain_text("sample_record.csv", timeout=SLOW_MS)
    page.get_by_role("button", name="Identify the supply flows").click()
    result = page.locator(".lubeviz-result")
    expect(result).to_contain_text("Q1 =", timeout=SLOW_MS)
    expect(result).to_contain_text("best mode")
    return flows_after(text(result), "Identified supply flows")


def test_maps_page_shows_the_identify_pages_answer_for_its_record(app_page, screenshot):
    q_identify = identify_the_sample(app_page)
    open_tab(app_page, "Maps")
    summary = app_page.locator(".lubeviz-maps-summary")
    expect(summary).to_contain_text("Identified", timeout=SLOW_MS)  # the page's own first map is drawn
    app_page.get_by_label("Source").select_option(label="the session's record (loaded on Identify or Diagnose)")
    # The Maps page searches in paper mode by default: the Identify page's best-mode answer is shown beside
    # its own, labelled, with the Identify page's numbers.
    expect(summary).to_contain_text("Same record, another search", timeout=SLOW_MS)
    expect(summary).to_contain_text("Identify page's answer (best mode)")
    shown = text(summary)
    assert flows_after(shown, "Identify page's answer (best mode)") == pytest.approx(q_identify, abs=0.11)
    assert "Identified (paper mode)" in shown
    wait_for_plot_title(app_page, "(paper mode search)", timeout_ms=SLOW_MS)
    assert "Identify page (best mode)" in legend_labels(app_page)  # the diamond, in the map's legend
    screenshot(app_page, "maps_identify_record_paper_mode")
    # The same mode as the Identify page: one answer, the Identify page's, drawn as this page's result.
    app_page.get_by_label("Search mode").select_option("best")
    expect(summary).to_contain_text("Identified (best mode)", timeout=SLOW_MS)
    expect(summary).not_to_contain_text("another search")
    assert flows_after(text(summary), "Identified (best mode)") == pytest.approx(q_identify, abs=0.11)
    wait_for_plot_title(app_page, "(best mode search)", timeout_ms=SLOW_MS)


def test_maps_page_fits_a_1400_px_window_and_opens_away_from_q_t(app_page, screenshot):
    app_page.set_viewport_size({"width": 1400, "height": 900})
    open_tab(app_page, "Maps")
    wait_for_plot_title(app_page, "ε_T and the root curves", timeout_ms=SLOW_MS)
    for name in ("fb1", "fb2", "φ1", "φ2"):
        wait_for_plot_title(app_page, f"{name} over Q1 × Q2", timeout_ms=SLOW_MS)
    summary = app_page.locator(".lubeviz-maps-summary")
    expect(summary).to_contain_text("True flows", timeout=SLOW_MS)
    # The simulated record's own flows: one bearing starved, the other over-supplied, not both at Q_T.
    q1, q2 = (float(v) for v in re.search(r"True flows ([0-9.]+) / ([0-9.]+) ml/min", text(summary)).groups())
    q_t = float(re.search(r"Q_T = ([0-9.]+) ml/min", text(summary)).group(1))
    assert q1 < 0.9 * q_t and q2 > 1.1 * q_t
    # Widgets labelled as a person writes them.
    for label in ("SNR (dB)", "Grid points"):
        expect(app_page.locator(".bk-Slider", has_text=label).first).to_be_visible()
    assert not any("phi" in t for t in plot_titles(app_page))
    app_page.wait_for_timeout(1000)  # let Bokeh lay the grid of feature maps out
    assert app_page.evaluate("() => document.documentElement.scrollWidth <= window.innerWidth")
    # The template scrolls and clips inside its own containers, so also look at every element's box.
    assert elements_past_right_edge(app_page) == []
    screenshot(app_page, "maps_1400px")


_LINE_COLORS_JS = """types => {
  const out = [];
  for (const doc of Bokeh.documents) for (const m of doc.all_models)
    if (types.includes(m.type)) {
      const c = m.line_color;
      out.push(c !== null && typeof c === "object" ? c.value : c);
    }
  return out;
}"""


def _contrast(a: str, b: str) -> float:
    """WCAG contrast ratio of two "#rrggbb" colours."""
    def luminance(h):
        c = [int(h[i:i + 2], 16) / 255 for i in (1, 3, 5)]
        c = [x / 12.92 if x <= 0.03928 else ((x + 0.055) / 1.055) ** 2.4 for x in c]
        return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
    lo, hi = sorted((luminance(a), luminance(b)))
    return (hi + 0.05) / (lo + 0.05)


def test_maps_page_search_paths_and_q_t_lines_show_in_the_dark_theme(page, app_server, screenshot):
    page.set_viewport_size({"width": 1400, "height": 900})
    page.goto(app_server + "/app?theme=dark")
    open_tab(page, "Maps")
    wait_for_plot_title(page, "ε_T and the root curves", timeout_ms=SLOW_MS)
    # The search paths (Line) and the Q_T lines (Span) sit on the grey ε_T map, the same in either theme:
    # each line must stand out from its darkest and its lightest grey (no black, no white).
    colors = page.evaluate(_LINE_COLORS_JS, ["Line", "Span"])
    assert colors, "no search path or Q_T line on the Maps page"
    from lubeviz.app.maps_page import ERROR_GREYS

    for color in colors:
        assert re.fullmatch(r"#[0-9a-fA-F]{6}", color), f"{color!r}: expected a colour chosen by its contrast"
        assert min(_contrast(color, ERROR_GREYS[0]), _contrast(color, ERROR_GREYS[-1])) >= 2.5, color
    screenshot(page, "maps_dark")


def test_campbell_diagram_says_when_the_flows_have_moved(app_page, screenshot):
    open_tab(app_page, "Rotor")
    summary = app_page.locator(".lubeviz-rotor-summary")
    expect(summary).to_contain_text("Node 6", timeout=SLOW_MS)
    stale = app_page.locator(".lubeviz-campbell-stale")
    campbell_status = app_page.locator(".lubeviz-campbell-panel").locator(".lubeviz-job-status")
    button = app_page.get_by_role("button", name=re.compile("Compute Campbell diagram"))
    q1_handle, q2_handle = (app_page.locator(".bk-Slider", has_text=f"Supply flow Q{k}").locator(".noUi-handle").first
                            for k in (1, 2))
    # Flows of this test's own: the server's memory keeps Campbell diagrams by flows for every session, and
    # test_pages' Rotor test needs the one at the start flows still to compute.
    for _ in range(10):
        q2_handle.press("ArrowRight")
    q1, q2 = (float(h.get_attribute("aria-valuenow")) for h in (q1_handle, q2_handle))
    expect(summary).to_contain_text(f"Q2 = {q2:.0f} ml/min", timeout=SLOW_MS)
    button.click()
    wait_for_plot_title(app_page, f"Q1/Q2 = {q1:.0f}/{q2:.0f} ml/min:", timeout_ms=SLOW_MS)
    expect(campbell_status).to_contain_text(f"Campbell diagram at Q1 = {q1:.0f}, Q2 = {q2:.0f} ml/min",
                                            timeout=30_000)
    expect(stale).to_be_hidden()
    assert not any("(stale)" in t for t in plot_titles(app_page))
    # Move the Q1 slider 20 steps down, one key press at a time (each one a change of the flows).
    for _ in range(20):
        q1_handle.press("ArrowLeft")
    moved = float(q1_handle.get_attribute("aria-valuenow"))
    assert moved < q1 - 10
    expect(stale).to_be_visible(timeout=30_000)
    expect(stale).to_contain_text(f"computed for Q1 = {q1:.0f}, Q2 = {q2:.0f} ml/min")
    expect(stale).to_contain_text("the flows have changed: press the button to recompute")
    wait_for_plot_title(app_page, "(stale)", timeout_ms=30_000)
    # The response to the new flows is computed (another job of this page) ...
    expect(summary).to_contain_text(f"Q1 = {moved:.0f} ml/min", timeout=SLOW_MS)
    # ... and the Campbell job panel still describes the Campbell job, not the response's.
    shown = text(campbell_status)
    assert f"Campbell diagram at Q1 = {q1:.0f}" in shown and "response" not in shown, shown
    screenshot(app_page, "rotor_campbell_stale")
    button.click()
    expect(stale).to_be_hidden(timeout=SLOW_MS)
    wait_for_plot_title(app_page, f"Q1/Q2 = {moved:.0f}/{q2:.0f} ml/min:", timeout_ms=SLOW_MS)
    # (a replaced figure's title may linger among the document's models: look at the new diagram's only)
    new = [t for t in plot_titles(app_page) if f"Q1/Q2 = {moved:.0f}/{q2:.0f} ml/min:" in t]
    assert new and not any("(stale)" in t for t in new), new
    expect(campbell_status).to_contain_text(f"Campbell diagram at Q1 = {moved:.0f}, Q2 = {q2:.0f} ml/min")
