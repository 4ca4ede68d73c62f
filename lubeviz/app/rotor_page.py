"""Rotor page: the machine to scale, orbits and probe signals at any node, the full spectrum, the mode
shapes and the Campbell diagram on the film bearings at the chosen supply flows.

Teaching (issue 11): a student switches on an effect of the library (hotter oil, a worn bearing, a
second unbalance, soft pedestals, probe errors, a bow), set with widgets made from the effect's own
parameter declarations, and watches the orbit, the full spectrum and the shaft centreline (the static
journal position in its clearance circle) move against the machine without it.

Display only: responses come from `identify.forward.model.tabled_response` (bearing K, C from the cached
coefficient tables) and, with an effect, from `identify.forward.chain.ForwardChain` (the same chain the
identification fits); modes from `rotor.modal`, the Campbell diagram from `rotor.stability`.

The Campbell diagram takes seconds, so it is computed on request, for the flows of that moment; when the
flows (or the speed) change afterwards it says so ("stale", and for which flows it was computed) until it
is recomputed. Its job panel shows only its own job.

Large orbits (issue 11, item 6): the nonlinear film along the orbit (`rotor.orbit_balance`, a harmonic
balance of tens of seconds) is not a switch of the effect selector but a section of its own, computed on
request for the flows, speed, node and unbalance scale of that moment, stale (as the Campbell diagram) when
one of them changes: the orbit against the linear ellipse, its lines +-1X, +-2X, ... and the static shift.
"""

from __future__ import annotations

import math

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..effects import EFFECTS
from ..errors import ConvergenceError
from ..identify.forward.explore import large_orbit, rotor_state
from ..model.machine import Machine
from ..model.operating import OperatingPoint
from ..progress import Cancelled
from ..rotor.elements import DOF_PER_NODE, X, Y
from ..rotor.directional import directional_components, forward_backward_ratio, orbit_angle
from ..rotor.orbit_balance import HARMONICS, POINTS
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
from .machine_view import disc_box
from .text import plain
from .widgets import quantity_slider, show_effect

hv.extension("bokeh", logo=False)

EXPLAIN = """
### Reading the orbit and its full spectrum
The unbalance on the central disc turns with the shaft and pushes it round once per revolution, so each
point of the shaft traces an **orbit**, an ellipse in steady state. Two probes at 90° (X and Y) see two
sine waves. Combining them into one complex signal **Z = x + i·y** and taking its spectrum separates the
orbit into a circle turning **with** the shaft (forward whirl, the +1X line) and one turning **against**
it (backward whirl, the −1X line). The ratio **fb = |Zf| / |Zb|** says how round the orbit is, and the
angle **φ** says how its major axis is tilted. The oil film's stiffness and damping — set by the supply
flow — shape both; that is what the identification reads. Both are independent of the unbalance's size
and phase.

Starving a bearing changes its film (see the Bearing page), which moves the modes: the **Campbell
diagram** shows the damped natural frequencies against the shaft speed, the 1X line, the first critical
speed (where a forward mode crosses 1X) and the **instability threshold** (oil whip) at the chosen
fractions of Q_T.

**A real machine** is more than its bearings' supply. Switch an effect on (left) and see what it does:
hotter oil (viscosity factor below 1) thins the film, so the journal sinks and the orbit turns; a worn
bearing (larger clearance) sits lower in a larger circle; a second unbalance or a bow changes the
orbit's shape although the bearings have not; soft pedestals eat damping; a turned or miscalibrated
probe changes only what is *read*. The **shaft centreline** plots show each journal's static position in
its clearance circle (grey: without the effect) — what condition-monitoring systems call the
centreline. The identification must tell these apart from a change of supply: the Diagnose page does.

**Large orbits** (the section above): everything else on this page is the *linear* model, the film
replaced by its stiffness and damping at the static equilibrium. Press the large-orbit button to solve
the film along the orbit instead and see what the linear model leaves out: a 2X and 3X line, a static
shift of the journals and a 1X that is no longer the linear one. A record's 2X line is how it shows.
"""

LARGE_ORBIT = """
The linear model holds while the orbit is small against the bearing clearance. When it is a sizeable
fraction of it, the film force is no longer linear in the journal's motion: the film stiffens as the gap
narrows and the cavitated zone breathes with the orbit. The orbit
stays periodic at the shaft speed but gains **2X, 3X** lines and a **static shift** (0X) of the journals,
and its 1X departs from the linear one. Scale the unbalance to see the lines grow with the orbit.
"""

PLOT = dict(tools=["hover"], framewise=True)
# In a wrapping row (pn.FlexBox): the plots beside the controls while both fit, below them in a narrow window.
WRAPPING = dict(sizing_mode="stretch_width", min_width=420, styles={"flex": "1 1 420px"})
HALF = dict(min_width=340, styles={"flex": "1 1 480px"})  # two in a row when each has 480 px, else one


def _flows(flows) -> str:
    """'Q1 = 546, Q2 = 556 ml/min' (m^3/s in)."""
    return ", ".join(f"Q{k + 1} = {q / M3S_PER_MLMIN:.0f}" for k, q in enumerate(flows)) + " ml/min"


NODE_LABEL_GAP = 0.035  # node numbers on the drawing at least this fraction of the shaft's length apart (~21 px of 600)


def node_labels(xs, first, gap_mm: float) -> list[int]:
    """The nodes whose numbers the drawing shows, none closer than `gap_mm` to another: the nodes of `first`
    (bearings, supports, planes, unbalance) before the others, then from the shaft's ends inwards, in order
    (issue 38: with every node numbered, those of a finely meshed shaft ran into one another)."""
    n = len(xs)
    order = list(dict.fromkeys([k for k in first if 1 <= k <= n] + [1, n] + list(range(2, n))))
    kept: list[int] = []
    for k in order:
        if all(abs(xs[k - 1] - xs[j - 1]) >= gap_mm for j in kept):
            kept.append(k)
    return sorted(kept)


def _mostly(whirls) -> str:
    """The whirl direction a mode has at most of the speeds ('' when it has none)."""
    named = [w for w in whirls if w]
    return max(sorted(set(named)), key=named.count) if named else ""


def effect_choices() -> dict[str, str]:
    """{words: name}: no effect, and every registered effect the linear response carries, named in words (large_orbit
    has its own section)."""
    return {"no effect": "none", **{c.kind(): n for n, c in EFFECTS.items() if c.stage != "response"}}


