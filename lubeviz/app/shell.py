"""The dashboard shell: one template, one tab per page, one set of model objects per browser session.

Each session gets its own `OperatingPoint` and `IdentificationSettings` (so two sessions never share
state by accident) and shares only deterministic results through `resources`. A page's expensive work
starts when the page is first shown (tabs render lazily), so the start page appears at once.
"""

from __future__ import annotations

import asyncio

import panel as pn

from ..model.operating import OperatingPoint
from ..units import M3S_PER_MLMIN
from . import resources
from .bearing_page import BearingPage
from .diagnose_page import DiagnosePage
from .identify_page import IdentifyPage
from .jobs import JobPanel
from .maps_page import MapsPage
from .rotor_page import RotorPage
from .session import SessionState

ABOUT = """
## lubeviz
How well is each hydrodynamic bearing of a machine lubricated? lubeviz answers from the shaft's
vibration alone: a mass-conserving film model whose oil **supply flow** is an input, a finite-element
rotor, the **full spectrum** of the shaft's orbit (forward and backward whirl), and a search for the two
supply flows Q1, Q2 that make the model's orbit features match the measured ones (Oliveira, Cunha &
Daniel; see the README).

* **Bearing**: the oil film of one bearing as its supply goes from starved to flooded.
* **Rotor**: the machine, its orbits, signals and full spectra, modes and Campbell diagram.
* **Maps**: how the orbit features depend on Q1 and Q2, and the identification's search on them.
* **Identify**: upload a measured record and get the flows, their uncertainty and a verdict.
* **Diagnose**: when the model does not explain a record, find the effect it lacks (hotter oil, a worn
  bearing, a probe turned …), identify the flows again with it, and download a report for the work order.

Everything shown here is also a Python API and a command (`lubeviz --help`).

**Where to start.** A student: open **Bearing** and drag the supply flow below Q_T, then switch an effect
on in **Rotor**. An engineer with a record: open **Identify**, upload it (or load the sample) and press
*Identify*; if the model does not explain it, **Diagnose** it. A researcher: **Maps**
shows the paper's Figs. 7 and 9–11 for any flows; `lubeviz reproduce` and `lubeviz figures` regenerate its
tables and figures.
"""


PAGES = {"Bearing": lambda m, op, state: BearingPage(m, op),
         "Rotor": lambda m, op, state: RotorPage(m, op),
         "Maps": lambda m, op, state: MapsPage(m, op, state),
         "Identify": lambda m, state_op, state: IdentifyPage(m, state),
         "Diagnose": lambda m, op, state: DiagnosePage(m, state)}


def build() -> pn.template.FastListTemplate:
    """The dashboard of one session. Pages are built when first opened, so the start page comes up at once."""
    pn.extension("tabulator", "filedropper", notifications=True)  # JS of lazily built pages, loaded up front
    machine = resources.machine()
    q_t = machine.reference.get("flooded_threshold_mlmin", 546.0) * M3S_PER_MLMIN
    op = OperatingPoint(speed=machine.operating_speed, q1=q_t, q2=q_t, name="operating point")
    state = SessionState(name="session")
    names = list(PAGES)
    pages: dict[str, object] = {}
    start = pn.pane.Markdown(ABOUT, sizing_mode="stretch_width", css_classes=["lubeviz-start"])
    tabs = pn.Tabs(("Start", start),
                   *[(name, pn.Column(pn.indicators.LoadingSpinner(value=True, size=40), sizing_mode="stretch_width"))
                     for name in names],
                   dynamic=True, sizing_mode="stretch_width", css_classes=["lubeviz-pages"])

    def show(index: int):
        if not 1 <= index <= len(names):
            return  # the start page is static
        name = names[index - 1]
        if name not in pages:
            pages[name] = PAGES[name](machine, op, state)
            tabs[index] = (name, pages[name])
        if hasattr(pages[name], "start"):
            asyncio.ensure_future(pages[name].start())

    def closed(session_context):
        # A closed browser tab stops its page's jobs at their next step (work already in a worker process
        # finishes, and its result, shared with other sessions, is kept).
        for page in pages.values():
            for jobs in vars(page).values():
                if isinstance(jobs, JobPanel):
                    jobs.cancel()

    tabs.param.watch(lambda e: show(e.new), "active")
    pn.state.onload(lambda: show(tabs.active))
    pn.state.on_session_destroyed(closed)
    template = pn.template.FastListTemplate(
        title="lubeviz — bearing lubrication from shaft vibration", main=[tabs],
        accent_base_color="#2c5f8a", header_background="#2c5f8a")
    template.lubeviz_pages = pages  # for tests and scripts: the pages built so far, by name
    return template
