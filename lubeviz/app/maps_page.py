"""Maps page: the orbit features over Q1 x Q2 (the paper's Fig. 7), the error functions' root curves
and eps_T (Figs. 9-11), and the identification's search drawn on them, start by start.

Display only: grids, errors and root curves come from `identify.paper.maps`, the search from `identify.paper.newton`.

The simulated record has its own operating point (`MapsPage.record_point`, an `OperatingPoint` like the
session's), not the Rotor page's: the maps teach most where the two bearings differ, one starved and one
over-supplied, while the Rotor page opens at Q_T. So the page opens at 0.8 and 1.2 Q_T, its flows are set by
its own sliders, and a button copies the Rotor page's flows when wanted; nothing changes behind the user's back.
"""

from __future__ import annotations

import math

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..identify.batch import model_speed
from ..identify.paper.maps import domain_axes, feature_grid, identification_map, simulated_measurement
from ..identify.fit.settings import IdentificationSettings
from ..model.machine import Machine
from ..model.operating import OperatingPoint, operating_point
from ..progress import Cancelled
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
from .session import SessionState
from .text import plain
from .widgets import quantity_slider, selector

hv.extension("bokeh", logo=False)

EXPLAIN = """
### How the search finds Q1 and Q2
Each orbit feature (fb and φ at two measurement planes) is a smooth surface over the two supply flows
(the four maps below; fb on a log colour scale). A measurement fixes one value of each: the flows must
lie on the contour of that value, its **root curve** (the zero line of its error function, Eq. 11).
Where the four root curves cross is the answer. The background is **ε_T = Σ|ε|**, the paper's total
error; the lines are the root curves; the paths are the Newton searches from the 3 × 3 starts
(triangles at 0.7, 1 and 1.3 Q_T; the dashed lines are Q_T), in the order they were tried until one
converged (**paper mode**), or the fit of **best mode**. Above Q_T the fb curves run nearly parallel,
which is why the paper's search oscillates there (its Fig. 9); outside the bearings φ has closed
contours, so an answer may not be unique (Fig. 10): best mode then says so.

The simulated record has its own flows (left), 0.8 and 1.2 Q_T to begin with: one bearing starved, the
other over-supplied. "Take the Rotor page's flows" copies the flows set there.
"""

PLANES = {"bearing centres": "center", "outside the bearings": "outside"}
SIMULATED_FRACTIONS = (0.8, 1.2)  # the simulated record's default flows, fractions of Q_T: starved / over-supplied
FEATURES = (("fb1", "fb1 (–)", "viridis"), ("fb2", "fb2 (–)", "viridis"),  # name, colour bar label, colour map
            ("phi1", "φ1 (deg)", "plasma"), ("phi2", "φ2 (deg)", "plasma"))
SYMBOLS = {"fb1": "fb1", "fb2": "fb2", "phi1": "φ1", "phi2": "φ2"}
ROOT_COLORS = {"fb1": "#e41a1c", "fb2": "#377eb8", "phi1": "#ff7f00", "phi2": "#4daf4a"}
# Drawn over the grey ε_T map in light and dark themes alike: mid-luminance colours (contrast >= 2.5 against
# both ends of ERROR_GREYS), never black or white, none a root curve's colour.
PATH_COLORS = ["#7570b3", "#b15928", "#00897b", "#a6761d", "#9467bd", "#cc4c02", "#5a7d2a", "#a05195",
               "#3f7fbf"]
THRESHOLD_COLOR = "#e7298a"  # the Q_T lines and the 3 x 3 starts (fractions of Q_T)
ERROR_GREYS = [f"#{v:02x}{v:02x}{v:02x}" for v in np.linspace(0x30, 0xd8, 256).round().astype(int)]


# Whose features the maps compare with: a record this page simulates, or the session's one record (loaded on the
# Identify or the Diagnose page; issue 38: "Maps names it"). A page opens on the session's record when it has one.
SOURCES = {"a record simulated at the flows set here": "simulated",
           "the session's record (loaded on Identify or Diagnose)": "uploaded"}
NO_RECORD = ("no record in this session yet: load one on the Identify or the Diagnose page (a file, or a sample), "
             "and it is drawn here")


