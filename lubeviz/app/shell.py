"""The dashboard shell: one template, one tab per page, one set of model objects per browser session.

Each session gets its own `OperatingPoint` and `IdentificationSettings` (so two sessions never share
state by accident) and shares only deterministic results through `resources`. A page's expensive work
starts when the page is first shown (tabs render lazily), so the start page appears at once.

The start page is static: what lubeviz does, two pictures (the machine, a bearing cut across the shaft),
what each page is for with a button that opens it, where to start, and the glossary. The glossary is also
one click away from every page (the header's Glossary button opens it in the template's dialog).
"""

from __future__ import annotations

import asyncio
import html
import importlib
import threading
from pathlib import Path

import panel as pn

from ..model.operating import operating_point
from . import resources
from .glossary import GLOSSARY
from .jobs import JobPanel
from .machine_view import MachineChooser
from .session import SessionState
from .text import plain

ASSETS = Path(__file__).resolve().parents[2] / "assets"
# The start page's pictures (assets/, drawn for it): file, kind (its CSS class), caption.
PICTURES = (
    ("machine.svg", "machine",
     "The paper's machine, the example the dashboard opens on (the machine chosen above is drawn from its file "
     "there), drawn to scale: a stepped shaft with three discs (the unbalance on the middle one) on "
     "two grooved oil-film bearings, each fed its own supply flow (Q1, Q2); an X and a Y probe measure the "
     "shaft's vibration in each of two planes."),
    ("bearing_section.svg", "bearing",
     "One bearing cut across the shaft. Oil enters the axial groove at the top; the turning journal drags it "
     "into the narrowing gap, where the full film carries the load; after the minimum film the gap widens and "
     "the film breaks into streamers (cavitation). With less oil (starved) the full film shrinks and the "
     "journal sinks."),
)

INTRO = """
## lubeviz
How well is each hydrodynamic bearing of a machine lubricated? lubeviz answers from the shaft's
vibration alone: a mass-conserving film model whose oil **supply flow** is an input, a finite-element
rotor, the **full spectrum** of the shaft's orbit (forward and backward whirl: {fb}, {phi}), and a search
for the supply flows Q1, Q2, … of its bearings that make the model's orbit features match the measured ones (Oliveira,
Cunha & Daniel; see the README). A bearing fed less than {q_t} is {starved}.
"""

PAGE_PURPOSES = {
    "Bearing": "The oil film of one bearing as its supply goes from starved to flooded: pressure and oil "
               "fraction θ, the journal's position (ε), the 8 stiffness and damping coefficients.",
    "Rotor": "The machine, its orbits, signals and full spectra (fb, φ), modes and Campbell diagram; switch an "
             "effect on (hotter oil, a worn bearing, a probe turned …) and watch them move.",
    "Maps": "How the orbit features depend on Q1 and Q2 (the paper's Figs. 7, 9–11), and the identification's "
            "search on them.",
    "Identify": "Upload a measured record (or load the sample) and get the flows, their 95 % intervals and a "
                "verdict: starved, normal or over-supplied.",
    "Diagnose": "When the model does not explain a record (small p), find the effect it lacks, identify the flows "
                "again with it, and download a report for the work order.",
}

WHERE_TO_START = """
**Where to start.** A student: open **Bearing** and drag the supply flow below Q_T, then switch an effect
on in **Rotor**. An engineer with a record: open **Identify**, upload it (or load the sample) and press
*Identify*; if the model does not explain it, **Diagnose** it. A researcher: **Maps**
shows the paper's Figs. 7 and 9–11 for any flows; `lubeviz reproduce` and `lubeviz figures` regenerate its
tables and figures. Everything shown here is also a Python API and a command (`lubeviz --help`).
"""

# The start page's own styles (its panes render in shadow roots, so each pane carries what it uses).
_FIGURE_CSS = """
.lubeviz-figures { display: flex; flex-wrap: wrap; gap: 16px; }
.lubeviz-figures figure { margin: 0; min-width: 0; }
.lubeviz-figures figure.machine { flex: 7 1 520px; }
.lubeviz-figures figure.bearing { flex: 4 1 340px; max-width: 640px; }
.lubeviz-figures svg { display: block; width: 100%; height: auto; }
.lubeviz-figures figcaption { font-size: 0.9em; margin-top: 4px; opacity: 0.85; }
"""
# The header holds the title, the Glossary button, the theme switch and the busy indicator on one line: on a
# narrow window the title's letters get smaller so that it is read whole at 800 px, and below that it gives
# way (ellipsis) instead of pushing the others past its right edge.
_HEADER_CSS = """
#header .title { min-width: 0; overflow: hidden; text-overflow: ellipsis; white-space: nowrap; flex: 0 1 auto; }
#header-items { width: auto; flex: 1 0 auto; }
@media (max-width: 1100px) { #header .title { font-size: 1.2em; } }
"""
_GLOSSARY_CSS = """
dl.lubeviz-glossary { margin: 0; }
dl.lubeviz-glossary dt { font-weight: bold; margin-top: 0.6em; }
dl.lubeviz-glossary dd { margin: 0.1em 0 0 1.2em; }
"""


