"""Maps page: the orbit features over Q1 x Q2 (the paper's Fig. 7), the error functions' root curves
and eps_T (Figs. 9-11), and the identification's search drawn on them, start by start.

Display only: grids, errors and root curves come from `identify.maps`, the search from `identify.newton`.
"""

from __future__ import annotations

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..identify.maps import domain_axes, feature_grid, identification_map, simulated_measurement
from ..identify.settings import IdentificationSettings
from ..model.machine import Machine
from ..model.operating import OperatingPoint
from ..progress import Cancelled
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
from .session import SessionState
from .widgets import selector

hv.extension("bokeh", logo=False)

EXPLAIN = """
### How the search finds Q1 and Q2
Each orbit feature (fb and φ at two measurement planes) is a smooth surface over the two supply flows
(top row). A measurement fixes one value of each: the flows must lie on the contour of that value, its
**root curve** (the zero line of its error function, Eq. 11). Where the four root curves cross is the
answer. The background is **ε_T = Σ|ε|**, the paper's total error; the lines are the root curves; the
paths are the Newton searches from the 3 × 3 starts, in the order they were tried (**paper mode**), or
the weighted trust-region search (**best mode**). Above Q_T the fb curves run nearly parallel, which is
why the paper's search oscillates there (its Fig. 9); outside the bearings φ has closed contours, so an
answer may not be unique (Fig. 10): best mode then says so.
"""

PLANES = {"bearing centres": "center", "outside the bearings": "outside"}
ROOT_COLORS = {"fb1": "#e41a1c", "fb2": "#377eb8", "phi1": "#ff7f00", "phi2": "#4daf4a"}
PATH_COLORS = ["#111111", "#6a3d9a", "#b15928", "#1b9e77", "#e7298a", "#66a61e", "#a6761d", "#666666",
               "#e6ab02"]


