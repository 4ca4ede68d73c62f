"""Bearing page: what starvation looks like. Pressure and oil-fraction fields under a supply slider,
mid-plane profiles, the shaft-centre locus from starved to flooded, and the eight coefficients vs Q.

Display only: every number comes from `lubeviz.film.explore` through `resources` (frames shared by all
sessions, computed in the background and reused).

Teaching views that do not mislead: one colour means one value at every flow. By default θ is drawn on
0–1 and the pressure on 0 to the largest peak over the slider's range (the colour scale "fixed"); "auto"
lets each field span its own frame, for detail. Axes of the sweep plots span the slider's range from the
start, so the curves fill in without the axes moving.
"""

from __future__ import annotations

import asyncio
import math

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..film.explore import SupplyFrame
from ..identify.fit.result import lubrication_verdict
from ..model.machine import Machine
from ..model.operating import OperatingPoint
from ..progress import Cancelled
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
from .text import plain
from .widgets import quantity_slider

hv.extension("bokeh", logo=False)

EXPLAIN = """
### Starved or flooded: what the oil film does
The journal (shaft) floats on an oil film pumped into the narrow, converging gap by its rotation.
Oil arrives through the **groove at the top** (outlined). Its supply flow **Q** is the input of this
model (the mass-conserving p–θ model, Elrod–Adams): the oil fraction **θ** is 1 where the gap is full
and below 1 where it holds oil streamers and air.

* **Flooded (Q ≥ Q_T)**: the film is complete from the groove to the loaded zone; extra oil raises the
  groove pressure and leaks out of the sides.
* **Starved (Q < Q_T)**: not enough oil reaches the loaded zone, the full-film (pressure) zone shrinks,
  and to carry the same load the journal must sink deeper: the **eccentricity grows** and the minimum
  film gets thinner. The stiffness and damping the rotor feels change with it, which is what the
  identification reads from the vibration.

Drag the slider from flooded down to starved and watch the pressure zone shrink and the centre drop.
The tick on the slider marks Q_T. With the colour scale *fixed*, a colour means the same pressure or oil
fraction at every Q; *auto* stretches each field over its own range, to see detail.
The dashed curve is what a non-mass-conserving (half-Sommerfeld) model says at the same journal
position: it has no supply flow among its inputs, so it shows the same film at every Q — it cannot starve.
"""

# height as min_height: the pane makes each figure stretch_width; HoloViews' stretch_both (responsive without a
# height) at the first update after would relay the figures out in the browser
FIELD_OPTS = dict(cmap="viridis", colorbar=True, responsive=True, height=260, min_height=260, tools=["hover"],
                  xlabel="α (deg, from the top, in the direction of rotation)", ylabel="z (mm)",
                  framewise=True, toolbar="above")
COEF_COLORS = {"xx": "#1f77b4", "xy": "#ff7f0e", "yx": "#2ca02c", "yy": "#d62728"}
# The chosen button of a toggle (the bearing shown, the colour scale) filled in the header's blue, the others plain:
# Fast's own marking of the chosen one was hardly visible (issue 38).
CHOSEN_CSS = """
.bk-btn-group .bk-btn.bk-active { background-color: #2c5f8a !important; color: #ffffff !important;
  border-color: #2c5f8a !important; font-weight: 600; }
.bk-btn-group .bk-btn:not(.bk-active) { background-color: #ffffff !important; color: #2c5f8a !important; }
"""
VIEW_START_DEG = -90.0  # fields shown over alpha in [-90, 270): the groove (0) and the loaded zone (180) whole
AUTO = (math.nan, math.nan)  # HoloViews' "no limits": the colour or axis range follows the frame
THETA_RANGE = (0.0, 1.0)  # the oil fraction's whole range: 0 (no oil) to 1 (full film)
FILM_RATIO_RANGE = (0.0, 2.0)  # h/c = 1 + ε cos(...) stays within 0-2 for any ε < 1
LOCUS_LIMIT = 1.1  # e/c axes: the whole clearance circle (|e| = c) and a margin
SWEEP_COEF_MIN_PX = 380  # the K and C plots' narrowest width beside the locus (frame, axes, legend at the right)


def nice_ceiling(x: float) -> float:
    """`x` > 0 rounded up to a half or whole unit of its decade (2.33 -> 2.5, 1.39 -> 1.5, 0.47 -> 0.5), so a
    colour bar ends on a round number."""
    step = 10.0 ** math.floor(math.log10(x)) / 2.0
    return math.ceil(x / step - 1e-9) * step