def _term(start: str) -> str:
    """The glossary's key that starts with `start` (a KeyError names the missing word)."""
    for key in GLOSSARY:
        if key.startswith(start):
            return key
    raise KeyError(f"no glossary term starts with {start!r}; the terms: {list(GLOSSARY)}")


def _abbr(shown: str, start: str) -> str:
    """`shown` with the glossary's explanation of the term starting with `start` as its tooltip."""
    return f'<abbr title="{html.escape(GLOSSARY[_term(start)], quote=True)}">{html.escape(shown)}</abbr>'


def glossary_html() -> str:
    """The glossary as an HTML definition list."""
    items = "".join(f"<dt>{html.escape(term)}</dt><dd>{html.escape(text)}</dd>" for term, text in GLOSSARY.items())
    return f'<dl class="lubeviz-glossary">{items}</dl>'


def _svg(name: str) -> str:
    """An SVG picture of `assets/`, inlined (the app works offline; no file is served)."""
    text = (ASSETS / name).read_text(encoding="utf-8")
    return text[text.index("<svg"):]  # from the <svg> element on (no XML declaration inside HTML)


def start_page(tabs: pn.Tabs, chooser: MachineChooser | None = None) -> pn.Column:
    """The start page. Its "Open NAME" buttons switch `tabs` to that page's tab in the browser itself: the switch
    does not wait for the server, which may be busy building a page opened before (tens of seconds on a loaded
    2-core machine); the server sees the new active tab when it is free and builds the page then."""
    intro = pn.pane.Markdown(INTRO.format(fb=_abbr("fb", "fb"), phi=_abbr("φ", "φ"), q_t=_abbr("Q_T", "Q_T"),
                                          starved=_abbr("starved", "starved")), sizing_mode="stretch_width")
    figures = pn.pane.HTML(
        '<div class="lubeviz-figures">' + "".join(
            f'<figure class="{kind}">{_svg(name)}<figcaption>{html.escape(caption)}</figcaption></figure>'
            for name, kind, caption in PICTURES) + "</div>",
        sizing_mode="stretch_width", stylesheets=[_FIGURE_CSS], css_classes=["lubeviz-start-figures"])
    rows = []
    for name, purpose in PAGE_PURPOSES.items():
        button = pn.widgets.Button(name=f"Open {name}", button_type="primary", width=140, description=purpose,
                                   css_classes=[f"lubeviz-open-{name.lower()}"])
        button.js_on_click(args={"tabs": tabs}, code=f"tabs.active = {1 + list(PAGES).index(name)}")
        rows.append(pn.Row(button, pn.pane.Markdown(f"**{name}**: {purpose}", sizing_mode="stretch_width",
                                                    margin=(0, 10)), sizing_mode="stretch_width"))
    glossary = pn.pane.HTML(glossary_html(), sizing_mode="stretch_width", stylesheets=[_GLOSSARY_CSS],
                            css_classes=["lubeviz-start-glossary"])
    machine = [chooser.panel()] if chooser is not None else []
    return pn.Column(intro, *machine, figures,
                     pn.pane.Markdown("### What each page is for", sizing_mode="stretch_width"),
                     *rows, pn.pane.Markdown(WHERE_TO_START, sizing_mode="stretch_width"),
                     pn.pane.Markdown("### Glossary", sizing_mode="stretch_width"), glossary,
                     sizing_mode="stretch_width", css_classes=["lubeviz-start"])


# A page's module (holoviews, its plots) is imported when the page is first opened, not before the start page
# is shown: that import took about 2 s of the first session's start page on our 2-core machines.
def _bearing(m, op, state):
    from .bearing_page import BearingPage
    return BearingPage(m, op)


def _rotor(m, op, state):
    from .rotor_page import RotorPage
    return RotorPage(m, op)


def _maps(m, op, state):
    if len(m.bearings) == 2:  # the paper's maps: its error functions and Newton search over Q1 x Q2
        from .maps_page import MapsPage
        return MapsPage(m, op, state)
    from .pair_maps_page import PairMapsPage  # any pair of flows, the others held at their identified ones
    return PairMapsPage(m, op, state)


def _identify(m, op, state):
    from .identify_page import IdentifyPage
    return IdentifyPage(m, state)


def _diagnose(m, op, state):
    from .diagnose_page import DiagnosePage
    return DiagnosePage(m, state)