class RotorPage(pn.viewable.Viewer):
    """The Rotor page of one session."""

    node = param.Integer(1, bounds=(1, None), doc="Node whose orbit, signals and spectrum are shown (first shown: "
                                                  "the first measurement plane's)")
    snr_db = param.Number(12.0, bounds=(-5.0, 60.0), doc="Signal-to-noise ratio of the simulated probes (dB)")
    revolutions = param.Integer(5, bounds=(1, 50), doc="Revolutions shown in the time signals")
    # large_orbit replaces the linear response (a harmonic balance, tens of seconds): its own section below
    effect_name = param.Selector(default="none", objects=["none"],
                                 doc="An effect of a real machine, switched on to see what it does")
    unbalance_scale = param.Number(1.0, bounds=(0.25, 2.0), step=0.05,
                                   doc="Unbalance of the large orbit, relative to the machine's (-)")

    def __init__(self, machine: Machine, operating: OperatingPoint, *,
                 _orbit_resolution: tuple[int, int] = (HARMONICS, POINTS), **params):
        """`_orbit_resolution`: harmonics and points per revolution of the large orbit (tests use fewer)."""
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.param.node.bounds = (1, machine.n_nodes)
        if "node" not in params:
            self.node = machine.measurement_planes[0].node
        self.param.effect_name.objects = effect_choices()  # the library as registered now
        self.jobs = JobPanel()
        self.campbell_jobs = JobPanel()
        self._tables = None
        self._rng_seed = 12345
        self._pipe = hv.streams.Pipe(data=None)
        self._summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-rotor-summary"])
        self._error = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width")
        self._sliders = pn.Column(sizing_mode="stretch_width")
        self._campbell_button = pn.widgets.Button(name="Compute Campbell diagram (film at each speed)",
                                                  button_type="primary", css_classes=["lubeviz-campbell"])
        self._campbell_button.on_click(self._on_campbell)
        # The diagram shown and the operating point it was computed for: a change of the flows (or the speed)
        # afterwards marks it stale until it is recomputed.
        self._campbell_data: dict | None = None
        self._campbell_drawn: tuple | None = None  # (data, stale) of the diagram on screen
        self._campbell_stale = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width",
                                             css_classes=["lubeviz-campbell-stale"])
        self._campbell_error = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width",
                                             css_classes=["lubeviz-campbell-error"])
        self.effect = None
        self._effect_story = pn.pane.Markdown("", sizing_mode="stretch_width", styles={"font-size": "0.9em"},
                                              css_classes=["lubeviz-rotor-effect-story"])
        self._effect_widgets = pn.Column(sizing_mode="stretch_width")
        self._init_large_orbit(_orbit_resolution)
        self._ready = False
        self._layout = self._build()
        self.param.watch(self._on_effect, "effect_name")
        self.param.watch(self._refresh, ["node", "snr_db", "revolutions"])
        self.op.param.watch(self._refresh, list(self.op.flow_names))
        self.op.param.watch(self._show_campbell, [*self.op.flow_names, "speed"])
        self.op.param.watch(self._show_large_orbit, [*self.op.flow_names, "speed"])
        self.param.watch(self._show_large_orbit, ["node", "unbalance_scale"])

    def _build(self):
        widgets = pn.Param(self.param, parameters=["node", "snr_db", "revolutions"], show_name=False,
                           widgets={"node": {"type": pn.widgets.IntSlider, "name": "Node"},
                                    "snr_db": {"type": pn.widgets.FloatSlider, "name": "Probe SNR (dB)"},
                                    "revolutions": {"type": pn.widgets.IntSlider,
                                                    "name": "Revolutions shown"}})
        effect = pn.Param(self.param, parameters=["effect_name"], show_name=False,
                          widgets={"effect_name": {"type": pn.widgets.Select, "name": "Effect switched on",
                                                   "css_classes": ["lubeviz-rotor-effect"]}})
        controls = pn.Column("### Operating point", self._sliders, widgets, "### A real machine", effect,
                             self._effect_story, self._effect_widgets, self._summary, self.jobs, width=330)
        # The response's plots are built once the first response is computed, with it as their first frame: built
        # from empty frames first, each was made twice on the server and drawn twice in the browser (issue 38: the
        # tab's first draw 5.2 s; `_show_plots`). Until then a line says what is coming.
        self._plots_built = False
        waiting = pn.pane.Markdown("Computing the rotor's response …", css_classes=["lubeviz-rotor-waiting"],
                                   margin=(10, 10))
        self._plots = pn.Column(waiting, **WRAPPING)
        self._spectra = pn.FlexBox(flex_wrap="wrap", sizing_mode="stretch_width")
        self._centrelines = pn.FlexBox(flex_wrap="wrap", sizing_mode="stretch_width")
        pane = dict(sizing_mode="stretch_width", linked_axes=False)
        # Replaced whole when computed (the number of tracked modes varies): no DynamicMap here. Hidden until then:
        # no empty axes under the button (issue 38). The box is hidden, not the pane: a HoloViews pane shown after
        # its object was replaced passed the page design on to its Bokeh figure, which raised in the callback.
        self._campbell_pane = pn.pane.HoloViews(self._campbell(None), css_classes=["lubeviz-campbell-plot"], **pane)
        self._campbell_box = campbell = pn.Column(self._campbell_pane, visible=False, sizing_mode="stretch_width")
        # Wrapping rows, so that a narrow window (800 px) stacks what a wide one sets side by side: the controls
        # above the plots, the orbit above the signals, one plot per row below.
        return pn.Column(
            self._error,
            pn.FlexBox(controls, self._plots, flex_wrap="wrap"),
            self._spectra,
            self._centrelines,
            pn.Row(pn.Column(self._campbell_button, self.campbell_jobs, self._campbell_error, self._campbell_stale,
                             campbell, sizing_mode="stretch_width", css_classes=["lubeviz-campbell-panel"]),
                   sizing_mode="stretch_width"),
            self._large_orbit_section(),
            pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
            sizing_mode="stretch_width")

    def __panel__(self):
        return self._layout

    def _show_plots(self) -> None:
        """The response's plots, made on the pipe's current data (the first response) as their first frame. (The
        plots below the first screen sent in a second message did not draw the spectrum sooner: 3.4 s against 3.3.)"""
        pane = dict(sizing_mode="stretch_width", linked_axes=False)
        drawing = pn.pane.HoloViews(hv.DynamicMap(self._drawing, streams=[self._pipe]),
                                    css_classes=["lubeviz-machine"], linked_axes=False)
        self._orbit_pane = orbit = pn.pane.HoloViews(hv.DynamicMap(self._orbit, streams=[self._pipe]), width=380,
                                                     css_classes=["lubeviz-orbit"], linked_axes=False)
        signals = pn.pane.HoloViews(hv.DynamicMap(self._signals, streams=[self._pipe]), min_width=300,
                                    styles={"flex": "1 1 300px"}, **pane)
        spectrum = pn.pane.HoloViews(hv.DynamicMap(self._spectrum, streams=[self._pipe]),
                                     css_classes=["lubeviz-spectrum"], **HALF, **pane)
        modes = pn.pane.HoloViews(hv.DynamicMap(self._modes, streams=[self._pipe]), **HALF, **pane)
        centreline = [pn.pane.HoloViews(hv.DynamicMap(lambda data, k=k: self._centreline(data, k), streams=[self._pipe]),
                                        linked_axes=False, css_classes=[f"lubeviz-centreline{k + 1}"])
                      for k in range(len(self.machine.bearings))]
        self._plots.objects = [drawing, pn.FlexBox(orbit, signals, flex_wrap="wrap")]
        self._spectra.objects = [spectrum, modes]
        self._centrelines.objects = centreline
        self._plots_built = True

    # --- computing -------------------------------------------------------------------------------------
    async def start(self):
        if self._ready:
            return
        self._ready = True
        try:
            self._tables = await self.jobs.run(resources.tables, self.machine, self.op.speed,
                                               label="bearing coefficient tables")
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._fail(exc)
            return
        qt = [t.q_threshold for t in self._tables]
        # The sliders move by whole ml/min over the tables' span; the session's first guess on a machine without
        # a published Q_T (or a flow outside the span) starts at each bearing's Q_T.
        span = [(math.ceil(t.q_min / M3S_PER_MLMIN) * M3S_PER_MLMIN, math.floor(t.q_max / M3S_PER_MLMIN) * M3S_PER_MLMIN)
                for t in self._tables]
        first = self.op.provisional
        self.op.flows = [round((t.q_threshold if first or not lo <= q <= hi else q) / M3S_PER_MLMIN) * M3S_PER_MLMIN
                         for q, (lo, hi), t in zip(self.op.flows, span, self._tables)]
        self.op.provisional = False
        self._sliders.objects = [
            quantity_slider(self.op, name, start=lo, end=hi, step=M3S_PER_MLMIN,
                            label=f"Supply flow Q{k + 1} (ml/min); Q_T = {qt[k] / M3S_PER_MLMIN:.0f}",
                            sizing_mode="stretch_width", css_classes=[f"lubeviz-q{k + 1}"])
            for k, (name, (lo, hi)) in enumerate(zip(self.op.flow_names, span))]
        await self._refresh()

    def _state(self, node: int, flows, effect, progress=None) -> dict:
        """Everything the plots show (`identify.forward.explore.rotor_state`, on this server's shared rotor,
        tables and chains)."""
        m = self.machine
        return rotor_state(m, self._tables, resources.rotor(m), flows, node, effect, snr_db=self.snr_db,
                           seed=self._rng_seed, progress=progress or (lambda *a: None),
                           chain_for=lambda nodes: resources.chain(m, self.op.speed, nodes),
                           prepare=resources.prepare_views)

    async def _refresh(self, *events):
        if not self._ready or self._tables is None:
            return
        try:
            effect = None if self.effect is None else self.effect.hold()  # a copy: widgets may move meanwhile
            label = "response" if effect is None else f"response with {effect.title()}"
            state = await self.jobs.run(self._state, self.node, self.op.flows, effect, label=label,
                                        quiet=True)
        except Cancelled:
            return
        except Exception as exc:  # noqa: BLE001
            self._fail(exc)
            return
        self._error.visible = False
        if not self._plots_built:
            self._pipe.send(state)  # nothing draws from it yet: the plots are made with it as their first frame
            self._show_plots()
        else:
            with plotting.frozen(self._orbit_pane):  # one walk of the session's models for the seven plots
                self._pipe.send(state)
        self._summary.object = self._summary_text(state)

    async def _on_effect(self, event):
        name = event.new
        if name == "none":
            self.effect = None
            self._effect_story.object = ""
            self._effect_widgets.objects = []
        else:
            self.effect = show_effect(name, self.machine, self._effect_story, self._effect_widgets)
            if self.effect is not None:
                self.effect.param.watch(self._refresh, [p for p in self.effect.param if p != "name"])
        await self._refresh()

    def _campbell_ratios(self, flows) -> tuple[float, ...]:
        """The supply fractions of Q_T the Campbell diagram is computed at, rounded as its cache key is."""
        return tuple(round(q / t.q_threshold, 3) for q, t in zip(flows, self._tables))

    async def _on_campbell(self, event):
        if self._tables is None:
            return
        flows, speed = self.op.flows, self.op.speed
        ratios = tuple(q / t.q_threshold for q, t in zip(flows, self._tables))
        speeds = 2 * math.pi * np.linspace(max(self.machine.speed_min, 5.0), self.machine.speed_max, 30)
        key = ("campbell", self.machine.source, self._campbell_ratios(flows))
        label = f"Campbell diagram at {_flows(flows)}"
        self._campbell_error.visible = False
        cached = resources.memo_get(key)
        if cached is None:
            # One Campbell job at a time: a job in a worker process runs to its end even when cancelled, and
            # meanwhile a second job's progress would share this panel with the first's "cancelling".
            self._campbell_button.disabled = True
            try:
                cached = await self.campbell_jobs.run(resources.compute_stability, self.machine.source, speeds,
                                                      ratios, process=True, label=label)
            except Cancelled:
                return
            except Exception as exc:  # noqa: BLE001 - shown beside the diagram (its job status says it too)
                self._campbell_error.object = f"**Campbell diagram not computed**: {plain(exc)}"
                self._campbell_error.visible = True
                return
            finally:
                self._campbell_button.disabled = False
            resources.memo_put(key, cached)
        else:
            self.campbell_jobs.status = f"{label}: from the cache"
        self._campbell_data = dict(result=cached, ratios=ratios, flows=flows, speed=speed)
        self._show_campbell()

    def _campbell_changes(self) -> list[str]:
        """What has changed since the diagram shown was computed (empty: it is up to date)."""
        d = self._campbell_data
        if d is None or self._tables is None:
            return []
        changes = []
        if self._campbell_ratios(self.op.flows) != self._campbell_ratios(d["flows"]):
            changes.append("the flows have changed")
        if self.op.speed != d["speed"]:
            changes.append("the speed has changed")
        return changes

    def _show_campbell(self, *events):
        d = self._campbell_data
        if d is None:
            return
        changes = self._campbell_changes()
        self._campbell_stale.object = (f"Campbell diagram computed for {_flows(d['flows'])} "
                                       f"at {d['speed']:g} Hz; {' and '.join(changes)}: "
                                       "press the button to recompute.")
        self._campbell_stale.visible = bool(changes)
        drawn = (d, bool(changes))
        if self._campbell_drawn is None or self._campbell_drawn[0] is not d or self._campbell_drawn[1] != drawn[1]:
            self._campbell_pane.object = self._campbell(d, stale=drawn[1])  # redrawn only when its title changes
            self._campbell_box.visible = True
            self._campbell_drawn = drawn

    # --- large orbits (nonlinear film) -------------------------------------------------------------------
    def _init_large_orbit(self, resolution: tuple[int, int]):
        self._orbit_resolution = tuple(int(v) for v in resolution)
        self.large_orbit_jobs = JobPanel()
        self._large_orbit_button = pn.widgets.Button(
            name="Compute the large orbit (harmonic balance, tens of seconds)", button_type="primary",
            css_classes=["lubeviz-large-orbit-button"])
        self._large_orbit_button.on_click(self._on_large_orbit)
        # The orbit shown and what it was computed for: flows, speed, node and unbalance scale (as Campbell).
        self._large_orbit_data: dict | None = None
        self._large_orbit_drawn: tuple | None = None  # (data, stale) of the plots on screen
        alert = dict(visible=False, sizing_mode="stretch_width")
        self._large_orbit_stale = pn.pane.Alert("", alert_type="warning",
                                                css_classes=["lubeviz-large-orbit-stale"], **alert)
        self._large_orbit_error = pn.pane.Alert("", alert_type="danger",
                                                css_classes=["lubeviz-large-orbit-error"], **alert)
        self._large_orbit_whirl = pn.pane.Alert("", alert_type="warning",
                                                css_classes=["lubeviz-large-orbit-whirl"], **alert)
        self._large_orbit_summary = pn.pane.Markdown("", min_width=300, styles={"flex": "1 1 300px"},
                                                     css_classes=["lubeviz-large-orbit-summary"])
        # Replaced whole when computed, as the Campbell diagram, and hidden until then as it is (its box).
        self._large_orbit_pane = pn.pane.HoloViews(self._large_orbit_plot(None), linked_axes=False,
                                                   css_classes=["lubeviz-large-orbit-plot"])
        self._large_orbit_lines = pn.pane.HoloViews(self._large_orbit_spectrum(None), linked_axes=False,
                                                    css_classes=["lubeviz-large-orbit-spectrum"], **HALF)
        self._large_orbit_box = pn.FlexBox(self._large_orbit_pane, self._large_orbit_lines, self._large_orbit_summary,
                                           flex_wrap="wrap", visible=False)

    def _large_orbit_section(self):
        scale = pn.Param(self.param, parameters=["unbalance_scale"], show_name=False,
                         widgets={"unbalance_scale": {"type": pn.widgets.FloatSlider,
                                                      "name": "Unbalance scale (× the machine's)",
                                                      "css_classes": ["lubeviz-large-orbit-scale"]}})
        return pn.Column("### Large orbits (nonlinear film)",
                         pn.pane.Markdown(LARGE_ORBIT, sizing_mode="stretch_width"),
                         pn.FlexBox(scale, self._large_orbit_button, flex_wrap="wrap", align_items="center"),
                         self.large_orbit_jobs, self._large_orbit_error, self._large_orbit_whirl,
                         self._large_orbit_stale,
                         self._large_orbit_box,
                         sizing_mode="stretch_width", css_classes=["lubeviz-large-orbit-panel"])

    @staticmethod
    def _orbit_balance(machine: Machine, flows, speed_hz: float, node: int, scale: float,
                       resolution: tuple[int, int], progress):
        """The large orbit and its stability (`identify.forward.explore.large_orbit`, in the job's thread)."""
        return large_orbit(machine, resources.rotor(machine), flows, speed_hz, node, scale, resolution, progress)

    async def _on_large_orbit(self, event=None):
        flows, speed = self.op.flows, self.op.speed
        node, scale = self.node, self.unbalance_scale
        label = f"large orbit at node {node}, unbalance ×{scale:g}"
        self._large_orbit_error.visible = False
        try:
            result = await self.large_orbit_jobs.run(self._orbit_balance, self.machine, flows, speed, node, scale,
                                                     self._orbit_resolution, label=label)
        except Cancelled:
            return
        except ConvergenceError as exc:  # e.g. the orbit reaches the wall: a physical answer, not a crash
            self._large_orbit_error.object = (f"**No periodic orbit near the linear one** at unbalance "
                                              f"×{scale:g}: {plain(exc)}. Try a smaller unbalance scale.")
            self._large_orbit_error.visible = True
            return
        except Exception as exc:  # noqa: BLE001 - shown beside the button (its job status says it too)
            self._large_orbit_error.object = f"**Large orbit not computed**: {plain(exc)}"
            self._large_orbit_error.visible = True
            return
        result, stability, orbit_stab = result
        self._large_orbit_data = dict(result=result, stability=stability, orbit_stability=orbit_stab, flows=flows,
                                      speed=speed, node=node, scale=scale)
        self._large_orbit_whirl.object = (
            f"**Oil whirl**: at these flows and speed the machine is {stability.describe()}. The periodic orbit "
            "drawn here is a solution of the equations, not what the machine shows: the whirl grows on top of "
            f"it as a sub-synchronous line near {stability.order:.2f}X (the Campbell diagram above shows the "
            "instability threshold; `lubeviz simulate --effect large_orbit` writes the whirl's onset).")
        self._large_orbit_whirl.visible = stability.unstable
        self._show_large_orbit()

    def _large_orbit_changes(self) -> list[str]:
        """What has changed since the large orbit shown was computed (empty: it is up to date)."""
        d = self._large_orbit_data
        if d is None:
            return []
        changes = []
        rounded = [round(q / M3S_PER_MLMIN, 1) for q in d["flows"]]  # the sliders move by 1 ml/min
        if [round(q / M3S_PER_MLMIN, 1) for q in self.op.flows] != rounded:
            changes.append("the flows have changed")
        if self.op.speed != d["speed"]:
            changes.append("the speed has changed")
        if self.node != d["node"]:
            changes.append("the node has changed")
        if self.unbalance_scale != d["scale"]:
            changes.append("the unbalance scale has changed")
        return changes

    def _show_large_orbit(self, *events):
        d = self._large_orbit_data
        if d is None:
            return
        changes = self._large_orbit_changes()
        self._large_orbit_stale.object = (f"Large orbit computed for {_flows(d['flows'])} at "
                                          f"{d['speed']:g} Hz, node {d['node']}, unbalance ×{d['scale']:g}; "
                                          f"{' and '.join(changes)}: press the button to recompute.")
        self._large_orbit_stale.visible = bool(changes)
        drawn = (d, bool(changes))
        if self._large_orbit_drawn is None or self._large_orbit_drawn[0] is not d \
                or self._large_orbit_drawn[1] != drawn[1]:  # redrawn only when the result or its title changes
            self._large_orbit_pane.object = self._large_orbit_plot(d, stale=drawn[1])
            self._large_orbit_lines.object = self._large_orbit_spectrum(d, stale=drawn[1])
            self._large_orbit_summary.object = self._large_orbit_text(d)
            self._large_orbit_box.visible = True
            self._large_orbit_drawn = drawn

    def _fail(self, exc: Exception):
        self._error.object = f"**Could not compute the response**: {plain(exc)}"
        self._error.visible = True
        self._summary.object = ""
        if self._plots_built:  # no earlier response's plots under the error (issue 38): their empty frames
            with plotting.frozen(self._orbit_pane):
                self._pipe.send(None)
        else:  # nor a line that says a response is coming
            self._plots.objects[0].object = "No response computed (see the message above)."

    # --- plots -------------------------------------------------------------------------------------------
    def _drawing(self, data):
        m = self.machine
        xs = np.concatenate([[0.0], np.cumsum([e.length for e in m.elements])]) * 1e3
        shaft = [(xs[i], -e.diameter / 2e-3, xs[i + 1], e.diameter / 2e-3) for i, e in enumerate(m.elements)]
        discs = [(x - hw, -r, x + hw, r) for x, hw, r in (disc_box(d, xs) for d in m.discs)]  # lumped ones too
        top = max(d[3] for d in discs) if discs else 100.0
        bearings = []
        for b in m.bearings:
            x0 = xs[b.node - 1]
            r = b.radius * 1e3
            bearings += [(x0 - b.length / 2e-3, r, x0 + b.length / 2e-3, r + 25),
                         (x0 - b.length / 2e-3, -r - 25, x0 + b.length / 2e-3, -r)]
        supports = []
        for sp in m.supports:
            x0, r = xs[sp.node - 1], m.elements[min(sp.node - 1, len(m.elements) - 1)].diameter / 2e-3
            supports += [(x0 - 8, r, x0 + 8, r + 25), (x0 - 8, -r - 25, x0 + 8, -r)]
        el = (hv.Rectangles(shaft, ["x (mm)", "radius (mm)", "x1", "y1"]).opts(color="#9aa5b1", line_color="black")
              * hv.Rectangles(discs).opts(color="#51606f", line_color="black")
              * hv.Rectangles(bearings).opts(color="#e8a33d", line_color="black")
              * hv.Rectangles(supports).opts(color="#5a9e5a", line_color="black"))
        meas = list(m.center_nodes) + list(m.outside_nodes)
        shown = node_labels(xs, [b.node for b in m.bearings] + [sp.node for sp in m.supports] + meas
                            + [m.unbalance_node], gap_mm=NODE_LABEL_GAP * (xs[-1] - xs[0]))
        labels = hv.Labels([(xs[n - 1], -top - 40, str(n)) for n in shown],
                           ["x (mm)", "radius (mm)"], "node").opts(text_font_size="8pt", text_color="gray")
        probes = hv.Points([(xs[n - 1], top + 30) for n in meas], ["x (mm)", "radius (mm)"],
                           label="measurement planes").opts(marker="inverted_triangle", size=10, color="#2c5f8a")
        node = data["node"] if data else self.node
        sel = hv.Points([(xs[node - 1], top + 30)], ["x (mm)", "radius (mm)"], label="node shown").opts(
            marker="inverted_triangle", size=14, color="red")
        unb = hv.Points([(xs[m.unbalance_node - 1], 0.0)], ["x (mm)", "radius (mm)"], label="unbalance").opts(
            marker="star", size=14, color="#d62728")
        return (el * labels * probes * sel * unb).opts(
            # read whole above a 600 px frame (the longer one was cut): what the colours mean, briefly
            title="The machine to scale: oil-film bearings orange, other supports green, ▼ probe planes",
            # 600 px: about 705 with its axes, within the plots' column of an 800 px window (a responsive
            # width would lose the 1:1 scale, data_aspect fixes the height)
            frame_width=600, data_aspect=1, xlim=(-50.0, xs[-1] + 50.0), ylim=(-top - 70, top + 60),
            show_legend=False, xlabel="axial position x (mm)", ylabel="radius (mm)", framewise=True)

    def _orbit(self, data):
        # the legend under the frame, never over the orbit (issue 38)
        opts = dict(frame_width=300, frame_height=300, framewise=True, **plotting.outside_legend("below", cols=2))
        kd = ["x (µm)", "y (µm)"]
        if not data:
            # labelled as the response's layers will be: the legend is in the first drawing, not added to a figure
            # the browser has drawn (BokehJS then relaid the figure out before the legend had a view: "cannot find
            # a view for Legend", at every update after)
            return (hv.Curve([], *kd, label="steady orbit") * hv.Scatter([], *kd, label="probes (noisy)")
                    * hv.Points([], kd, label="t = 0 (keyphasor)")).opts(title="Orbit", **opts)
        th = np.linspace(0, 2 * math.pi, 181)
        x = (data["x"] * np.exp(1j * th)).real * 1e6
        y = (data["y"] * np.exp(1j * th)).real * 1e6
        n_show = min(data["noisy"].shape[1], 64 * self.revolutions)
        noisy = data["noisy"][:, :n_show] * 1e6
        lim = 1.25 * max(np.abs(noisy).max(), 1e-9)
        bx = (data["base_x"] * np.exp(1j * th)).real * 1e6
        by = (data["base_y"] * np.exp(1j * th)).real * 1e6
        effect = data.get("effect")
        base = hv.Curve((bx, by) if effect is not None else ([], []), *kd, label="without the effect").opts(
            color="gray", line_dash="dashed", line_width=1.5)
        return (hv.Scatter((noisy[0], noisy[1]), *kd, label="probes (noisy)").opts(color="#9ecae1", size=3)
                * base
                * hv.Curve((x, y), *kd, label="steady orbit" if effect is None else f"with {effect.title()}").opts(
                    color="#08519c", line_width=2)
                * hv.Points([(x[0], y[0])], kd, label="t = 0 (keyphasor)").opts(color=plotting.NEUTRAL, size=8)).opts(
            title=f"Orbit at node {data['node']} (forward: counter-clockwise)", xlim=(-lim, lim), ylim=(-lim, lim),
            **opts)

    def _signals(self, data):
        # height and min_width as the pane gives them to the figure when it is made: an update with other values
        # (HoloViews' stretch_both without a width) relays the figures out in the browser, ~0.5 s each
        opts = dict(responsive=True, height=340, min_height=340, min_width=300, legend_position="top_right",
                    framewise=True, title="Probe signals")
        if not data:
            return (hv.Curve([], "t (ms)", "displacement (µm)", label="x (horizontal)")
                    * hv.Curve([], "t (ms)", "displacement (µm)", label="y (vertical)")).opts(**opts)  # as the orbit
        n_show = min(data["noisy"].shape[1], 64 * self.revolutions)
        t = data["t"][:n_show] * 1e3
        nz = data["noisy"][:, :n_show] * 1e6
        return (hv.Curve((t, nz[0]), "t (ms)", "displacement (µm)", label="x (horizontal)").opts(color="#1f77b4")
                * hv.Curve((t, nz[1]), "t (ms)", "displacement (µm)", label="y (vertical)").opts(color="#d62728")
                ).opts(**opts)

    def _spectrum(self, data):
        opts = dict(responsive=True, height=320, min_height=320, min_width=HALF["min_width"], framewise=True)  # as _signals
        kd, vd = "frequency (Hz)", "amplitude (µm)"
        if not data:
            return (hv.Spikes([], kd, vd) * hv.Labels([], [kd, vd], "text")).opts(
                title="Full spectrum (+: forward whirl, −: backward whirl)", **opts)
        spec = data["spectrum"]
        f, a = spec.freq_hz, np.abs(spec.amplitude) * 1e6
        keep = np.abs(f) <= 4.5 * data["speed"]
        zf, zb = spec.line(1.0), spec.line(-1.0)
        fb, phi = float(forward_backward_ratio(zf, zb)), float(orbit_angle(zf, zb))
        labels = hv.Labels([(data["speed"], abs(zf) * 1e6, f"+1X  |Zf| = {abs(zf) * 1e6:.1f} µm"),
                            (-data["speed"], abs(zb) * 1e6, f"−1X  |Zb| = {abs(zb) * 1e6:.1f} µm")],
                           [kd, vd], "text").opts(text_font_size="9pt", yoffset=0.0, text_baseline="bottom")
        return (hv.Spikes((f[keep], a[keep]), kd, vd).opts(color="#2c5f8a", line_width=2) * labels).opts(
            title=f"Full spectrum at node {data['node']}: fb = {fb:.3f}, φ = {math.degrees(phi):.1f}°", **opts)

    def _modes(self, data):
        kd, vd = "axial position x (mm)", "mode shape (–)"
        opts = dict(responsive=True, height=320, min_height=320, min_width=HALF["min_width"],  # as _signals
                    **plotting.outside_legend("right"), framewise=True,
                    title="Damped mode shapes at the operating speed (horizontal component)")
        if not data:
            return hv.Overlay([hv.Curve([], kd, vd, label=f"mode {j + 1}") for j in range(4)]).opts(**opts)  # as the orbit
        m = self.machine
        xs = np.concatenate([[0.0], np.cumsum([e.length for e in m.elements])]) * 1e3
        modal = data["modal"]
        curves = []
        for j in range(min(4, modal.modes.shape[1])):
            shape = modal.modes[:DOF_PER_NODE * xs.size, j]  # the shaft's (a pedestal's housing after it)
            ux = shape[X::DOF_PER_NODE]
            uy = shape[Y::DOF_PER_NODE]
            ref = ux[np.argmax(np.abs(ux))] if np.abs(ux).max() >= np.abs(uy).max() else uy[np.argmax(np.abs(uy))]
            u = (ux * np.conj(ref) / abs(ref)).real
            u = u / max(np.abs(u).max(), 1e-30)
            label = (f"{modal.damped_frequencies_hz[j]:.1f} Hz, ζ = {modal.damping_ratios[j]:.3f}, "
                     f"{modal.whirl[j]}")
            curves.append(hv.Curve((xs, u), kd, vd, label=label))
        while len(curves) < 4:
            curves.append(hv.Curve([], kd, vd))
        return hv.Overlay(curves).opts(**opts)

    def _campbell(self, data, stale: bool = False):
        kd, vd = "shaft speed (Hz)", "damped natural frequency (Hz)"
        opts = dict(responsive=True, min_height=380, **plotting.outside_legend("right"), framewise=True,
                    title="Campbell diagram (press the button above; film recomputed at every speed)")
        if not data:
            return hv.Overlay([hv.Curve([], kd, vd)]).opts(**opts)
        res = data["result"].modes
        speeds = res.speeds / (2 * math.pi)
        fr = res.damped_frequencies_hz
        # each mode marked by the way it mostly whirls over the speeds: forward solid, backward dashed (issue 38)
        whirl = [_mostly([row[j] for row in res.whirl]) for j in range(fr.shape[1])]
        tracks = [hv.Curve((speeds, fr[:, j]), kd, vd, label=f"mode {j + 1}" + (f", {whirl[j]}" if whirl[j] else "")).opts(
                      line_dash="dashed" if whirl[j] == "backward" else "solid")
                  for j in range(min(8, fr.shape[1]))]
        one_x = hv.Curve((speeds, speeds), kd, vd, label="1X").opts(color=plotting.NEUTRAL, line_dash="dashed")
        marks = []
        crit = res.first_critical_speed
        if crit is not None:
            marks.append((crit / (2 * math.pi), crit / (2 * math.pi), "first critical"))
        if res.unstable_mode is not None:
            u = res.unstable_mode
            marks.append((u.speed_hz, u.frequency_hz, "instability threshold"))
        pts = hv.Points([(a, b) for a, b, _ in marks], [kd, vd]).opts(color="red", size=10, marker="x")
        text = "; ".join(f"{name} {a:.1f} Hz" for a, _, name in marks) or "no crossing in range"
        q = "/".join(f"{f / M3S_PER_MLMIN:.0f}" for f in data["flows"])
        names = "/".join(f"Q{k + 1}" for k in range(len(data["flows"])))
        # short enough to be read whole above the plot (the fractions of Q_T are in the job's status and the sliders)
        title = f"Campbell diagram at {names} = {q} ml/min: {text}{' (stale)' if stale else ''}"
        return (hv.Overlay(tracks) * one_x * pts * hv.VLine(data["speed"], label="operating speed").opts(
            color="green")).opts(**dict(opts, title=title, ylim=(0.0, 1.5 * speeds[-1])))

    # --- large-orbit plots -------------------------------------------------------------------------------
    @staticmethod
    def _large_orbit_plot(data, stale: bool = False):
        """The nonlinear orbit over one revolution (its static shift included) on the linear ellipse."""
        kd = ["x (µm)", "y (µm)"]
        opts = dict(frame_width=300, frame_height=300, **plotting.outside_legend("below"), framewise=True)
        if not data:
            return (hv.Curve([], *kd) * hv.Curve([], *kd)).opts(
                title="Large orbit (press the button above)", **opts)
        res = data["result"]
        t = np.linspace(0.0, 2 * math.pi / res.omega, 241)
        xs, ys = res.signals(t)
        x, y = xs[0] * 1e6, ys[0] * 1e6
        e = np.exp(1j * res.omega * t)
        lx, ly = (res.linear_x[0] * e).real * 1e6, (res.linear_y[0] * e).real * 1e6
        centre = (res.x[0, 0].real * 1e6, res.y[0, 0].real * 1e6)
        lim = 1.15 * max(np.abs(np.concatenate([x, y, lx, ly])).max(), 1e-9)
        title = f"Orbit at node {data['node']}, unbalance ×{data['scale']:g}{' (stale)' if stale else ''}"
        return (hv.Curve((lx, ly), *kd, label="linear model (K, C at equilibrium)").opts(
                    color="gray", line_dash="dashed", line_width=1.5)
                * hv.Curve((x, y), *kd, label="nonlinear film (static shift included)").opts(
                    color="#d62728", line_width=2)
                * hv.Points([centre], kd, label="orbit centre: static shift 0X").opts(color="#d62728", size=8,
                                                                                       marker="x")
                * hv.Points([(lx[0], ly[0]), (x[0], y[0])], kd, label="t = 0 (keyphasor)").opts(
                    color=plotting.NEUTRAL, size=7)).opts(
            title=title, xlim=(-lim, lim), ylim=(-lim, lim), **opts)

    @staticmethod
    def _large_orbit_spectrum(data, stale: bool = False):
        """The lines of the nonlinear orbit, amplitude against order (+: forward whirl, −: backward)."""
        kd, vd = "order (× shaft speed)", "amplitude (µm)"
        opts = dict(responsive=True, min_height=340, legend_position="top_right", framewise=True)
        if not data:
            return (hv.Spikes([], kd, vd) * hv.Scatter([], kd, vd)).opts(
                title="Lines of the large orbit (+: forward, −: backward whirl)", **opts)
        res = data["result"]
        orders, amps = [0], [math.hypot(res.x[0, 0].real, res.y[0, 0].real) * 1e6]
        for h in range(1, res.harmonics + 1):
            zf, zb = directional_components(res.x[h, 0], res.y[h, 0])
            orders += [h, -h]
            amps += [abs(zf) * 1e6, abs(zb) * 1e6]
        zf1 = amps[1]
        lf, lb = directional_components(res.linear_x[0], res.linear_y[0])
        text = [(o, a, f"{a / zf1:.1%}") for o, a in zip(orders, amps) if abs(o) >= 2 and a > 0.002 * zf1]
        title = (f"Lines of the large orbit at node {data['node']} (+: forward, −: backward whirl; "
                 f"% of +1X){' (stale)' if stale else ''}")
        return (hv.Spikes((orders, amps), kd, vd, label="nonlinear film").opts(color="#d62728", line_width=3)
                * hv.Scatter([(1, abs(lf) * 1e6), (-1, abs(lb) * 1e6)], kd, vd, label="linear model ±1X").opts(
                    color="gray", size=9, marker="circle")
                * hv.Labels(text, [kd, vd], "text").opts(text_font_size="8pt", text_baseline="bottom")).opts(
            title=title, xticks=[(o, f"{o:+d}X" if o else "0X") for o in sorted(orders)], **opts)

    @staticmethod
    def _large_orbit_text(data) -> str:
        res = data["result"]
        zf, zb = directional_components(res.x[1, 0], res.y[1, 0])
        lf, lb = directional_components(res.linear_x[0], res.linear_y[0])
        size = math.hypot(abs(res.x[1, 0]), abs(res.y[1, 0]))
        linear = math.hypot(abs(res.linear_x[0]), abs(res.linear_y[0]))
        shifts = [f"| static shift (0X), journal {j + 1} | ({res.bearing_x[0, j].real * 1e6:+.2f}, "
                  f"{res.bearing_y[0, j].real * 1e6:+.2f}) µm |" for j in range(res.bearing_x.shape[1])]
        return "\n".join([
            f"#### Large orbit at node {data['node']}, unbalance ×{data['scale']:g}",
            "| quantity | value |", "|---|---|",
            f"| 2X / 1X at node {data['node']} (\\|+2X\\| + \\|−2X\\| over \\|+1X\\|) | "
            f"{res.harmonic_ratio(2, 0):.1%} |",
            *([f"| 3X / 1X | {res.harmonic_ratio(3, 0):.1%} |"] if res.harmonics >= 3 else []),
            f"| \\|1X\\| nonlinear / linear | {size / linear:.3f} |",
            f"| \\|Zf\\| forward 1X | {abs(zf) * 1e6:.2f} µm (linear {abs(lf) * 1e6:.2f} µm) |",
            f"| \\|Zb\\| backward 1X | {abs(zb) * 1e6:.2f} µm (linear {abs(lb) * 1e6:.2f} µm) |",
            f"| static shift (0X) at node {data['node']} | ({res.x[0, 0].real * 1e6:+.2f}, "
            f"{res.y[0, 0].real * 1e6:+.2f}) µm |",
            *shifts,
            f"| largest eccentricity along the orbit | {res.max_eccentricity:.3f} |",
            *([f"| stability of the equilibrium | {data['stability'].describe()} |"] if data.get("stability") else []),
            *([f"| stability of this orbit | {data['orbit_stability'].describe()} |"]
              if data.get("orbit_stability") else []),
            f"| harmonic balance | {res.iterations} Newton steps, {res.seconds:.1f} s "
            f"(0X–{res.harmonics}X, {res.films and len(res.films[0])} points per revolution) |",
            "", "\\|1X\\|: the orbit's size √(\\|X₁\\|² + \\|Y₁\\|²). Static shift from the linear "
            "model's equilibrium (x horizontal, y vertical)."])

    def _centreline(self, data, k: int):
        """Journal k's static position in its clearance circle (µm, from the bearing centre; Y up)."""
        kd = ["X (µm)", "Y (µm)"]
        opts = dict(frame_width=250, frame_height=250, framewise=True, **plotting.outside_legend("right"),
                    title=f"Shaft centreline, bearing {k + 1}")
        if not data:
            return (hv.Curve([], *kd, label="clearance circle") * hv.Points([], kd, label="journal")).opts(**opts)
        th = np.linspace(0, 2 * math.pi, 181)
        c0, c = data["clearance"][k] * 1e6, data["clearance_eff"][k] * 1e6
        p0, p = data["static0"][k] * 1e6, data["static"][k] * 1e6
        lim = 1.1 * max(c0, c)
        layers = [hv.Curve((c0 * np.cos(th), c0 * np.sin(th)), *kd, label="clearance circle").opts(color=plotting.NEUTRAL)]
        effect = data.get("effect")
        if effect is not None and abs(c - c0) > 1e-9:
            layers.append(hv.Curve((c * np.cos(th), c * np.sin(th)), *kd, label="with the effect").opts(
                color="#d62728", line_dash="dashed"))
        layers.append(hv.Points([tuple(p0)], kd, label="journal" if effect is None else "without the effect").opts(
            color="gray" if effect is not None else "#08519c", size=10))
        if effect is not None:
            layers.append(hv.Curve(([p0[0], p[0]], [p0[1], p[1]]), *kd).opts(color="#d62728", line_width=1))
            layers.append(hv.Points([tuple(p)], kd, label=f"with {effect.title()}").opts(color="#d62728", size=10))
        e = math.hypot(*p) / c
        return hv.Overlay(layers).opts(**dict(opts, title=f"Shaft centreline, bearing {k + 1}: ε = {e:.2f}"),
                                       xlim=(-lim, lim), ylim=(-lim, lim))

    def _summary_text(self, s) -> str:
        spec = s["spectrum"]
        zf, zb, phi = s["zf"], s["zb"], math.degrees(s["phi"])
        modal = s["modal"]
        q = [f"{q / M3S_PER_MLMIN:.0f} ml/min ({q / qt:.2f} Q_T" + ("" if abs(qt / qt0 - 1) < 0.01 else
                                                               f" of the bearing with the effect, Q_T = "
                                                               f"{qt / M3S_PER_MLMIN:.0f} ml/min") + ")"
             for q, qt, qt0 in zip(s["flows"], s["q_threshold"], s["q_threshold_declared"])]
        fr = ", ".join(f"{f:.1f}" for f in modal.damped_frequencies_hz[:4])
        return "\n".join([
            f"#### Node {s['node']} at {s['speed']:.1f} Hz",
            ", ".join(f"Q{k + 1} = {v}" for k, v in enumerate(q)), "",
            "| feature | model | from the noisy signal |", "|---|---|---|",
            f"| \\|Zf\\| forward 1X | {abs(zf) * 1e6:.2f} µm | {abs(spec.line(1.0)) * 1e6:.2f} µm |",
            f"| \\|Zb\\| backward 1X | {abs(zb) * 1e6:.2f} µm | {abs(spec.line(-1.0)) * 1e6:.2f} µm |",
            f"| fb = \\|Zf\\|/\\|Zb\\| | {abs(zf) / abs(zb):.3f} | "
            f"{abs(spec.line(1.0)) / abs(spec.line(-1.0)):.3f} |",
            f"| orbit angle φ | {phi:.1f}° | |",
            "", f"Damped natural frequencies: {fr} Hz; {'stable' if modal.stable else '**unstable**'} at this speed.",
        ] + self._effect_lines(s))

    @staticmethod
    def _effect_lines(s) -> list[str]:
        effect = s["effect"]
        if effect is None:
            return []
        fb0 = abs(s["zf0"]) / abs(s["zb0"])
        shift = ", ".join(f"bearing {k + 1} ({(a[0] - b[0]) * 1e6:+.1f}, {(a[1] - b[1]) * 1e6:+.1f}) µm"
                          for k, (a, b) in enumerate(zip(s["static"], s["static0"])))
        note = " (modes: the bearings as the effect changes them)" if effect.stage == "bearings" else \
            " (modes: without the effect)"
        return ["", f"**With {plain(effect.title())}**: fb {fb0:.3f} → {abs(s['zf']) / abs(s['zb']):.3f}, "
                    f"φ {math.degrees(s['phi0']):.1f}° → {math.degrees(s['phi']):.1f}° "
                    f"(without the effect → with it); centreline moved {shift}{note}."]

