"""Maps page of a machine whose bearings are not the paper's two: the fit's χ² and the orbit features over any
chosen pair of supply flows, the other bearings held at their identified flows, with the search drawn on them.

Display only: the grid comes from `identify.fit.maps.pair_map`, the identification from `identify.fit.least_squares`
(best mode, the model budget), the simulated record from `signals.synthesize` (direct film solves). The paper's
own maps (its error functions and Newton search over Q1 x Q2) stay on `maps_page` for a two-bearing machine.

As on that page, the simulated record has its own flows (starting at fractions of each bearing's Q_T: one starved,
one over-supplied ...) set by its own sliders, and a button copies the Rotor page's.
"""

from __future__ import annotations

import math

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..identify.batch import fit_features, model_speed
from ..identify.fit.least_squares import fit, flows_text
from ..identify.fit.maps import pair_map
from ..identify.fit.settings import IdentificationSettings
from ..identify.forward.budget import ModelBudget
from ..identify.forward.measured import measure
from ..model.machine import Machine
from ..model.operating import OperatingPoint, operating_point
from ..progress import Cancelled
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
from .maps_page import NO_RECORD, SOURCES, RecordSourceWatch
from .session import SessionState
from .text import plain
from .widgets import quantity_slider

hv.extension("bokeh", logo=False)

EXPLAIN = """
### How the search finds the flows
With more than two bearings the flows span more than a plane, so the page draws a **slice**: two flows
(chosen above) move over 25–200 % of their Q_T while every other bearing is held at its **identified** flow.
The background is the fit's **χ²** (features against the record, in standard deviations of the noise and of
the model's own uncertainty); the white path is the search, projected on the slice; the dashed lines are Q_T.
The feature maps show what each measurement plane sees: fb (log colour scale) and the orbit angle φ. Where the
valley of χ² is long and flat, the two flows trade off against each other and their intervals are wide.

The simulated record has its own flows (left), starting at fractions of each bearing's Q_T. "Take the Rotor
page's flows" copies the flows set there.
"""

SIMULATED_FRACTIONS = (0.8, 1.2, 1.0, 0.9, 1.3, 0.7)  # the simulated record's first flows, fractions of Q_T
THRESHOLD_COLOR = "#e7298a"