_PRELOAD_LOCK = threading.Lock()
_PRELOADING: list[threading.Thread] = []


def _preload(machine, op) -> None:
    """Import the numerics and the Bearing page's module (HoloViews, Bokeh models) and start solving the films
    it draws first, so a click on its tab finds them ready instead of paying about 2 s of imports. The other
    pages' modules follow. Module imports and the shared deterministic caches only: no session state."""
    try:
        resources.import_numerics()
        films = resources.first_films(machine, 0, op.speed, op.flows[0])
        from . import bearing_page  # noqa: F401
        films.exception()  # waits: the other pages' imports would slow the films of a Bearing page opened now
        _draw_once(machine, op)
        from . import rotor_page, maps_page, identify_page, diagnose_page  # noqa: F401
    except Exception:  # noqa: BLE001 - a failed preload only loses the head start: the page imports it again
        pass


def _draw_once(machine, op) -> None:
    """Draw a throwaway Bearing page into a throwaway Bokeh document (no session sees it): the first drawing of
    HoloViews plots imports what they use lazily (pandas, pyarrow, colorcet, markdown …), 0.4 s of the 0.67 s
    the first visit's page took to draw on the server, against 0.27 s for a later one."""
    from bokeh.document import Document

    from .bearing_page import BearingPage

    page = BearingPage(machine, operating_point(machine, speed=op.speed, flows=op.flows, name="warm-up"))
    page.__panel__().get_root(Document())


def preload(machine, op) -> None:
    """Run `_preload` once per server process, in the first session's build: with `panel serve --warm` that is
    the warm-up run, before the server takes its first visitor, so the first visit finds the pages imported
    and the first films solved. Later sessions skip it (a daemon thread, so a failure or a hang cannot hold
    the server: the wait is bounded)."""
    with _PRELOAD_LOCK:
        if _PRELOADING:
            return
        thread = threading.Thread(target=_preload, args=(machine, op), name="lubeviz-preload", daemon=True)
        _PRELOADING.append(thread)
        thread.start()
    thread.join(timeout=PRELOAD_WAIT_S)


PRELOAD_WAIT_S = 30.0


PAGES = {"Bearing": _bearing, "Rotor": _rotor, "Maps": _maps, "Identify": _identify, "Diagnose": _diagnose}
PAGE_MODULES = {name: f"{__package__}.{name.lower()}_page" for name in PAGES}  # pair_maps_page: imported by _maps


def _offline() -> None:
    """Panel's Fast design without its web font: it asked fonts.googleapis.com for Open Sans on every page load, and
    a plant's network is often closed (issue 38). Every file a page asks for now comes from this server; the text is
    set in Open Sans where the system has it, else in its sans-serif (as it was wherever the font could not be
    fetched). The design's class is changed, not an instance: a template makes its design anew as a page is served,
    and a subclass would lose the design's own scripts, which Panel finds by the class's name."""
    from panel.theme.fast import Fast

    if "font" in Fast._resources:
        Fast._resources = {k: v for k, v in Fast._resources.items() if k != "font"}
    _stylesheets_from_this_server()


def _stylesheets_from_this_server() -> None:
    """Panel's own style sheets (loading.css, markdown.css, the design's theme) from this server, never its CDN.

    Panel rewrites a component's style sheet to the document's `dist_url` (this server's static files), but falls
    back to cdn.holoviz.org where the model has no document yet: a design applied to a pane built during an
    update (the Rotor page's first draw). The style sheet objects are shared by every component of a document, so
    that one rewrite sent the whole page's loading.css to the CDN: offline, each failed to load (issue 38, found in
    session 53: no DOM link named the CDN before the Rotor page, 16 after it). Served by `panel serve`, this app never
    wants the CDN: a rewrite to it goes to this server's copy instead."""
    import panel.io.resources as resources
    import panel.reactive as reactive

    if getattr(resources.patch_stylesheet, "lubeviz_local", False):
        return
    original = resources.patch_stylesheet

    def local(stylesheet, dist_url):
        if dist_url == resources.CDN_DIST and not resources.use_cdn():
            doc = pn.state.curdoc
            dist_url = (doc._template_variables.get("dist_url") if doc is not None else None) or \
                resources.get_dist_path()
        return original(stylesheet, dist_url)

    local.lubeviz_local = True
    resources.patch_stylesheet = local
    reactive.patch_stylesheet = local