class RecordSourceWatch:
    """What both Maps pages do when their record changes: recompute when it is the source shown; a new record
    of the session becomes the source. While the page is not on screen (`on_screen`, set by the dashboard's shell)
    a change of the session's record or identification only marks the maps stale: they are recomputed when the page
    is shown again (`_catch_up`, from `start`), not beside the Identify page's identification."""

    on_screen = True  # the shell sets it on every tab change; a page built outside a dashboard is always shown
    _stale = False

    async def _catch_up(self) -> bool:
        """Recompute maps left stale while the page was hidden; whether it did."""
        if not (self._ready and self._stale):
            return False
        self._stale = False
        await self._recompute()
        return True

    def _watch_record(self):
        """Call in `__init__` once `state` is set, before the page's controls are built."""
        if self.state.record is not None:
            self.source = "uploaded"
        self.state.param.watch(self._on_new_record, "record")

    def _on_new_record(self, event):
        if event.new is None or self.source == "uploaded":
            return
        if self.on_screen:
            self.source = "uploaded"  # the page's own watcher on `source` recomputes
            return
        with param.parameterized.discard_events(self):
            self.source = "uploaded"
        self._stale = True

    def _record_line(self, r) -> str:
        """The summary's first line: which record the maps are of."""
        if r.get("source") != "uploaded":
            return "Record: simulated here at the flows below."
        where = self.state.loaded_on
        name = r.get("record_name") or "the session's record"
        return f"Record: **{plain(name)}**" + (
            f" (loaded on the {where} page)" if where else "")

    async def _on_flows(self, *events):
        if self._ready and self.source == "simulated":
            await self._recompute()

    async def _on_upload(self, event):
        if self._ready and self.source == "uploaded":
            if not self.on_screen:
                self._stale = True
                return
            await self._recompute()