class PairMapsPage(RecordSourceWatch, pn.viewable.Viewer):
    """The Maps page of one session, for a machine of any number of fluid-film bearings."""

    x_flow = param.Selector(default=0, objects={"Q1": 0}, label="Horizontal axis", doc="The flow along x")
    y_flow = param.Selector(default=1, objects={"Q2": 1}, label="Vertical axis", doc="The flow along y")
    source = param.Selector(default="simulated", objects=SOURCES,
        label="Source", doc="Whose measured features the χ² compares with")
    grid_points = param.Integer(41, bounds=(21, 101), label="Grid points", doc="Grid points along each flow axis")
    snr_db = param.Number(12.0, bounds=(0.0, 60.0), label="SNR (dB)", doc="Noise of the simulated record (dB)")

    def __init__(self, machine: Machine, operating: OperatingPoint, state: SessionState, **params):
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.state = state
        self._watch_record()
        n = len(machine.bearings)
        if n < 2:
            raise ValueError(f"{machine.name} has {n} oil-film bearing: there is no pair of flows to map")
        names = {f"Q{k + 1} ({b.name or f'bearing {k + 1}'})": k for k, b in enumerate(machine.bearings)}
        self.param.x_flow.objects = names
        self.param.y_flow.objects = names
        self.x_flow, self.y_flow = 0, 1
        self.record_point = operating_point(machine, speed=operating.speed, name="simulated record")
        self.jobs = JobPanel()
        self._result = None
        self._chain = None
        self._flow_sliders = pn.Column(sizing_mode="stretch_width")
        self._take_rotor_flows = pn.widgets.Button(name="Take the Rotor page's flows", button_type="default",
                                                   css_classes=["lubeviz-maps-take-flows"])
        self._take_rotor_flows.on_click(self._on_take_rotor_flows)
        self._chi2 = pn.pane.HoloViews(None, sizing_mode="stretch_width", min_width=420, styles={"flex": "1 1 420px"},
                                       linked_axes=False, css_classes=["lubeviz-error-map"])
        self._features = pn.FlexBox(flex_wrap="wrap", css_classes=["lubeviz-feature-maps"])
        self._summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-maps-summary"])
        self._error = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width")
        self._ready = self._starting = False
        self._layout = self._build()
        self.param.watch(self._recompute, ["x_flow", "y_flow", "source", "grid_points", "snr_db"])
        self.record_point.param.watch(self._on_flows, list(self.record_point.flow_names))
        self.op.param.watch(lambda e: setattr(self.record_point, "speed", e.new), "speed")
        self.state.param.watch(self._on_upload, ["measured", "identification"])

    def _build(self):
        widgets = pn.Param(self.param, parameters=["x_flow", "y_flow", "source", "grid_points"], show_name=False,
                           widgets={"grid_points": pn.widgets.IntSlider,
                                    "x_flow": {"type": pn.widgets.Select, "css_classes": ["lubeviz-maps-x"]},
                                    "y_flow": {"type": pn.widgets.Select, "css_classes": ["lubeviz-maps-y"]}})
        simulated = pn.Column("#### The simulated record", self._flow_sliders, self._take_rotor_flows,
                              pn.Param(self.param, parameters=["snr_db"], show_name=False),
                              sizing_mode="stretch_width", visible=self.source == "simulated",
                              css_classes=["lubeviz-maps-simulated"])
        self.param.watch(lambda e: setattr(simulated, "visible", e.new == "simulated"), "source")
        controls = pn.Column("### Maps over two flows", widgets, simulated, self._summary, self.jobs, width=330)
        return pn.Column(self._error, pn.FlexBox(controls, self._chi2, flex_wrap="wrap"), self._features,
                         pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"), sizing_mode="stretch_width")

    def __panel__(self):
        return self._layout

    def _planes(self):
        planes = self.machine.measurement_planes
        return tuple(p.node for p in planes)

    async def start(self):
        if self._starting:
            await self._catch_up()
            return
        self._starting = True
        try:
            self._chain = await self.jobs.run(resources.chain, self.machine, self.record_point.speed, self._planes(),
                                              label="forward model")
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._error.object = f"**Maps not computed**: {plain(exc)}"
            self._error.visible = True
            self._starting = False
            return
        self._set_up_flows(self._chain)
        self._ready = True
        await self._recompute()

    def _set_up_flows(self, chain):
        qt = chain.q_threshold
        lo, hi = chain.bounds()
        sliders = []
        flows = []
        for k, name in enumerate(self.record_point.flow_names):
            q = round(SIMULATED_FRACTIONS[k % len(SIMULATED_FRACTIONS)] * qt[k] / M3S_PER_MLMIN) * M3S_PER_MLMIN
            flows.append(q)
        with param.parameterized.discard_events(self.record_point):  # the first map is computed by `start`
            self.record_point.flows = flows
        for k, name in enumerate(self.record_point.flow_names):
            sliders.append(quantity_slider(
                self.record_point, name, start=math.ceil(lo[k] / M3S_PER_MLMIN) * M3S_PER_MLMIN,
                end=math.floor(hi[k] / M3S_PER_MLMIN) * M3S_PER_MLMIN, step=M3S_PER_MLMIN,
                label=f"Q{k + 1} (ml/min); Q_T = {qt[k] / M3S_PER_MLMIN:.0f}", sizing_mode="stretch_width",
                css_classes=[f"lubeviz-maps-q{k + 1}"]))
        self._flow_sliders.objects = sliders

    def _on_take_rotor_flows(self, event):
        if self._chain is None:
            return
        lo, hi = self._chain.bounds()
        self.record_point.flows = [min(max(q, a), b) for q, a, b in zip(self.op.flows, lo, hi)]

    def _compute(self, source, pair, points, snr_db, speed, flows, state, progress):
        from ..signals.synthesize import synthesize_record

        m = self.machine
        if source == "uploaded":
            if state.measured is None or state.record is None:
                raise ValueError(NO_RECORD)
            record, measured = state.record, state.measured
            chain = resources.chain(m, model_speed(m, record), tuple(record.nodes), record.probe_angles_deg,
                                    progress=progress)
            q_ref = None
        else:
            progress(0, 1, "simulating the record (direct film solves)")
            record = synthesize_record(m, flows, nodes=self._planes(), snr_db=snr_db, speed_hz=speed,
                                       rng=np.random.default_rng(2024), method="steady", rotor=resources.rotor(m))
            measured = measure(record)
            chain = resources.chain(m, speed, self._planes(), progress=progress)
            q_ref = np.array(flows)
        settings = IdentificationSettings(name="maps identification")
        names = fit_features(settings, chain)
        budget = ModelBudget()
        progress(0, 1, "identifying the flows (best mode)")
        result = fit(chain, measured, names=names, budget=budget)
        held = chain.start()
        for name, value in zip(result.names, result.values):
            held[chain.names.index(name)] = value
        progress(0, 1, "the maps")
        kinds = [f"{kind}{p + 1}" for p in range(chain.n_planes) for kind in ("fb", "phi")]
        pm = pair_map(chain, pair, held, measured=measured, names=names, features=kinds, budget=budget, n=points)
        return dict(map=pm, fit=result, chain_names=chain.names, q_ref=q_ref, nodes=tuple(chain.nodes), source=source,
                    record_name=state.record_name)

    async def _recompute(self, *events):
        if not self._ready:
            return
        self._stale = False  # computed now, with the record and settings of now
        if self.x_flow == self.y_flow:
            self._failed("choose two different flows for the two axes")
            return
        try:
            self._result = await self.jobs.run(
                self._compute, self.source, (self.x_flow, self.y_flow), self.grid_points, self.snr_db,
                self.record_point.speed, self.record_point.flows, self.state, label="maps and identification")
        except Cancelled:
            return
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._failed(exc)
            return
        self._error.visible = False
        self._redraw()

    def _failed(self, exc):
        """The error, and no plot of an earlier record or setting under it (issue 38)."""
        self._result = None
        self._chi2.object = None
        self._features.objects = []
        self._summary.object = ""
        self._error.object = f"**Maps not computed**: {plain(exc)}"
        self._error.visible = True

    def _redraw(self):
        r = self._result
        if r is None:
            return
        self._chi2.object = self._chi2_plot(r)
        self._features.objects = [pn.pane.HoloViews(p, linked_axes=False) for p in self._feature_plots(r)]
        self._summary.object = self._summary_text(r)

    # --- plots -------------------------------------------------------------------------------------------
    @staticmethod
    def _axes(pm):
        i, j = pm.pair
        return [f"Q{i + 1} (ml/min)", f"Q{j + 1} (ml/min)"]

    def _chi2_plot(self, r):
        pm, res = r["map"], r["fit"]
        i, j = pm.pair
        kd = self._axes(pm)
        a, b = pm.qx / M3S_PER_MLMIN, pm.qy / M3S_PER_MLMIN
        z = np.log10(pm.chi2 - np.nanmin(pm.chi2) + 1.0).T
        layers = [hv.QuadMesh((a, b, z), kd, "log10(χ² − min + 1)").opts(cmap="viridis_r", colorbar=True,
                                                                          tools=["hover"])]
        layers.append(hv.VLine(pm.q_threshold[i] / M3S_PER_MLMIN).opts(color=THRESHOLD_COLOR, line_dash="dashed"))
        layers.append(hv.HLine(pm.q_threshold[j] / M3S_PER_MLMIN).opts(color=THRESHOLD_COLOR, line_dash="dashed"))
        cols = [res.names.index(f"q{k + 1}") if f"q{k + 1}" in res.names else None for k in (i, j)]
        if None not in cols:
            for path in res.paths:
                p = np.asarray(path) / M3S_PER_MLMIN
                layers.append(hv.Curve((p[:, cols[0]], p[:, cols[1]]), *kd).opts(color="white", line_width=1.5,
                                                                                 alpha=0.8))
        q = res.flow_values() / M3S_PER_MLMIN
        layers.append(hv.Points([(q[i], q[j])], kd, label="identified").opts(color="yellow", marker="circle", size=13,
                                                                              line_color="black"))
        if r["q_ref"] is not None:
            t = r["q_ref"] / M3S_PER_MLMIN
            layers.append(hv.Points([(t[i], t[j])], kd, label="true flows").opts(color="red", marker="x", size=14,
                                                                                  line_width=3))
        held = [k for k in range(len(q)) if k not in (i, j)]
        note = ("; " + ", ".join(f"Q{k + 1} held at {q[k]:.0f}" for k in held) + " ml/min") if held else ""
        return hv.Overlay(layers).opts(title=f"χ² over Q{i + 1} × Q{j + 1}{note}", responsive=True, min_height=520,
                                       legend_position="right", xlim=(a[0], a[-1]), ylim=(b[0], b[-1]))

    def _feature_plots(self, r) -> list:
        pm = r["map"]
        kd = self._axes(pm)
        a, b = pm.qx / M3S_PER_MLMIN, pm.qy / M3S_PER_MLMIN
        i, j = pm.pair
        plots = []
        for name in pm.names:
            v = pm.feature(name).T
            fb = name.startswith("fb")
            label = f"{name} (–)" if fb else f"φ{name[3:]} (deg)"
            img = hv.QuadMesh((a, b, v if fb else np.degrees(v)), kd, label).opts(
                cmap="viridis" if fb else "plasma", colorbar=True, clabel=label, tools=["hover"], logz=fb)
            t = r["q_ref"]
            marks = hv.Points([] if t is None else [(t[i] / M3S_PER_MLMIN, t[j] / M3S_PER_MLMIN)], kd).opts(
                color="red", marker="x", size=12, line_width=3)
            plane = int(name[2:] if fb else name[3:])
            plots.append((img * marks).opts(title=f"{label.split(' ')[0]} at plane {plane} (node {r['nodes'][plane - 1]})",
                                            frame_width=300, frame_height=230))
        return plots

    def _summary_text(self, r) -> str:
        res = r["fit"]
        q = res.flow_values()
        lines = [self._record_line(r), f"#### Identified (best mode): {flows_text(q)}",
                 f"χ² = {res.chi2:.1f} for {res.dof} degrees of freedom (p = {res.p_value:.3g}); "
                 f"{res.seconds * 1e3:.0f} ms"]
        for k in range(q.size):
            iv = res.intervals.get(f"q{k + 1}")
            if iv is not None:
                hi = "open" if iv[1] is None else f"{iv[1] / M3S_PER_MLMIN:.0f}"
                lines.append(f"Q{k + 1}: 95 % interval {iv[0] / M3S_PER_MLMIN:.0f} – {hi} ml/min")
        if r["q_ref"] is not None:
            err = 100 * (q - r["q_ref"]) / r["q_ref"]
            lines.append("True flows " + " / ".join(f"{v / M3S_PER_MLMIN:.0f}" for v in r["q_ref"]) + " ml/min: errors "
                         + " / ".join(f"{e:+.2f} %" for e in err))
        if res.alternatives:
            lines.append("**Not unique**: other flows fit as well.")
        return "\n\n".join(lines)
