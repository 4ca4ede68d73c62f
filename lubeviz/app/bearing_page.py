"""Bearing page: what starvation looks like. Pressure and oil-fraction fields under a supply slider,
mid-plane profiles, the shaft-centre locus from starved to flooded, and the eight coefficients vs Q.

Display only: every number comes from `lubeviz.film.explore` through `resources` (frames shared by all
sessions, computed in the background and reused).
"""

from __future__ import annotations

import asyncio
import math

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..film.explore import SupplyFrame
from ..identify.newton import lubrication_verdict
from ..model.machine import Machine
from ..model.operating import OperatingPoint
from ..progress import Cancelled
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
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
The dashed curve is what a non-mass-conserving (half-Sommerfeld) model says at the same journal
position: it has no supply flow among its inputs, so it shows the same film at every Q — it cannot starve.
"""

FIELD_OPTS = dict(cmap="viridis", colorbar=True, responsive=True, min_height=260, tools=["hover"],
                  xlabel="α (deg, from the top, in the direction of rotation)", ylabel="z (mm)",
                  framewise=True, toolbar="above")
COEF_COLORS = {"xx": "#1f77b4", "xy": "#ff7f0e", "yx": "#2ca02c", "yy": "#d62728"}
VIEW_START_DEG = -90.0  # fields shown over alpha in [-90, 270): the groove (0) and the loaded zone (180) whole


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

    bearing = param.Selector(default=0, objects={"Bearing 1": 0, "Bearing 2": 1},
                             doc="Which bearing of the machine to show")

    def __init__(self, machine: Machine, operating: OperatingPoint, **params):
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.jobs = JobPanel()
        self.sweep_jobs = JobPanel()
        self._q_threshold: dict[int, float] = {}
        self._frame: SupplyFrame | None = None
        self._frame_pipe = hv.streams.Pipe(data=None)  # the two fields
        self._detail_pipe = hv.streams.Pipe(data=None)  # profiles and current-Q markers, drawn just after
        self._sweep_pipe = hv.streams.Pipe(data=None)
        self._sliders: dict[int, pn.widgets.Widget] = {}
        self._slider_box = pn.Column(sizing_mode="stretch_width")
        self._summary = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-bearing-summary"])
        self._error = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width")
        names = {f"Bearing {k + 1} (node {b.node})": k for k, b in enumerate(machine.bearings)}
        self.param.bearing.objects = names
        self._bearing_select = pn.widgets.RadioButtonGroup.from_param(self.param.bearing, button_type="primary")
        self._ready = False
        self._layout = self._build()
        self.param.watch(self._on_bearing, "bearing")
        self.op.param.watch(self._on_flow, ["q1", "q2"])
        self.op.param.watch(self._on_speed, "speed")

    # --- layout --------------------------------------------------------------------------------
    def _build(self):
        pressure = hv.DynamicMap(self._pressure_image, streams=[self._frame_pipe])
        theta = hv.DynamicMap(self._theta_image, streams=[self._frame_pipe])
        profile_p = hv.DynamicMap(self._profile_pressure, streams=[self._detail_pipe])
        profile_t = hv.DynamicMap(self._profile_theta, streams=[self._detail_pipe])
        # The sweep curves and the current-Q markers are separate DynamicMaps, so moving the slider
        # redraws only the markers.
        locus = (hv.DynamicMap(self._locus, streams=[self._sweep_pipe])
                 * hv.DynamicMap(self._locus_marker, streams=[self._detail_pipe]))
        coef_k = (hv.DynamicMap(lambda data: self._coefficients(data, "K"), streams=[self._sweep_pipe])
                  * hv.DynamicMap(self._q_line, streams=[self._detail_pipe]))
        coef_c = (hv.DynamicMap(lambda data: self._coefficients(data, "C"), streams=[self._sweep_pipe])
                  * hv.DynamicMap(self._q_line, streams=[self._detail_pipe]))
        pane = dict(sizing_mode="stretch_width", linked_axes=False)
        controls = pn.Column(
            "### Bearing", self._bearing_select, self._slider_box, self._summary, self.jobs, self.sweep_jobs,
            width=330)
        fields = pn.Column(
            pn.pane.HoloViews(pressure, css_classes=["lubeviz-pressure"], **pane),
            pn.pane.HoloViews(theta, css_classes=["lubeviz-theta"], **pane),
            sizing_mode="stretch_width")
        profiles = pn.Row(pn.pane.HoloViews(profile_p, **pane), pn.pane.HoloViews(profile_t, **pane),
                          sizing_mode="stretch_width")
        sweep = pn.Row(pn.pane.HoloViews(locus, css_classes=["lubeviz-locus"], width=380, linked_axes=False),
                       pn.pane.HoloViews(coef_k, **pane), pn.pane.HoloViews(coef_c, **pane),
                       sizing_mode="stretch_width")
        return pn.Column(
            self._error,
            pn.Row(controls, fields, sizing_mode="stretch_width"),
            profiles, sweep,
            pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
            sizing_mode="stretch_width")

    def __panel__(self):
        return self._layout

    # --- state -------------------------------------------------------------------------------------
    @property
    def speed(self) -> float:
        return self.op.speed

    def _q(self) -> float:
        return self.op.q1 if self.bearing == 0 else self.op.q2

    async def start(self):
        """Called once the page is shown: Q_T, the first frame, then the whole sweep in the background."""
        if self._ready:
            return
        self._ready = True
        await self._prepare()

    async def _prepare(self):
        k, speed = self.bearing, self.speed
        for step in (lambda: self._threshold(k, speed), self._show_current, self._fill_sweep):
            try:
                await step()
            except Cancelled:
                continue  # superseded by a newer request (e.g. the slider moved): go on with the rest
            except Exception as exc:  # noqa: BLE001 - shown on the page; the app keeps serving
                self._fail(exc)
                return

    async def _threshold(self, k: int, speed: float):
        if (k, speed) not in self._q_threshold:
            self._q_threshold[(k, speed)] = await self.jobs.run(
                resources.flooded_flow, self.machine, k, speed, label="Q_T", quiet=True)
        self._make_slider(k)

    def _make_slider(self, k: int):
        qt = self._q_threshold[(k, self.speed)]
        grid = resources.frame_grid(qt)
        name = "q1" if k == 0 else "q2"
        key = (k, self.speed)
        if key not in self._sliders:
            setattr(self.op, name, resources.snap(min(max(getattr(self.op, name), grid[0]), grid[-1])))
            self._sliders[key] = quantity_slider(
                self.op, name, start=float(grid[0]), end=float(grid[-1]),
                step=resources.FRAME_STEP_MLMIN * M3S_PER_MLMIN,
                label=f"Supply flow Q{k + 1} (ml/min); Q_T = {qt / M3S_PER_MLMIN:.0f}",
                sizing_mode="stretch_width", css_classes=["lubeviz-supply"])
        self._slider_box.objects = [self._sliders[key]]

    async def _show_current(self):
        k, speed, q = self.bearing, self.speed, resources.snap(self._q())
        store = resources.cached_frames(self.machine, k, speed)
        frame = store.get(q)
        if frame is None:
            got = await self.jobs.run(resources.frames, self.machine, k, speed, [q],
                                      label=f"film at {q / M3S_PER_MLMIN:.0f} ml/min", quiet=True)
            frame = got[q]
        if (k, speed) != (self.bearing, self.speed) or resources.snap(self._q()) != q:
            return  # the user moved on meanwhile; a newer request shows its own frame
        self._frame = frame
        self._error.visible = False
        # Two steps: the fields reach the browser first (one Bokeh patch for two plots), then the five
        # smaller plots; together they cost 0.35 s in the browser, the fields alone 0.14 s.
        self._frame_pipe.send(frame)
        self._summary.object = self._summary_text(frame)
        await asyncio.sleep(0.02)  # lets the server send the fields' patch on its own
        if self._frame is frame:
            self._detail_pipe.send(frame)

    async def _fill_sweep(self):
        k, speed = self.bearing, self.speed
        grid = resources.frame_grid(self._q_threshold[(k, speed)])
        store = resources.cached_frames(self.machine, k, speed)
        missing = [q for q in grid if resources.snap(q) not in store]
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
        self._sweep_pipe.send(dict(frames=[store[q] for q in qs], q_threshold=self._q_threshold.get((k, speed))))

    def _fail(self, exc: Exception):
        self._error.object = f"**Could not solve the film**: {exc}"
        self._error.visible = True

    # --- events --------------------------------------------------------------------------------------
    async def _on_flow(self, event):
        if not self._ready or event.name != ("q1" if self.bearing == 0 else "q2"):
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

    # --- plots -----------------------------------------------------------------------------------------
    def _field(self, frame, values, label, clabel, cmap, clim=None):
        opts = dict(FIELD_OPTS, cmap=cmap, clabel=clabel)
        if clim is not None:
            opts["clim"] = clim
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
        return self._field(f, None if f is None else f.pressure / 1e6, "Pressure p(α, z)", "p (MPa)", "inferno")

    def _theta_image(self, data):
        f = data
        return self._field(f, None if f is None else f.theta, "Oil fraction θ(α, z) (1: full film)", "θ (–)",
                           "Blues_r")

    def _profile_pressure(self, data):
        opts = dict(responsive=True, min_height=220, framewise=True, legend_position="top_left",
                    title="Mid-plane pressure" + ("" if data is None else f" at Q = {data.q / M3S_PER_MLMIN:.0f} ml/min"))
        deg, p, hs = [], [], []
        if data is not None:
            deg, order = _view_order(data.alpha)
            p = data.mid_plane()[0][order] / 1e6
            hs = data.half_sommerfeld[order] / 1e6
        return (hv.Curve((deg, p), "α (deg)", "p (MPa)", label="p–θ (mass-conserving)").opts(
                    color="#b2182b", tools=["hover"])
                * hv.Curve((deg, hs), "α (deg)", "p (MPa)", label="half-Sommerfeld (ignores Q)").opts(
                    color="gray", line_dash="dashed")).opts(**opts)

    def _profile_theta(self, data):
        opts = dict(responsive=True, min_height=220, xlabel="α (deg)", ylabel="θ and h/c (–)",
                    title="Mid-plane oil fraction θ and film thickness h/c", framewise=True,
                    legend_position="top_right")
        deg, th, h = [], [], []
        if data is not None:
            deg, order = _view_order(data.alpha)
            th = data.mid_plane()[1][order]
            h = data.film_thickness[order] / data.clearance
        theta = hv.Curve((deg, th), "α (deg)", "θ and h/c (–)", label="θ").opts(color="#2166ac", tools=["hover"])
        film = hv.Curve((deg, h), "α (deg)", "θ and h/c (–)", label="h/c").opts(color="gray", line_dash="dashed")
        return (theta * film).opts(**opts)

    def _locus(self, data):
        opts = dict(frame_width=300, frame_height=300, title="Shaft-centre locus (Y up, gravity down)",
                    legend_position="bottom_left", framewise=True)
        kd = ["e_X / c", "e_Y / c"]
        t = np.linspace(0, 2 * math.pi, 181)
        circle = hv.Curve((np.cos(t), np.sin(t)), kd[0], kd[1], label="clearance").opts(color="black", line_width=1)
        frames = (data or {}).get("frames") or []
        pos, q, qt_pt = np.zeros((0, 2)), np.zeros(0), []
        if frames:
            c = frames[0].clearance
            pos = np.array([f.position for f in frames]) / c
            q = np.array([f.q for f in frames]) / M3S_PER_MLMIN
            qt = data.get("q_threshold")
            if qt:
                qt_pt = [tuple(pos[int(np.argmin(np.abs(q - qt / M3S_PER_MLMIN)))])]
        locus = hv.Curve((pos[:, 0], pos[:, 1]), kd[0], kd[1], label="locus").opts(color="#555555")
        pts = hv.Points((pos[:, 0], pos[:, 1], q), kd, ["Q (ml/min)"]).opts(
            color="Q (ml/min)", cmap="viridis", size=4, tools=["hover"])
        threshold = hv.Points(qt_pt, kd, label="Q_T").opts(color="black", size=12, marker="star")
        lim = max(0.3, float(np.abs(pos).max()) * 1.3) if len(pos) else 1.05
        box = dict(xlim=(-lim, lim), ylim=(-lim, lim))  # on every layer: framewise would zoom out to the circle
        return (circle * locus * pts * threshold).opts(
            hv.opts.Curve(**box), hv.opts.Points(**box), hv.opts.Overlay(**opts))

    def _locus_marker(self, data):
        cur = [] if data is None else [tuple(data.position / data.clearance)]
        return hv.Points(cur, ["e_X / c", "e_Y / c"], label="current Q").opts(color="red", size=10)

    def _q_line(self, data):
        q = math.nan if data is None else data.q / M3S_PER_MLMIN
        return hv.VLine(q, label="current Q").opts(color="red")

    def _coefficients(self, data, which):
        unit, scale = ("MN/m", 1e-6) if which == "K" else ("kN·s/m", 1e-3)
        opts = dict(responsive=True, min_height=340,
                    title=f"{'Stiffness' if which == 'K' else 'Damping'} coefficients (Lund's sign)",
                    legend_position="right", framewise=True)
        frames = (data or {}).get("frames") or []
        q = np.array([f.q for f in frames]) / M3S_PER_MLMIN
        m = np.array([getattr(f, which) for f in frames]).reshape(-1, 2, 2) * scale
        curves = [hv.Curve((q, m[:, i, j]), "supply flow Q (ml/min)", f"{which} ({unit})",
                           label=f"{which}{a}").opts(color=COEF_COLORS[a], tools=["hover"])
                  for (i, j), a in zip([(0, 0), (0, 1), (1, 0), (1, 1)], COEF_COLORS)]
        qt = (data or {}).get("q_threshold") or math.nan
        line = hv.VLine(qt / M3S_PER_MLMIN, label="Q_T").opts(color="black", line_dash="dashed")
        return hv.Overlay(curves + [line]).opts(**opts)

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
            f"| eccentricity ratio ε | {s.eccentricity_ratio:.3f} |",
            f"| attitude angle | {math.degrees(s.attitude_angle):.1f}° |",
            f"| minimum film h_min | {s.min_film * 1e6:.1f} µm |",
            f"| maximum pressure | {s.max_pressure / 1e6:.2f} MPa |",
            f"| cavitated / starved area | {100 * s.cavitated_fraction:.1f} % / {100 * s.starved_fraction:.1f} % |",
            f"| groove pressure | {s.groove_pressure / 1e3:.1f} kPa |",
            f"| side leakage | {s.side_leakage / M3S_PER_MLMIN:.1f} ml/min |",
            f"| friction power loss | {s.power_loss:.0f} W |",
        ])