class MapsPage(RecordSourceWatch, pn.viewable.Viewer):
    """The Maps page of one session."""

    planes = param.Selector(default="center", objects=PLANES, label="Measurement planes",
                            doc="Measurement planes of the maps")
    source = param.Selector(default="simulated", objects=SOURCES,
        label="Source", doc="Whose measured features define the error functions")
    grid_points = param.Integer(81, bounds=(21, 201), label="Grid points", doc="Grid points along each flow axis")
    starts_shown = param.Integer(9, bounds=(1, 9), label="Searches shown",
                                 doc="Searches drawn (in the order they were tried)")
    snr_db = param.Number(12.0, bounds=(0.0, 60.0), label="SNR (dB)", doc="Noise of the simulated record (dB)")

    def __init__(self, machine: Machine, operating: OperatingPoint, state: SessionState, **params):
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.state = state
        self._watch_record()
        self.settings = IdentificationSettings.paper(name="maps identification")
        # The simulated record's operating point: the session's speed, this page's own flows (set in `start`,
        # once Q_T is known from the model).
        self.record_point = operating_point(machine, speed=operating.speed, flows=operating.flows,
                                            name="simulated record")
        if not machine.outside_nodes:  # a machine whose file names no planes outside the bearings
            self.param.planes.objects = {k: v for k, v in PLANES.items() if v == "center"}
        self.jobs = JobPanel()
        self._result = None
        self._flow_sliders = pn.Column(sizing_mode="stretch_width")
        self._take_rotor_flows = pn.widgets.Button(name="Take the Rotor page's flows", button_type="default",
                                                   css_classes=["lubeviz-maps-take-flows"])
        self._take_rotor_flows.on_click(self._on_take_rotor_flows)
        # The four feature maps in a wrapping row: two a row in a wide window, one in a narrow one.
        self._feature_panes = [pn.pane.HoloViews(None, linked_axes=False) for _ in FEATURES]
        self._features = pn.FlexBox(*self._feature_panes, flex_wrap="wrap", css_classes=["lubeviz-feature-maps"])
        self._errors = pn.pane.HoloViews(None, sizing_mode="stretch_width", min_width=420,
                                         styles={"flex": "1 1 420px"}, linked_axes=False,
                                         css_classes=["lubeviz-error-map"])
        self._summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-maps-summary"])
        self._error = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width")
        self._starting = self._ready = False
        self._slider_range: list = []
        self._layout = self._build()
        self.param.watch(self._recompute, ["planes", "source", "grid_points", "snr_db"])
        self.settings.param.watch(self._recompute, ["mode", "phi_scale"])
        self.param.watch(self._redraw, ["starts_shown"])
        self.record_point.param.watch(self._on_flows, ["q1", "q2", "speed"])
        self.op.param.watch(lambda e: setattr(self.record_point, "speed", e.new), "speed")
        # a new record (its identification reset to None, which may already be None) or a new identification
        self.state.param.watch(self._on_upload, ["measured", "identification"])

    def _build(self):
        widgets = pn.Param(self.param, parameters=["planes", "source", "grid_points", "starts_shown"],
                           show_name=False, widgets={"starts_shown": pn.widgets.IntSlider,
                                                     "grid_points": pn.widgets.IntSlider})
        mode = selector(self.settings, "mode", widgets={"mode": {"type": pn.widgets.Select, "name": "Search mode"}})
        # what only the simulated record has: shown only when it is the source
        simulated = pn.Column("#### The simulated record", self._flow_sliders, self._take_rotor_flows,
                              pn.Param(self.param, parameters=["snr_db"], show_name=False),
                              sizing_mode="stretch_width", visible=self.source == "simulated",
                              css_classes=["lubeviz-maps-simulated"])
        self.param.watch(lambda e: setattr(simulated, "visible", e.new == "simulated"), "source")
        controls = pn.Column("### Maps", widgets, mode, simulated, self._summary, self.jobs, width=330)
        return pn.Column(self._error,
                         pn.FlexBox(controls, self._errors, flex_wrap="wrap"),  # the map below the controls when narrow
                         self._features,
                         pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
                         sizing_mode="stretch_width")

    def __panel__(self):
        return self._layout

    def _nodes(self):
        return tuple(self.machine.center_nodes if self.planes == "center" else self.machine.outside_nodes)

    async def start(self):
        if self._starting:
            await self._catch_up()
            return
        self._starting = True
        try:
            model = await self.jobs.run(resources.forward_model, self.machine, self.record_point.speed,
                                        self._nodes(), label="forward model")
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._error.object = f"**Maps not computed**: {plain(exc)}"
            self._error.visible = True
            self._starting = False  # tried again when the page is shown again
            return
        self._set_up_flows(model)
        self._ready = True
        await self._recompute()

    def _set_up_flows(self, model):
        """The simulated record's flows: SIMULATED_FRACTIONS of Q_T, on sliders over the search domain in whole
        ml/min."""
        qt = model.q_threshold
        q1_axis, q2_axis = domain_axes(model, 2, self.settings)
        sliders = []
        for k, (name, axis) in enumerate((("q1", q1_axis), ("q2", q2_axis))):
            lo = math.ceil(axis[0] / M3S_PER_MLMIN) * M3S_PER_MLMIN
            hi = math.floor(axis[-1] / M3S_PER_MLMIN) * M3S_PER_MLMIN
            q = round(SIMULATED_FRACTIONS[k] * qt[k] / M3S_PER_MLMIN) * M3S_PER_MLMIN
            with param.parameterized.discard_events(self.record_point):  # the first map is computed by `start`
                setattr(self.record_point, name, q)
            sliders.append(quantity_slider(self.record_point, name, start=lo, end=hi, step=M3S_PER_MLMIN,
                                           label=f"Q{k + 1} (ml/min); Q_T = {qt[k] / M3S_PER_MLMIN:.0f}",
                                           sizing_mode="stretch_width", css_classes=[f"lubeviz-maps-q{k + 1}"]))
        self._flow_sliders.objects = sliders
        self._slider_range = [(s.start * M3S_PER_MLMIN, s.end * M3S_PER_MLMIN) for s in sliders]

    def _on_take_rotor_flows(self, event):
        if not self._slider_range:
            return
        self.record_point.flows = [min(max(q, lo), hi) for q, (lo, hi) in zip(self.op.flows, self._slider_range)]

    def _compute(self, planes_nodes, source, grid_points, snr_db, speed, flows, state, progress):
        m = self.machine
        if source == "uploaded":
            if state.measured is None or state.record is None:
                raise ValueError(NO_RECORD)
            # the model the Identify page built for this record: same speed, same planes
            speed, planes_nodes = model_speed(m, state.record), tuple(state.measured.nodes)
        model = resources.forward_model(m, speed, planes_nodes, progress=progress)
        axes = domain_axes(model, grid_points, self.settings)
        key = ("feature-grid", m.source, round(speed, 9), planes_nodes, grid_points)
        grid = resources.memo_get(key)
        if grid is None:
            grid = feature_grid(model, *axes)
            resources.memo_put(key, grid)
        page = None  # the Identify page's answer when this map searches in another mode: shown, labelled
        if source == "uploaded":
            measured, q_ref = state.measured, None
            same = state.settings is not None and state.settings.mode == self.settings.mode
            ident = state.identification if same else None
            if not same and state.identification is not None and state.settings is not None:
                page = (state.settings.mode, state.identification)
        else:
            progress(0, 1, "simulating the record (direct film solves)")
            measured = simulated_measurement(m, model, flows, snr_db=snr_db, rng=np.random.default_rng(2024))
            q_ref, ident = np.array(flows), None
        result = identification_map(model, measured, self.settings, axes, identification=ident)
        result.update(grid=grid, q_ref=q_ref, model_nodes=planes_nodes, page_identification=page,
                      mode=self.settings.mode, source=source, record_name=state.record_name)
        return result

    async def _recompute(self, *events):
        if not self._ready:
            return
        self._stale = False  # computed now, with the record and settings of now
        try:
            self._result = await self.jobs.run(
                self._compute, self._nodes(), self.source, self.grid_points, self.snr_db, self.record_point.speed,
                (self.record_point.q1, self.record_point.q2), self.state, label="maps and identification")
        except Cancelled:
            return
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._failed(exc)
            return
        self._error.visible = False
        self.param.starts_shown.bounds = (1, max(1, len(self._result["paths"])))
        self.starts_shown = len(self._result["paths"])
        self._redraw()

    def _failed(self, exc):
        """The error, and no plot of an earlier record or setting under it (issue 38)."""
        self._result = None
        self._errors.object = None
        for pane in self._feature_panes:
            pane.object = None
        self._summary.object = ""
        self._error.object = f"**Maps not computed**: {plain(exc)}"
        self._error.visible = True

    def _redraw(self, *events):
        r = self._result
        if r is None:
            return
        self._errors.object = self._error_plot(r)
        for pane, plot in zip(self._feature_panes, self._feature_plots(r)):
            pane.object = plot
        self._summary.object = self._summary_text(r)

    # --- plots -------------------------------------------------------------------------------------------
    def _error_plot(self, r):
        q1, q2 = r["q1"] / M3S_PER_MLMIN, r["q2"] / M3S_PER_MLMIN
        kd = ["Q1 (ml/min)", "Q2 (ml/min)"]
        total = np.log10(np.maximum(r["eps_total"], 1e-6))
        img = hv.Image((q1, q2, total), kd, "log10 ε_T").opts(cmap=ERROR_GREYS, colorbar=True, clabel="log10 ε_T")
        layers = [img]
        for name, curves in r["roots"].items():
            paths = [c / M3S_PER_MLMIN for c in curves]
            # hv.Path has no legend entry in bokeh; the root curves are drawn as Contours, which do.
            layers.append(hv.Contours(paths, kd, label=f"ε_{SYMBOLS.get(name, name)} = 0").opts(
                color=ROOT_COLORS.get(name, "cyan"), line_width=2, show_legend=True))
        for k, qt in enumerate(r["q_threshold"] / M3S_PER_MLMIN):
            layers.append((hv.VLine(qt) if k == 0 else hv.HLine(qt)).opts(color=THRESHOLD_COLOR, line_dash="dashed",
                                                                          line_width=1.5))
        layers.append(hv.Points([tuple(q) for q in r["start_grid"] / M3S_PER_MLMIN], kd, label="3 × 3 starts").opts(
            marker="triangle", size=11, fill_alpha=0.0, line_color=THRESHOLD_COLOR, line_width=2))
        for k, p in enumerate(r["paths"][: self.starts_shown]):
            p = np.asarray(p) / M3S_PER_MLMIN
            c = PATH_COLORS[k % len(PATH_COLORS)]
            layers.append(hv.Curve((p[:, 0], p[:, 1]), *kd, label=f"search {k + 1}").opts(
                color=c, line_width=1.5, line_dash="dotted"))
            layers.append(hv.Scatter((p[:, 0], p[:, 1]), *kd).opts(color=c, size=5))
            layers.append(hv.Points([tuple(p[0])], kd).opts(color=c, marker="triangle", size=11))
        layers.append(hv.Points([tuple(r["q_identified"] / M3S_PER_MLMIN)], kd,
                                label=f"identified ({r['mode']} mode)").opts(
            color="yellow", marker="circle", size=13, line_color="black"))
        if r.get("page_identification") is not None:
            mode, ident = r["page_identification"]
            layers.append(hv.Points([tuple(ident.q / M3S_PER_MLMIN)], kd,
                                    label=f"Identify page ({mode} mode)").opts(
                color="deepskyblue", marker="diamond", size=14, line_color="black"))
        if r.get("q_ref") is not None:
            layers.append(hv.Points([tuple(r["q_ref"] / M3S_PER_MLMIN)], kd, label="true flows").opts(
                color="red", marker="x", size=14, line_width=3))
        nodes = r["model_nodes"]
        return hv.Overlay(layers).opts(
            title=f"ε_T and the root curves, nodes {', '.join(str(n) for n in nodes)} ({self.settings.mode} mode search)",
            responsive=True, min_height=520, legend_position="right", xlim=(q1[0], q1[-1]), ylim=(q2[0], q2[-1]))

    def _feature_plots(self, r) -> list:
        """The four feature maps, in the order of FEATURES (each about 490 px wide with its colour bar)."""
        grid = r["grid"]
        q1, q2 = grid.q1 / M3S_PER_MLMIN, grid.q2 / M3S_PER_MLMIN
        kd = ["Q1 (ml/min)", "Q2 (ml/min)"]
        plots = []
        for name, label, cmap in FEATURES:
            v = grid[name]
            fb = not name.startswith("phi")
            if not fb:
                v = np.degrees(v)
            # fb spans decades over the domain (flooded vs starved): a log colour scale shows both ends
            img = hv.Image((q1, q2, v), kd, label).opts(cmap=cmap, colorbar=True, clabel=label, tools=["hover"],
                                                        logz=fb)
            pt = r.get("q_ref")
            marks = hv.Points([] if pt is None else [tuple(pt / M3S_PER_MLMIN)], kd).opts(
                color="red", marker="x", size=12, line_width=3)
            plots.append((img * marks).opts(title=f"{SYMBOLS[name]} over Q1 × Q2 (Fig. 7)", frame_width=330,
                                            frame_height=250))
        return plots

    def _summary_text(self, r) -> str:
        qi = r["q_identified"] / M3S_PER_MLMIN
        lines = [self._record_line(r), f"#### Identified ({r['mode']} mode): Q1 = {qi[0]:.1f}, Q2 = {qi[1]:.1f} ml/min",
                 f"{'converged' if r['converged'] else '**not converged**'}; {r['iterations']} iterations, "
                 f"{r['starts_tried']} start(s) tried"]
        if r.get("q_ref") is not None:
            qr = r["q_ref"] / M3S_PER_MLMIN
            err = 100 * (qi - qr) / qr
            lines.append(f"True flows {qr[0]:.1f} / {qr[1]:.1f} ml/min: errors {err[0]:+.2f} % / {err[1]:+.2f} %")
        qt = r["q_threshold"] / M3S_PER_MLMIN
        lines.append(f"Q_T = {qt[0]:.0f} ml/min (bearing 1), {qt[1]:.0f} ml/min (bearing 2)")
        ident = r.get("identification")
        if ident is not None and ident.q_std is not None:
            s = ident.q_std / M3S_PER_MLMIN
            lines.append(f"1σ uncertainty: ±{s[0]:.1f} / ±{s[1]:.1f} ml/min")
        if ident is not None and not ident.unique:
            lines.append("**Not unique**: another pair of flows fits as well (closed φ contours).")
        if r.get("page_identification") is not None:
            mode, ident = r["page_identification"]
            qp = ident.q / M3S_PER_MLMIN
            lines.append(f"**Same record, another search**: the Identify page's answer ({mode} mode) is "
                         f"Q1 = {qp[0]:.1f}, Q2 = {qp[1]:.1f} ml/min (the diamond); this map draws the {r['mode']} "
                         f"mode's search. Choose {mode} mode here to draw that search.")
        lines.append(f"_{r['message']}_")
        return "\n\n".join(lines)