class MapsPage(pn.viewable.Viewer):
    """The Maps page of one session."""

    planes = param.Selector(default="center", objects=PLANES, doc="Measurement planes of the maps")
    source = param.Selector(default="simulated", objects={
        "a record simulated at the Rotor page's flows": "simulated", "the record of the Identify page": "uploaded"},
        doc="Whose measured features define the error functions")
    grid_points = param.Integer(81, bounds=(21, 201), doc="Grid points along each flow axis")
    starts_shown = param.Integer(9, bounds=(1, 9), doc="Searches drawn (in the order they were tried)")
    snr_db = param.Number(12.0, bounds=(0.0, 60.0), doc="Noise of the simulated record (dB)")

    def __init__(self, machine: Machine, operating: OperatingPoint, state: SessionState, **params):
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.state = state
        self.settings = IdentificationSettings.paper(name="maps identification")
        self.jobs = JobPanel()
        self._result = None
        self._features = pn.pane.HoloViews(None, sizing_mode="stretch_width", linked_axes=False,
                                           css_classes=["lubeviz-feature-maps"])
        self._errors = pn.pane.HoloViews(None, sizing_mode="stretch_width", linked_axes=False,
                                         css_classes=["lubeviz-error-map"])
        self._summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-maps-summary"])
        self._error = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width")
        self._ready = False
        self._layout = self._build()
        self.param.watch(self._recompute, ["planes", "source", "grid_points", "snr_db"])
        self.settings.param.watch(self._recompute, ["mode", "phi_scale"])
        self.param.watch(self._redraw, ["starts_shown"])
        self.op.param.watch(self._on_flows, ["q1", "q2"])
        self.state.param.watch(self._on_upload, ["identification"])

    def _build(self):
        widgets = pn.Param(self.param, parameters=["planes", "source", "grid_points", "snr_db", "starts_shown"],
                           show_name=False, widgets={"starts_shown": pn.widgets.IntSlider,
                                                     "grid_points": pn.widgets.IntSlider})
        controls = pn.Column("### Maps", widgets, selector(self.settings, "mode"), self._summary, self.jobs,
                             width=330)
        return pn.Column(self._error,
                         pn.Row(controls, self._errors, sizing_mode="stretch_width"),
                         self._features,
                         pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
                         sizing_mode="stretch_width")

    def __panel__(self):
        return self._layout

    def _nodes(self):
        return tuple(self.machine.center_nodes if self.planes == "center" else self.machine.outside_nodes)

    async def start(self):
        if not self._ready:
            self._ready = True
            await self._recompute()

    async def _on_flows(self, event):
        if self._ready and self.source == "simulated":
            await self._recompute()

    async def _on_upload(self, event):
        if self._ready and self.source == "uploaded":
            await self._recompute()

    def _compute(self, planes_nodes, source, grid_points, snr_db, flows, state, progress):
        m = self.machine
        speed = self.op.speed
        if source == "uploaded":
            if state.measured is None:
                raise ValueError("no record on the Identify page yet: upload one there (or use the sample)")
            speed, planes_nodes = state.measured.speed_hz, tuple(state.measured.nodes)
        model = resources.forward_model(m, speed, planes_nodes, progress=progress)
        axes = domain_axes(model, grid_points, self.settings)
        key = ("feature-grid", m.source, round(speed, 9), planes_nodes, grid_points)
        grid = resources.memo_get(key)
        if grid is None:
            grid = feature_grid(model, *axes)
            resources.memo_put(key, grid)
        if source == "uploaded":
            measured, q_ref = state.measured, None
            ident = state.identification if state.settings is not None and state.settings.mode == self.settings.mode \
                else None
        else:
            progress(0, 1, "simulating the record (direct film solves)")
            measured = simulated_measurement(m, model, flows, snr_db=snr_db, rng=np.random.default_rng(2024))
            q_ref, ident = np.array(flows), None
        result = identification_map(model, measured, self.settings, axes, identification=ident)
        result.update(grid=grid, q_ref=q_ref, model_nodes=planes_nodes)
        return result

    async def _recompute(self, *events):
        if not self._ready:
            return
        try:
            self._result = await self.jobs.run(
                self._compute, self._nodes(), self.source, self.grid_points, self.snr_db,
                (self.op.q1, self.op.q2), self.state, label="maps and identification")
        except Cancelled:
            return
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._error.object = f"**Maps not computed**: {exc}"
            self._error.visible = True
            return
        self._error.visible = False
        self.param.starts_shown.bounds = (1, max(1, len(self._result["paths"])))
        self.starts_shown = len(self._result["paths"])
        self._redraw()

    def _redraw(self, *events):
        r = self._result
        if r is None:
            return
        self._errors.object = self._error_plot(r)
        self._features.object = self._feature_plots(r)
        self._summary.object = self._summary_text(r)

    # --- plots -------------------------------------------------------------------------------------------
    def _error_plot(self, r):
        q1, q2 = r["q1"] / M3S_PER_MLMIN, r["q2"] / M3S_PER_MLMIN
        kd = ["Q1 (ml/min)", "Q2 (ml/min)"]
        total = np.log10(np.maximum(r["eps_total"], 1e-6))
        img = hv.Image((q1, q2, total), kd, "log10 ε_T").opts(cmap="Greys_r", colorbar=True, clabel="log10 ε_T")
        layers = [img]
        for name, curves in r["roots"].items():
            paths = [c / M3S_PER_MLMIN for c in curves]
            # hv.Path has no legend entry in bokeh; the root curves are drawn as Contours, which do.
            layers.append(hv.Contours(paths, kd, label=f"ε_{name} = 0").opts(
                color=ROOT_COLORS.get(name, "cyan"), line_width=2, show_legend=True))
        for k, p in enumerate(r["paths"][: self.starts_shown]):
            p = np.asarray(p) / M3S_PER_MLMIN
            c = PATH_COLORS[k % len(PATH_COLORS)]
            layers.append(hv.Curve((p[:, 0], p[:, 1]), *kd, label=f"search {k + 1}").opts(
                color=c, line_width=1.5, line_dash="dotted"))
            layers.append(hv.Scatter((p[:, 0], p[:, 1]), *kd).opts(color=c, size=5))
            layers.append(hv.Points([tuple(p[0])], kd).opts(color=c, marker="triangle", size=11))
        for k, qt in enumerate(r["q_threshold"] / M3S_PER_MLMIN):
            layers.append((hv.VLine(qt) if k == 0 else hv.HLine(qt)).opts(color="white", line_dash="dashed",
                                                                          line_width=1))
        layers.append(hv.Points([tuple(r["q_identified"] / M3S_PER_MLMIN)], kd, label="identified").opts(
            color="yellow", marker="circle", size=13, line_color="black"))
        if r.get("q_ref") is not None:
            layers.append(hv.Points([tuple(r["q_ref"] / M3S_PER_MLMIN)], kd, label="true flows").opts(
                color="red", marker="x", size=14, line_width=3))
        nodes = r["model_nodes"]
        return hv.Overlay(layers).opts(
            title=f"ε_T and the root curves, nodes {nodes[0]} and {nodes[1]} ({self.settings.mode} mode search)",
            responsive=True, min_height=520, legend_position="right", xlim=(q1[0], q1[-1]), ylim=(q2[0], q2[-1]))

    def _feature_plots(self, r):
        grid = r["grid"]
        q1, q2 = grid.q1 / M3S_PER_MLMIN, grid.q2 / M3S_PER_MLMIN
        kd = ["Q1 (ml/min)", "Q2 (ml/min)"]
        plots = []
        for name, label, cmap in (("fb1", "fb1 (–)", "viridis"), ("fb2", "fb2 (–)", "viridis"),
                                  ("phi1", "φ1 (deg)", "twilight"), ("phi2", "φ2 (deg)", "twilight")):
            v = grid[name]
            if name.startswith("phi"):
                v = np.degrees(v)
            img = hv.Image((q1, q2, v), kd, label).opts(cmap=cmap, colorbar=True, clabel=label, tools=["hover"])
            pt = r.get("q_ref")
            marks = hv.Points([] if pt is None else [tuple(pt / M3S_PER_MLMIN)], kd).opts(
                color="red", marker="x", size=12, line_width=3)
            plots.append((img * marks).opts(title=f"{name} over Q1 × Q2 (Fig. 7)", frame_width=260,
                                            frame_height=220))
        return hv.Layout(plots).cols(4).opts(shared_axes=False)

    def _summary_text(self, r) -> str:
        qi = r["q_identified"] / M3S_PER_MLMIN
        lines = [f"#### Identified: Q1 = {qi[0]:.1f}, Q2 = {qi[1]:.1f} ml/min",
                 f"{'converged' if r['converged'] else '**not converged**'}; {r['iterations']} iterations, "
                 f"{r['starts_tried']} start(s) tried"]
        if r.get("q_ref") is not None:
            qr = r["q_ref"] / M3S_PER_MLMIN
            err = 100 * (qi - qr) / qr
            lines.append(f"True flows {qr[0]:.1f} / {qr[1]:.1f} ml/min: errors {err[0]:+.2f} % / {err[1]:+.2f} %")
        ident = r.get("identification")
        if ident is not None and ident.q_std is not None:
            s = ident.q_std / M3S_PER_MLMIN
            lines.append(f"1σ uncertainty: ±{s[0]:.1f} / ±{s[1]:.1f} ml/min")
        if ident is not None and not ident.unique:
            lines.append("**Not unique**: another pair of flows fits as well (closed φ contours).")
        lines.append(f"_{r['message']}_")
        return "\n\n".join(lines)

