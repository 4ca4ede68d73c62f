"""Teaching views that do not mislead (issue 13, item 3), Bearing page, in a real browser (see harness.py).

A colour means one value at every flow: θ on 0–1 and the pressure on one scale for the whole sweep while
the colour scale is "fixed" (the default); "auto" spans each frame. Q_T is marked on the supply slider and
named with its value in the legends of the stiffness and damping plots.

Colour bars, legends and titles are drawn on canvases; the tests read them from BokehJS's models. One page
(one session) serves the whole module: each test leaves the page as it found it (colour scale "fixed").
"""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.app.harness import PLOT_TIMEOUT_MS, set_slider, slider, wait_for_panel, wait_for_plot_title

pytestmark = pytest.mark.browser

SLOW_MS = 240_000  # a cold server solves Q_T and the films at both ends of the slider before the first frame
SLIDER = "Supply flow Q1"
PRESSURE, THETA = "p (MPa)", "θ (–)"  # the colour bars' titles

# {colour bar title: [low, high]} of every colour bar on the page (HoloViews updates its mapper in place).
_COLOUR_BARS_JS = """() => {
  const out = {};
  for (const doc of Bokeh.documents)
    for (const m of doc.all_models)
      if (m.type === "ColorBar" && typeof m.title === "string" && m.color_mapper)
        out[m.title] = [m.color_mapper.low, m.color_mapper.high];
  return out;
}"""

# The labels of every legend entry on the page.
_LEGEND_LABELS_JS = """() => {
  const out = [];
  for (const doc of Bokeh.documents)
    for (const m of doc.all_models)
      if (m.type === "LegendItem" && m.label != null)
        out.push(typeof m.label === "string" ? m.label : String(m.label.value ?? m.label.field ?? ""));
  return out;
}"""


@pytest.fixture(scope="module")
def bearing_page(browser, app_server):
    """One browser page on the Bearing tab, its fields drawn, for the whole module."""
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    page.goto(app_server + "/app")
    wait_for_panel(page)
    page.locator(".bk-tab", has_text="Bearing").first.click()
    wait_for_plot_title(page, "Pressure p(α, z) at Q = ", timeout_ms=SLOW_MS)
    expect(page.locator(".lubeviz-bearing-summary")).to_contain_text("eccentricity ratio", timeout=SLOW_MS)
    yield page
    context.close()


def colour_bars(page) -> dict[str, list[float]]:
    return page.evaluate(_COLOUR_BARS_JS)


def summary_text(page) -> str:
    return page.locator(".lubeviz-bearing-summary").evaluate("e => (e.shadowRoot || e).textContent")


def shown_max_pressure(page) -> float:
    """The frame's peak pressure (MPa) as the summary table shows it."""
    return float(re.search(r"maximum pressure\s*\|?\s*([0-9.]+)\s*MPa", summary_text(page)).group(1))


def show_flow(page, q_mlmin: float) -> None:
    """Move the supply slider to `q_mlmin` and wait until both fields and the summary show that flow."""
    set_slider(page, SLIDER, q_mlmin)
    for field in ("Pressure p(α, z)", "Oil fraction θ(α, z)"):
        wait_for_plot_title(page, f"{field} at Q = {q_mlmin:.0f} ml/min", timeout_ms=SLOW_MS)
    expect(page.locator(".lubeviz-bearing-summary")).to_contain_text(f"Q = {q_mlmin:.0f} ml/min",
                                                                      timeout=SLOW_MS)


def slider_range(page) -> tuple[float, float]:
    handle = slider(page, SLIDER).locator(".noUi-handle").first
    return tuple(float(handle.get_attribute(a)) for a in ("aria-valuemin", "aria-valuemax"))


def wait_for_colour_bar(page, title: str, predicate_js: str, what: str) -> list[float]:
    """Wait until the colour bar `title`'s [low, high] satisfies `predicate_js` ("(lo, hi) => …"); return it.
    The mapper is patched in the same message as the title, but a slow browser may lag a frame."""
    js = f"title => {{ const r = ({_COLOUR_BARS_JS})()[title]; return r != null && ({predicate_js})(r[0], r[1]); }}"
    try:
        page.wait_for_function(js, arg=title, timeout=PLOT_TIMEOUT_MS)
    except Exception:  # noqa: BLE001 - re-raised as an assertion that shows what the page has
        raise AssertionError(f"colour bar {title!r}: expected {what}; the page's colour bars: "
                             f"{colour_bars(page)}") from None
    return colour_bars(page)[title]


def test_oil_fraction_colour_bar_reads_0_to_1_at_two_flows(bearing_page, screenshot):
    lowest, _ = slider_range(bearing_page)
    seen = {}
    for q in (lowest, 1000.0):  # starved (θ down to about 0.4) and over-supplied (θ above about 0.77)
        show_flow(bearing_page, q)
        seen[q] = wait_for_colour_bar(bearing_page, THETA, "(lo, hi) => lo === 0 && hi === 1", "0–1")
        screenshot(bearing_page, f"bearing_fixed_scale_{q:.0f}")
    assert all(r == [0, 1] for r in seen.values()), seen