def build() -> pn.template.FastListTemplate:
    """The dashboard of one session. Pages are built when first opened, so the start page comes up at once.
    The session works on one machine at a time (the start page's chooser): choosing another builds every page
    afresh for it, with its own operating point (one flow per fluid-film bearing) and session state."""
    pn.extension("filedropper", notifications=True)  # JS of lazily built pages, loaded up front
    first = resources.machine()
    work = {"machine": first, "op": operating_point(first),
            "state": SessionState(name="session")}
    names = list(PAGES)
    pages: dict[str, object] = {}

    def spinner():
        return pn.Column(pn.indicators.LoadingSpinner(value=True, size=40), sizing_mode="stretch_width")

    tabs = pn.Tabs(("Start", pn.Column()), *[(name, spinner()) for name in names],
                   dynamic=True, sizing_mode="stretch_width", css_classes=["lubeviz-pages"])
    building: dict[str, asyncio.Future] = {}

    def watch_state(state: SessionState) -> SessionState:
        # a page asks for another ("Diagnose this record"): its tab is shown, and built and started by `show`
        state.param.watch(lambda e: e.new in names and setattr(tabs, "active", 1 + names.index(e.new)), "open_page")
        return state

    def use_machine(machine) -> None:
        cancel_jobs()
        pages.clear()
        building.clear()
        work.update(machine=machine, op=operating_point(machine),
                    state=watch_state(SessionState(name="session")))
        for i, name in enumerate(names, start=1):
            tabs[i] = (name, spinner())
        template.lubeviz_machine = machine

    chooser = MachineChooser(first, use_machine)
    tabs[0] = ("Start", start_page(tabs, chooser))  # its buttons switch the tabs in the browser; the watcher builds

    def build_page(name: str, index: int):
        if name not in pages:
            pages[name] = PAGES[name](work["machine"], work["op"], work["state"])
            tabs[index] = (name, pages[name])
        if hasattr(pages[name], "start") and tabs.active == index:  # else started when the tab is next shown
            asyncio.ensure_future(pages[name].start())

    async def import_then_build(name: str, index: int):
        # The page's module (HoloViews, its plots, the numerics it calls: 3 s, and 30 s and more on a loaded
        # 2-core machine) is imported on a thread, so the tab switches at once with its spinner and the
        # server's other sessions are not held meanwhile; the page is then built on the event loop.
        try:
            await asyncio.to_thread(importlib.import_module, PAGE_MODULES[name])
            build_page(name, index)
        except Exception as exc:  # noqa: BLE001 - shown in the tab; the other pages keep serving
            tabs[index] = (name, pn.pane.Alert(f"The {name} page could not be built: {plain(exc)}", alert_type="danger",
                                               sizing_mode="stretch_width"))

    def show(index: int):
        # each built page is told whether it is the one on screen: a hidden page defers its work (the Maps page does
        # not recompute for a record loaded elsewhere until it is shown)
        for built, page in pages.items():
            if hasattr(page, "on_screen"):
                page.on_screen = 1 <= index <= len(names) and built == names[index - 1]
        if not 1 <= index <= len(names):
            return  # the start page is static
        name = names[index - 1]
        if name in pages:
            build_page(name, index)
            return
        try:
            asyncio.get_running_loop()
        except RuntimeError:  # a script or a test without a server: build at once
            build_page(name, index)
            return
        if name not in building or building[name].done():  # done here: it failed, try again
            building[name] = asyncio.ensure_future(import_then_build(name, index))

    def cancel_jobs():
        # A closed browser tab (or another machine) stops its pages' jobs at their next step (work already in a
        # worker process finishes, and its result, shared with other sessions, is kept).
        for page in pages.values():
            for jobs in vars(page).values():
                if isinstance(jobs, JobPanel):
                    jobs.cancel()

    def closed(session_context):
        cancel_jobs()

    tabs.param.watch(lambda e: show(e.new), "active")
    watch_state(work["state"])
    pn.state.onload(lambda: show(tabs.active))
    pn.state.on_session_destroyed(closed)
    glossary_button = pn.widgets.Button(name="Glossary", button_type="light", width=100, align="center",
                                        description="What the words and symbols on these pages mean",
                                        css_classes=["lubeviz-glossary-button"])
    _offline()
    template = pn.template.FastListTemplate(
        title="lubeviz — bearing lubrication from shaft vibration", main=[tabs], header=[glossary_button],
        modal=[pn.Column(pn.pane.Markdown("## Glossary"),
                         pn.pane.HTML(glossary_html(), stylesheets=[_GLOSSARY_CSS], sizing_mode="stretch_width"),
                         sizing_mode="stretch_width", css_classes=["lubeviz-glossary-dialog"])],
        accent_base_color="#2c5f8a", header_background="#2c5f8a", raw_css=[_HEADER_CSS])
    glossary_button.on_click(lambda event: template.open_modal())
    template.lubeviz_pages = pages  # for tests and scripts: the pages built so far, by name
    template.lubeviz_machine = first
    template.lubeviz_chooser = chooser
    preload(first, work["op"])
    return template