def _view_order(alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    deg = (np.degrees(alpha) - VIEW_START_DEG) % 360.0 + VIEW_START_DEG
    order = np.argsort(deg)
    return deg[order], order


def _groove_box(frame: SupplyFrame, deg: np.ndarray, order: np.ndarray):
    """The groove's outline; `deg`, `order` are those of the field on its uniform grid (on_uniform_grid)."""
    g = frame.on_uniform_grid(frame.groove)[1][:, order]
    cols, rows = np.flatnonzero(g.any(axis=0)), np.flatnonzero(g.any(axis=1))
    if cols.size == 0:
        return hv.Bounds((0, 0, 0, 0))
    da = deg[1] - deg[0]
    dz = (frame.z[1] - frame.z[0]) * 1e3
    return hv.Bounds((deg[cols[0]] - da / 2, frame.z[rows[0]] * 1e3 - dz / 2,
                      deg[cols[-1]] + da / 2, frame.z[rows[-1]] * 1e3 + dz / 2)).opts(
        color="white", line_width=2, line_dash="dashed")


class BearingPage(pn.viewable.Viewer):
    """The Bearing page of one session."""

    bearing = param.Selector(default=0, objects={"Bearing 1": 0},
                             doc="Which bearing of the machine to show")
    colour_scale = param.Selector(
        default="fixed", objects=["fixed", "auto"], label="Colour scale",
        doc="fixed: θ on 0–1 and the pressure on 0 to the largest peak over the slider's range, the same at "
            "every flow (one colour, one value); auto: each field spans its own frame's range")

    def __init__(self, machine: Machine, operating: OperatingPoint, **params):
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.jobs = JobPanel()
        self.sweep_jobs = JobPanel()
        self._q_threshold: dict[tuple[int, float], float] = {}
        self._scales: dict[tuple[int, float], dict[str, float]] = {}  # (bearing, speed) -> fixed ranges (MPa)
        self._loads: dict[int, str] = {}  # bearing -> its static load in words
        self._frame: SupplyFrame | None = None
        self._frame_scaled = False  # the frame shown was drawn on the fixed scale (known by then)
        self._frame_pipe = hv.streams.Pipe(data=None)  # the two fields
        self._detail_pipe = hv.streams.Pipe(data=None)  # profiles and current-Q markers, drawn just after
        self._sweep_pipe = hv.streams.Pipe(data=None)
        self._sliders: dict[int, pn.widgets.Widget] = {}
        self._slider_box = pn.Column(sizing_mode="stretch_width")
        self._summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-bearing-summary"])
        self._error = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width")
        names = {f"Bearing {k + 1} (node {b.node})": k for k, b in enumerate(machine.bearings)}
        self.param.bearing.objects = names
        self._bearing_select = pn.widgets.RadioButtonGroup.from_param(self.param.bearing, button_type="default",
                                                                      stylesheets=[CHOSEN_CSS],
                                                                      css_classes=["lubeviz-bearing-choice"])
        self._scale_select = pn.Row(
            pn.pane.Markdown(f"{self.param.colour_scale.label}:", margin=(0, 5, 0, 10), align="center"),
            pn.widgets.RadioButtonGroup.from_param(self.param.colour_scale, button_type="default",
                                                   description=self.param.colour_scale.doc, align="center",
                                                   stylesheets=[CHOSEN_CSS]),
            css_classes=["lubeviz-colour-scale"])
        self._ready = False
        # The first films are solved while the page's plots are built and sent (about a second on first use).
        self._warm_up = resources.first_films(machine, self.bearing, self.speed, self._q())
        self._layout = self._build()
        self.param.watch(self._on_bearing, "bearing")
        self.param.watch(self._on_colour_scale, "colour_scale")
        self.op.param.watch(self._on_flow, list(self.op.flow_names))
        self.op.param.watch(self._on_speed, "speed")

    # --- layout --------------------------------------------------------------------------------
    def _build(self):
        pressure = hv.DynamicMap(self._pressure_image, streams=[self._frame_pipe])
        theta = hv.DynamicMap(self._theta_image, streams=[self._frame_pipe])
        profile_p = hv.DynamicMap(self._profile_pressure, streams=[self._detail_pipe])
        profile_t = hv.DynamicMap(self._profile_theta, streams=[self._detail_pipe])
        # The sweep curves and the current-Q markers are separate DynamicMaps, so moving the slider
        # redraws only the markers.
        # The plot's size and legend are options of the product of the two DynamicMaps (the overlay drawn),
        # not of the overlays their callbacks return. Legends outside the frames never cover a curve.
        locus = (hv.DynamicMap(self._locus, streams=[self._sweep_pipe])
                 * hv.DynamicMap(self._locus_marker, streams=[self._detail_pipe])).opts(
            frame_width=280, frame_height=280, **plotting.outside_legend("below", cols=2))
        coef = dict(responsive=True, height=245, min_height=245, **plotting.outside_legend("right"))  # as FIELD_OPTS
        coef_k = (hv.DynamicMap(lambda data: self._coefficients(data, "K"), streams=[self._sweep_pipe])
                  * hv.DynamicMap(self._q_line, streams=[self._detail_pipe])).opts(**coef)
        coef_c = (hv.DynamicMap(lambda data: self._coefficients(data, "C"), streams=[self._sweep_pipe])
                  * hv.DynamicMap(self._q_line, streams=[self._detail_pipe])).opts(**coef)
        pane = dict(sizing_mode="stretch_width", linked_axes=False)
        controls = pn.Column(
            "### Bearing", self._bearing_select, self._slider_box, self._scale_select, self._summary, self.jobs,
            self.sweep_jobs, width=330)
        self._pressure_pane = pn.pane.HoloViews(pressure, css_classes=["lubeviz-pressure"], **pane)
        # The fields and the profiles are put on the page with the first film (`_show_first`), which is their first
        # frame: built from empty frames, each was made twice on the server and drawn twice in the browser.
        self._field_panes = [self._pressure_pane, pn.pane.HoloViews(theta, css_classes=["lubeviz-theta"], **pane)]
        self._profile_panes = [pn.pane.HoloViews(profile_p, **pane), pn.pane.HoloViews(profile_t, **pane)]
        fields = self._fields = pn.Column(
            pn.pane.Markdown("Solving the film …", css_classes=["lubeviz-film-waiting"], margin=(10, 10)),
            sizing_mode="stretch_width")
        profiles = self._profiles = pn.Row(sizing_mode="stretch_width")
        # The coefficient plots stacked beside the locus: each as wide as the row allows, so their legends
        # fit at the right of the frames; the locus keeps its square frame (e/c equal on both axes). The row
        # wraps: below SWEEP_COEF_MIN_PX beside the locus (a narrow window) the coefficients go under it.
        self._sweep_plots = [
            pn.pane.HoloViews(locus, css_classes=["lubeviz-locus"], linked_axes=False),
            pn.Column(pn.pane.HoloViews(coef_k, **pane), pn.pane.HoloViews(coef_c, **pane),
                      sizing_mode="stretch_width", styles={"flex": f"1 1 {SWEEP_COEF_MIN_PX}px"})]
        # Drawn only once the film at the current flow is: their Bokeh models (built here, drawn in the
        # browser) would otherwise delay the first fields by about a second.
        self._sweep_box = pn.FlexBox(
            pn.pane.Markdown("*The shaft-centre locus and the coefficients over Q follow the film.*",
                             sizing_mode="stretch_width"),
            flex_wrap="wrap", sizing_mode="stretch_width", css_classes=["lubeviz-sweep"])
        return pn.Column(
            self._error,
            pn.Row(controls, fields, sizing_mode="stretch_width"),
            profiles, self._sweep_box,
            pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
            sizing_mode="stretch_width")

    def _show_sweep_plots(self):
        if self._sweep_box.objects[0] is not self._sweep_plots[0]:
            self._sweep_box.objects = list(self._sweep_plots)

    def __panel__(self):
        return self._layout

    # --- state -------------------------------------------------------------------------------------
    @property
    def speed(self) -> float:
        return self.op.speed

    def _q(self) -> float:
        return self.op.flows[self.bearing]

    async def start(self):
        """Called once the page is shown: Q_T, the first frame, then the whole sweep in the background."""
        if self._ready:
            return
        self._ready = True
        await self._prepare()

    async def _prepare(self):
        k, speed = self.bearing, self.speed
        if self._warm_up is not None:
            pending, self._warm_up = self._warm_up, None
            try:
                await asyncio.wrap_future(pending)
            except Exception as exc:  # noqa: BLE001 - shown on the page; the app keeps serving
                self._fail(exc)
                return
        # On a later bearing or speed, the film at the current flow and the two at the slider's ends (the
        # fixed colour scale) are solved at once, on two threads; the fields are drawn when both are in, so
        # their colours never jump.
        for step in (lambda: self._threshold(k, speed), lambda: self._first_film(k, speed), self._fill_sweep):
            try:
                await step()
            except Cancelled:
                continue  # superseded by a newer request (e.g. the slider moved): go on with the rest
            except Exception as exc:  # noqa: BLE001 - shown on the page; the app keeps serving
                self._fail(exc)
                return

    async def _first_film(self, k: int, speed: float):
        scales = asyncio.ensure_future(self._fixed_scales(k, speed))
        try:
            await self._show_current(before_drawing=scales)
        except Cancelled:
            pass  # a newer flow was asked for meanwhile: its own request draws it
        await scales
        if self._frame is not None and not self._frame_scaled and self.colour_scale == "fixed":
            self._redraw()  # drawn by that newer request before the fixed scale was known
        self._show_sweep_plots()

    async def _threshold(self, k: int, speed: float):
        if (k, speed) not in self._q_threshold:
            self._q_threshold[(k, speed)] = await self.jobs.run(
                resources.flooded_flow, self.machine, k, speed, label="Q_T", quiet=True)
        self._make_slider(k)

    def _make_slider(self, k: int):
        qt = self._q_threshold[(k, self.speed)]
        grid = resources.frame_grid(qt)  # multiples of FRAME_STEP_MLMIN: the slider moves on round flows
        name = self.op.flow_names[k]
        key = (k, self.speed)
        if key not in self._sliders:
            q = qt if self.op.provisional else getattr(self.op, name)  # a first guess: start at this bearing's Q_T
            setattr(self.op, name, resources.snap(min(max(q, grid[0]), grid[-1])))
            self._sliders[key] = quantity_slider(
                self.op, name, start=float(grid[0]), end=float(grid[-1]),
                step=resources.FRAME_STEP_MLMIN * M3S_PER_MLMIN, format="0",
                label=f"Supply flow Q{k + 1} (ml/min)", sizing_mode="stretch_width",
                css_classes=["lubeviz-supply"], margin=(5, 10, 24, 10), tooltips=False,  # the title shows Q
                stylesheets=[_threshold_tick_css(qt, grid)])
        self._slider_box.objects = [self._sliders[key]]

    async def _fixed_scales(self, k: int, speed: float):
        """The fixed colour and axis ranges of this bearing and speed, from the films at both ends of the
        slider's range. The peak pressure is largest at one end: starving shrinks the pressure zone that
        carries the same load, over-supply pressurizes the groove. Checked over the whole range for the
        paper's machine at 75 Hz (both bearings): 2.33 MPa at 140 ml/min, falling to 1.10 MPa near
        640 ml/min (above Q_T = 545), rising again to 1.39 MPa at 1090 ml/min: the most starved end holds
        the peak, not the flooded one. Should a frame of the sweep exceed these, `_send_sweep` widens them once."""
        if (k, speed) in self._scales:
            return
        grid = resources.frame_grid(self._q_threshold[(k, speed)])
        ends = [float(grid[0]), float(grid[-1])]
        got = await self.sweep_jobs.run(
            resources.frames, self.machine, k, speed, ends, quiet=True,
            label=f"colour scale: film at {ends[0] / M3S_PER_MLMIN:.0f} and {ends[1] / M3S_PER_MLMIN:.0f} ml/min")
        self._scales[(k, speed)] = _scales_of(got.values())

    async def _show_current(self, before_drawing=None):
        """Draw the film at the current flow; `before_drawing`, an awaitable to finish first (the fixed scales)."""
        k, speed, q = self.bearing, self.speed, resources.snap(self._q())
        store = resources.cached_frames(self.machine, k, speed)
        frame = store.get(q)
        if frame is None:
            got = await self.jobs.run(resources.frames, self.machine, k, speed, [q],
                                      label=f"film at {q / M3S_PER_MLMIN:.0f} ml/min", quiet=True)
            frame = got[q]
        if before_drawing is not None:
            await asyncio.shield(before_drawing)
        if (k, speed) != (self.bearing, self.speed) or resources.snap(self._q()) != q:
            return  # the user moved on meanwhile; a newer request shows its own frame
        self._frame = frame
        self._frame_scaled = (k, speed) in self._scales
        self._error.visible = False
        # Two steps: the fields reach the browser first (one Bokeh patch for two plots), then the five
        # smaller plots; together they cost 0.35 s in the browser, the fields alone 0.14 s.
        # One walk of the session's models for all seven plots (see plotting.frozen), when the detail is sent.
        # Held over the pause: the fields' patch still leaves at once (a freeze defers only the walk), and one
        # freeze measured 0.33 s per step against 0.38 s for one per pipe (back to back, median of 10 each).
        if self._fields.objects[0] is not self._pressure_pane:
            await self._show_first(frame)
            return
        with plotting.frozen(self._pressure_pane):
            self._frame_pipe.send(frame)
            self._summary.object = self._summary_text(frame)
            await asyncio.sleep(0.02)  # lets the server send the fields' patch on its own
            if self._frame is frame:
                self._detail_pipe.send(frame)

    async def _show_first(self, frame):
        """The first film: the fields and then the profiles put on the page with it as their first frame (nothing
        draws from the pipes before: sending only sets their data)."""
        self._frame_pipe.send(frame)
        self._detail_pipe.send(frame)
        self._summary.object = self._summary_text(frame)
        self._fields.objects = list(self._field_panes)
        await asyncio.sleep(0.02)  # the fields' models leave on their own, as a later film's patch does
        self._profiles.objects = list(self._profile_panes)

    async def _fill_sweep(self):
        k, speed = self.bearing, self.speed
        grid = resources.frame_grid(self._q_threshold[(k, speed)])
        store = resources.cached_frames(self.machine, k, speed)
        missing = [q for q in grid if resources.snap(q) not in store]
        self._show_sweep_plots()
        self._send_sweep()  # what other sessions (or an earlier visit) already computed
        chunk = 12
        for i in range(0, len(missing), chunk):
            if (k, speed) != (self.bearing, self.speed):
                return
            todo = [q for q in missing[i:i + chunk] if resources.snap(q) not in store]
            if todo:  # in a worker process: the sweep is pure Python and would slow the event loop
                new = await self.sweep_jobs.run(
                    resources.compute_frames, self.machine.source, k, speed, todo, process=True,
                    label=f"film over Q: {min(i + chunk, len(missing))}/{len(missing)} flows")
                resources.store_frames(self.machine, k, speed, new)
            self._send_sweep()
        self.sweep_jobs.status = f"{len(grid)} supply flows ready (cached for every session)"

    def _send_sweep(self):
        k, speed = self.bearing, self.speed
        store = resources.cached_frames(self.machine, k, speed)
        qs = sorted(store)
        qt = self._q_threshold.get((k, speed))
        grid = resources.frame_grid(qt) if qt else np.zeros(0)
        self._widen_scales(k, speed, [store[q] for q in qs])
        self._send(self._sweep_pipe, dict(frames=[store[q] for q in qs], q_threshold=qt,
                                   q_range=(float(grid[0]), float(grid[-1])) if len(grid) else None))

    def _widen_scales(self, k: int, speed: float, frames):
        """Raise the fixed ranges to cover `frames` if one exceeds them (not expected: see _fixed_scales)."""
        old = self._scales.get((k, speed))
        if old is None or not frames:
            return
        new = _scales_of(frames)
        if all(new[name] <= old[name] for name in old):
            return
        self._scales[(k, speed)] = {name: max(old[name], new[name]) for name in old}
        if self._frame is not None and self.colour_scale == "fixed":
            self._send(self._frame_pipe, self._frame)
            self._send(self._detail_pipe, self._frame)

    def _send(self, pipe, data):
        """Send `data` to the plots fed by `pipe`, with one walk of the session's models for all of them."""
        with plotting.frozen(self._pressure_pane):
            pipe.send(data)

    def _fail(self, exc: Exception):
        self._error.object = f"**Could not solve the film**: {plain(exc)}"
        self._error.visible = True
        if self._fields.objects[0] is not self._pressure_pane:  # no line that says a film is coming
            self._fields.objects[0].object = "No film solved (see the message above)."

    # --- events --------------------------------------------------------------------------------------
    async def _on_flow(self, event):
        if not self._ready or event.name != self.op.flow_names[self.bearing]:
            return
        try:
            await self._show_current()
        except Cancelled:
            pass
        except Exception as exc:  # noqa: BLE001
            self._fail(exc)

    async def _on_bearing(self, event):
        if self._ready:
            await self._prepare()

    async def _on_speed(self, event):
        if self._ready:
            await self._prepare()

    def _on_colour_scale(self, event):
        self._redraw()

    def _redraw(self):
        if self._frame is not None:
            self._frame_scaled = (self.bearing, self.speed) in self._scales
            self._send(self._frame_pipe, self._frame)
            self._send(self._detail_pipe, self._frame)

    def _fixed(self, name: str) -> tuple[float, float]:
        """The range `name` ("pressure", "profile") on the fixed scale, or AUTO (auto mode, or not known yet)."""
        scales = self._scales.get((self.bearing, self.speed))
        if self.colour_scale != "fixed" or scales is None:
            return AUTO
        return (0.0, scales[name])

    # --- plots -----------------------------------------------------------------------------------------
    def _field(self, frame, values, label, clabel, cmap, clim=AUTO):
        opts = dict(FIELD_OPTS, cmap=cmap, clabel=clabel, clim=clim)  # always given: AUTO resets a fixed one
        if frame is None:  # same element types as below: a DynamicMap must keep one type
            img = hv.Image(np.zeros((2, 2)), bounds=(-90, 0, 270, 70), kdims=["alpha", "z"], vdims=[clabel])
            return (img.opts(title=f"{label}: computing …", **opts) * hv.Bounds((0, 0, 0, 0))).opts(framewise=True)
        alpha, values = frame.on_uniform_grid(values)  # the groove's refined columns at their own width
        deg, order = _view_order(alpha)
        # float32: half the bytes to the browser, far below the plot's colour resolution
        img = hv.Image((deg, frame.z * 1e3, values[:, order].astype(np.float32)), kdims=["alpha", "z"],
                       vdims=[clabel])
        opts["title"] = f"{label} at Q = {frame.q / M3S_PER_MLMIN:.0f} ml/min"
        return (img.opts(**opts) * _groove_box(frame, deg, order)).opts(framewise=True)

    def _pressure_image(self, data):
        f = data
        return self._field(f, None if f is None else f.pressure / 1e6, "Pressure p(α, z)", "p (MPa)", "inferno",
                           clim=self._fixed("pressure"))

    def _theta_image(self, data):
        f = data
        field = self._field(f, None if f is None else f.theta, "Oil fraction θ(α, z)", "θ (–)",
                            "Blues_r", clim=THETA_RANGE if self.colour_scale == "fixed" else AUTO)
        return field * _film_broken_outline(f)

    def _profile_pressure(self, data):
        opts = dict(responsive=True, height=280, min_height=280, framewise=True, **plotting.outside_legend("above"),
                    title="Mid-plane pressure" + ("" if data is None else f" at Q = {data.q / M3S_PER_MLMIN:.0f} ml/min"))
        fixed = dict(ylim=self._fixed("profile"))  # on both curves: framewise would follow the data
        deg, p, hs = [], [], []
        if data is not None:
            deg, order = _view_order(data.alpha)
            p = data.mid_plane()[0][order] / 1e6
            hs = data.half_sommerfeld[order] / 1e6
        return (hv.Curve((deg, p), "α (deg)", "p (MPa)", label="p–θ (mass-conserving)").opts(
                    color="#b2182b", tools=["hover"], **fixed)
                * hv.Curve((deg, hs), "α (deg)", "p (MPa)", label="half-Sommerfeld (ignores Q)").opts(
                    color="gray", line_dash="dashed", **fixed)).opts(**opts)

    def _profile_theta(self, data):
        opts = dict(responsive=True, height=280, min_height=280, xlabel="α (deg)", ylabel="θ and h/c (–)",
                    title="Mid-plane θ and film thickness h/c", framewise=True,
                    **plotting.outside_legend("above"))
        fixed = dict(ylim=FILM_RATIO_RANGE if self.colour_scale == "fixed" else AUTO)
        deg, th, h = [], [], []
        if data is not None:
            deg, order = _view_order(data.alpha)
            th = data.mid_plane()[1][order]
            h = data.film_thickness[order] / data.clearance
        theta = hv.Curve((deg, th), "α (deg)", "θ and h/c (–)", label="θ").opts(
            color="#2166ac", tools=["hover"], **fixed)
        film = hv.Curve((deg, h), "α (deg)", "θ and h/c (–)", label="h/c").opts(
            color="gray", line_dash="dashed", **fixed)
        return (theta * film).opts(**opts)

    def _locus(self, data):
        opts = dict(title="Shaft-centre locus over Q (Y up, gravity down)", framewise=True)
        kd = ["e_X/c (–)", "e_Y/c (–)"]
        t = np.linspace(0, 2 * math.pi, 181)
        circle = hv.Curve((np.cos(t), np.sin(t)), kd[0], kd[1], label="clearance circle (e = c)").opts(
            color=plotting.NEUTRAL, line_width=1)
        data = data or {}
        frames = data.get("frames") or []
        pos, q, qt_pt = np.zeros((0, 2)), np.zeros(0), []
        qt = data.get("q_threshold")
        if frames:
            c = frames[0].clearance
            pos = np.array([f.position for f in frames]) / c
            q = np.array([f.q for f in frames]) / M3S_PER_MLMIN
            if qt:
                qt_pt = [tuple(pos[int(np.argmin(np.abs(q - qt / M3S_PER_MLMIN)))])]
        q_range = data.get("q_range")
        q_lim = AUTO if q_range is None else tuple(v / M3S_PER_MLMIN for v in q_range)
        locus = hv.Curve((pos[:, 0], pos[:, 1]), kd[0], kd[1], label="centre path").opts(color="#555555")
        pts = hv.Points((pos[:, 0], pos[:, 1], q), kd, ["Q (ml/min)"]).opts(
            color="Q (ml/min)", cmap="viridis", size=5, tools=["hover"], colorbar=True, clim=q_lim,
            clabel="Supply flow Q (ml/min)")
        threshold = hv.Points(qt_pt, kd, label=_qt_label(qt)).opts(color=plotting.NEUTRAL, size=12, marker="star")
        box = dict(xlim=(-LOCUS_LIMIT, LOCUS_LIMIT), ylim=(-LOCUS_LIMIT, LOCUS_LIMIT))  # the whole circle, always
        return (circle * locus * pts * threshold).opts(
            hv.opts.Curve(**box), hv.opts.Points(**box), hv.opts.Overlay(**opts))

    def _locus_marker(self, data):
        cur = [] if data is None else [tuple(data.position / data.clearance)]
        return hv.Points(cur, ["e_X/c (–)", "e_Y/c (–)"], label="current Q").opts(
            color=OUTLINE_COLOUR, marker="x", size=14, line_width=3)

    def _q_line(self, data):
        q = [] if data is None else [data.q / M3S_PER_MLMIN]
        return hv.VLines(q, label="current Q").opts(color=OUTLINE_COLOUR, line_width=2)

    def _coefficients(self, data, which):
        unit, scale = ("MN/m", 1e-6) if which == "K" else ("kN·s/m", 1e-3)
        data = data or {}
        q_range = data.get("q_range")
        opts = dict(title=f"{'Stiffness' if which == 'K' else 'Damping'} coefficients (Lund's sign)",
                    framewise=True)
        frames = data.get("frames") or []
        q = np.array([f.q for f in frames]) / M3S_PER_MLMIN
        m = np.array([getattr(f, which) for f in frames]).reshape(-1, 2, 2) * scale
        # x over the slider's range from the start: the curves fill in as the sweep runs, the axis stays
        xlim = AUTO if q_range is None else tuple(v / M3S_PER_MLMIN for v in q_range)
        curves = [hv.Curve((q, m[:, i, j]), "Supply flow Q (ml/min)", f"{which} ({unit})",
                           label=f"{which}{a}").opts(color=COEF_COLORS[a], tools=["hover"], xlim=xlim)
                  for (i, j), a in zip([(0, 0), (0, 1), (1, 0), (1, 1)], COEF_COLORS)]
        qt = data.get("q_threshold")
        # VLines (not VLine): a glyph, so the line has its legend entry with the value
        line = hv.VLines([qt / M3S_PER_MLMIN] if qt else [], label=_qt_label(qt)).opts(
            color=plotting.NEUTRAL, line_dash="dashed", line_width=2)
        return hv.Overlay(curves + [line]).opts(**opts)

    def _load_words(self) -> str:
        """The shown bearing's static load in words (computed once a bearing: on 3+ supports a coupled solve)."""
        if self.bearing not in self._loads:
            try:
                self._loads[self.bearing] = _load_words(resources.bearing_load(self.machine, self.bearing))
            except Exception:  # noqa: BLE001 - the table still shows the film
                return "—"
        return self._loads[self.bearing]

    def _summary_text(self, f: SupplyFrame) -> str:
        s = f.summary
        qt = self._q_threshold.get((self.bearing, self.speed))
        state = ""
        if qt:
            state = {"starved": "**starved**", "over-supplied": "**over-supplied** (groove pressurized)",
                     "normal": "**at the flooded threshold**"}[lubrication_verdict(f.q, qt)]
            state = f"{state}: Q / Q_T = {f.q / qt:.2f}"
        return "\n".join([
            f"#### Q = {f.q / M3S_PER_MLMIN:.0f} ml/min — {state}",
            "| quantity | value |", "|---|---|",
            f"| static load (its share of the rotor's weight) | {self._load_words()} |",
            f"| eccentricity ratio ε | {s.eccentricity_ratio:.3f} |",
            f"| attitude angle φ | {math.degrees(s.attitude_angle):.1f}° |",
            f"| minimum film h_min | {s.min_film * 1e6:.1f} µm |",
            f"| maximum pressure | {s.max_pressure / 1e6:.2f} MPa |",
            f"| cavitated / starved area | {100 * s.cavitated_fraction:.1f} % / {100 * s.starved_fraction:.1f} % |",
            f"| groove pressure | {s.groove_pressure / 1e3:.1f} kPa |",
            f"| side leakage | {s.side_leakage / M3S_PER_MLMIN:.1f} ml/min |",
            f"| friction power loss | {s.power_loss:.0f} W |",
        ])


FULL_FILM = 0.995  # θ above this is a full film: the outline drawn on the θ field is where the film breaks
OUTLINE_COLOUR = "#000000"  # the outline and the current-Q marks: black, no coefficient's colour (COEF_COLORS)


def _film_broken_outline(frame) -> hv.Contours:
    """Where the film breaks (θ < FULL_FILM) as a line over the θ field: near and above Q_T the streamers hold
    θ of 0.9-0.99, which the colour alone shows as almost the full film's white (issue 38)."""
    kd = ["alpha", "z"]
    if frame is None:
        return hv.Contours([], kd, label="film broken (θ < 1)").opts(color=OUTLINE_COLOUR, line_width=1.5)
    alpha, theta = frame.on_uniform_grid(frame.theta)
    deg, order = _view_order(alpha)
    img = hv.Image((deg, frame.z * 1e3, theta[:, order]), kdims=kd, vdims=["theta"])
    lines = hv.operation.contours(img, levels=[FULL_FILM], overlaid=False)
    return hv.Contours(lines.data if lines.data else [], kd, label="film broken (θ < 1)").opts(
        color=OUTLINE_COLOUR, line_width=1.5, line_dash="dotted")


def _load_words(load) -> str:
    """'3273 N, downwards' (or its angle from downwards) for a bearing's static load [Wx, Wy] (N)."""
    w = float(np.hypot(*load))
    lean = math.degrees(math.atan2(float(load[0]), -float(load[1])))
    return f"{w:.0f} N, " + ("downwards" if abs(lean) < 0.5 else f"{abs(lean):.0f}° from downwards towards "
                             f"{'+X' if lean > 0 else '−X'}")


def _qt_label(q_threshold: float | None) -> str:
    return "Q_T" if not q_threshold else f"Q_T = {q_threshold / M3S_PER_MLMIN:.0f} ml/min"


def _scales_of(frames) -> dict[str, float]:
    """Fixed ranges (MPa) covering `frames`: the field's peak pressure, and the profile plot's (the p–θ and
    the half-Sommerfeld mid-plane pressures), each rounded up to a round number."""
    frames = list(frames)
    peak = max(float(f.pressure.max()) for f in frames) / 1e6
    profile = max(peak, max(float(f.half_sommerfeld.max()) for f in frames) / 1e6)
    return {"pressure": nice_ceiling(peak), "profile": nice_ceiling(profile)}


def _threshold_tick_css(q_threshold: float, grid: np.ndarray) -> str:
    """A stylesheet for the supply slider: a tick on its track at Q_T, labelled with the value."""
    at = 100.0 * (q_threshold - grid[0]) / (grid[-1] - grid[0])
    return f"""
.noUi-base::before {{ content: ""; position: absolute; left: {at:.2f}%; top: -5px; width: 2px; height: 18px;
  background: #222; z-index: 0; }}
.noUi-base::after {{ content: "Q_T = {q_threshold / M3S_PER_MLMIN:.0f} ml/min"; position: absolute; left: {at:.2f}%;
  top: 14px; transform: translateX(-50%); font-size: 11px; white-space: nowrap; color: #222; }}
"""