def test_pressure_colour_bar_is_one_scale_over_the_sweep_and_auto_follows_the_frame(bearing_page):
    lowest, _ = slider_range(bearing_page)
    fixed = {}
    for q in (lowest, 600.0, 1000.0):  # (the harness cannot click the track at its very end)
        show_flow(bearing_page, q)
        fixed[q] = wait_for_colour_bar(bearing_page, PRESSURE, "(lo, hi) => lo === 0 && hi > 0", "0 to a peak")
        # the one scale holds every frame's peak (the summary's, read from the same film solution)
        assert fixed[q][1] >= shown_max_pressure(bearing_page), (q, fixed[q], summary_text(bearing_page))
    assert len({tuple(r) for r in fixed.values()}) == 1, f"the pressure colour bar moved with the flow: {fixed}"

    # "auto": the colour bar spans the frame itself, up to the peak the summary shows (2 decimals there)
    scale = bearing_page.locator(".lubeviz-colour-scale")
    scale.get_by_role("button", name="auto", exact=True).click()
    try:
        peak = shown_max_pressure(bearing_page)
        auto = wait_for_colour_bar(bearing_page, PRESSURE, f"(lo, hi) => Math.abs(hi - {peak}) <= 0.006",
                                   f"its high at the frame's peak {peak} MPa")
        assert auto[1] < fixed[1000.0][1]
        # over-supplied at 1000 ml/min, θ stays above about 0.77: auto stretches that range over the colours
        wait_for_colour_bar(bearing_page, THETA, "(lo, hi) => lo > 0.5 && hi === 1", "the frame's own range")
    finally:
        scale.get_by_role("button", name="fixed", exact=True).click()
    wait_for_colour_bar(bearing_page, PRESSURE, f"(lo, hi) => lo === 0 && hi === {fixed[1000.0][1]}",
                        f"back to the fixed {fixed[1000.0]}")


def test_q_t_is_marked_on_the_slider_and_named_in_the_coefficient_legends(bearing_page):
    from lubeviz.model.machine import load_machine

    # The paper's flooded threshold at the machine's operating speed; the page computes its own Q_T
    paper_qt = load_machine().reference["flooded_threshold_mlmin"]
    pattern = re.compile(r"Q_T = (\d+) ml/min")
    try:
        bearing_page.wait_for_function(
            f"() => ({_LEGEND_LABELS_JS})().filter(l => /^Q_T = \\d+ ml\\/min$/.test(l)).length >= 2",
            timeout=SLOW_MS)
    except Exception:  # noqa: BLE001
        raise AssertionError(f"no Q_T value in two legends; the legends: "
                             f"{bearing_page.evaluate(_LEGEND_LABELS_JS)}") from None
    labels = [m for label in bearing_page.evaluate(_LEGEND_LABELS_JS) if (m := pattern.fullmatch(label))]
    values = {int(m.group(1)) for m in labels}
    assert len(labels) >= 3, labels  # stiffness, damping and the locus's star
    assert len(values) == 1 and abs(values.pop() - paper_qt) <= 5, (labels, paper_qt)

    tick = slider(bearing_page, SLIDER).locator(".noUi-base").evaluate(
        "e => getComputedStyle(e, '::after').content")
    assert pattern.search(tick) and pattern.search(tick).group(1) == labels[0].group(1), tick
    expect(slider(bearing_page, SLIDER).locator(".bk-slider-title")).to_contain_text("Supply flow Q1 (ml/min)")


BLUE, WHITE = "rgb(44, 95, 138)", "rgb(255, 255, 255)"  # bearing_page.CHOSEN_CSS: the chosen one filled blue


def _fill(button) -> tuple[str, str]:
    """(background, text colour) of a toggle button as drawn."""
    return tuple(button.evaluate("b => { const s = getComputedStyle(b); return [s.backgroundColor, s.color]; }"))


def _chosen(button) -> bool:
    return _fill(button) == (BLUE, WHITE)


def test_the_chosen_bearing_and_colour_scale_are_filled_and_the_others_are_not(bearing_page):
    """Issue 38: "the selected bearing and scale toggles are not visibly selected". The chosen button is filled
    blue with white text, the others white with blue text (without !important, Bokeh's own grey button won)."""
    scale = bearing_page.locator(".lubeviz-colour-scale")
    fixed, auto = (scale.get_by_role("button", name=n, exact=True) for n in ("fixed", "auto"))
    assert _chosen(fixed) and _fill(auto) == (WHITE, BLUE), (_fill(fixed), _fill(auto))
    auto.click()
    try:
        expect(auto).to_have_css("background-color", BLUE)
        assert _chosen(auto) and _fill(fixed) == (WHITE, BLUE), (_fill(fixed), _fill(auto))
    finally:
        fixed.click()
    expect(fixed).to_have_css("background-color", BLUE)
    bearings = bearing_page.locator(".lubeviz-bearing-choice").get_by_role("button")
    fills = [_fill(bearings.nth(i)) for i in range(bearings.count())]
    assert fills[0] == (BLUE, WHITE) and all(f == (WHITE, BLUE) for f in fills[1:]), fills  # bearing 1 shown
