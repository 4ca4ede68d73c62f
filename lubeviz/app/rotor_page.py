"""Rotor page: the machine to scale, orbits and probe signals at any node, the full spectrum, the mode
shapes and the Campbell diagram on the film bearings at the chosen supply flows.

Display only: responses come from `identify.forward.tabled_response` (bearing K, C from the cached
coefficient tables), modes from `rotor.modal`, the Campbell diagram from `rotor.stability`.
"""

from __future__ import annotations

import math

import holoviews as hv
import numpy as np
import panel as pn
import param

from ..identify.forward import tabled_response
from ..model.machine import Machine
from ..model.operating import OperatingPoint
from ..progress import Cancelled
from ..rotor.elements import DOF_PER_NODE, X, Y
from ..rotor.modal import modal_analysis
from ..rotor.directional import forward_backward_ratio, orbit_angle
from ..signals.noise import add_noise
from ..signals.spectrum import full_spectrum
from ..signals.synthesize import steady_signals
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel
from .widgets import quantity_slider

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
"""

PLOT = dict(tools=["hover"], framewise=True)


class RotorPage(pn.viewable.Viewer):
    """The Rotor page of one session."""

    node = param.Integer(6, bounds=(1, 21), doc="Node (paper numbering) whose orbit, signals and spectrum are shown")
    snr_db = param.Number(12.0, bounds=(-5.0, 60.0), doc="Signal-to-noise ratio of the simulated probes (dB)")
    revolutions = param.Integer(5, bounds=(1, 50), doc="Revolutions shown in the time signals")

    def __init__(self, machine: Machine, operating: OperatingPoint, **params):
        super().__init__(**params)
        self.machine = machine
        self.op = operating
        self.param.node.bounds = (1, machine.n_nodes)
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
        self._ready = False
        self._layout = self._build()
        self.param.watch(self._refresh, ["node", "snr_db", "revolutions"])
        self.op.param.watch(self._refresh, ["q1", "q2"])

    def _build(self):
        widgets = pn.Param(self.param, parameters=["node", "snr_db", "revolutions"], show_name=False,
                           widgets={"node": {"type": pn.widgets.IntSlider, "name": "Node"},
                                    "snr_db": {"type": pn.widgets.FloatSlider, "name": "Probe SNR (dB)"},
                                    "revolutions": {"type": pn.widgets.IntSlider,
                                                    "name": "Revolutions shown"}})
        controls = pn.Column("### Operating point", self._sliders, widgets, self._summary, self.jobs, width=330)
        pane = dict(sizing_mode="stretch_width", linked_axes=False)
        drawing = pn.pane.HoloViews(hv.DynamicMap(self._drawing, streams=[self._pipe]),
                                    css_classes=["lubeviz-machine"], linked_axes=False)
        orbit = pn.pane.HoloViews(hv.DynamicMap(self._orbit, streams=[self._pipe]), width=380,
                                  css_classes=["lubeviz-orbit"], linked_axes=False)
        signals = pn.pane.HoloViews(hv.DynamicMap(self._signals, streams=[self._pipe]), **pane)
        spectrum = pn.pane.HoloViews(hv.DynamicMap(self._spectrum, streams=[self._pipe]),
                                     css_classes=["lubeviz-spectrum"], **pane)
        modes = pn.pane.HoloViews(hv.DynamicMap(self._modes, streams=[self._pipe]), **pane)
        # Replaced whole when computed (the number of tracked modes varies): no DynamicMap here.
        self._campbell_pane = campbell = pn.pane.HoloViews(self._campbell(None), css_classes=["lubeviz-campbell-plot"],
                                                           **pane)
        return pn.Column(
            self._error,
            pn.Row(controls, pn.Column(drawing, pn.Row(orbit, signals, sizing_mode="stretch_width"),
                                       sizing_mode="stretch_width"), sizing_mode="stretch_width"),
            pn.Row(spectrum, modes, sizing_mode="stretch_width"),
            pn.Row(pn.Column(self._campbell_button, self.campbell_jobs, campbell, sizing_mode="stretch_width"),
                   sizing_mode="stretch_width"),
            pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
            sizing_mode="stretch_width")

    def __panel__(self):
        return self._layout

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
        self._sliders.objects = [
            quantity_slider(self.op, name, start=t.q_min, end=t.q_max, step=M3S_PER_MLMIN,
                            label=f"Supply flow Q{k + 1} (ml/min); Q_T = {qt[k] / M3S_PER_MLMIN:.0f}",
                            sizing_mode="stretch_width", css_classes=[f"lubeviz-q{k + 1}"])
            for k, (name, t) in enumerate(zip(("q1", "q2"), self._tables))]
        await self._refresh()

    def _state(self) -> dict:
        """Everything the plots show, for the current flows and node (a few milliseconds)."""
        m, op = self.machine, self.op
        rotor = resources.rotor(m)
        flows = (op.q1, op.q2)
        resp = tabled_response(m, self._tables, flows, rotor=rotor)
        omega = self._tables[0].omega
        k = self.node - 1
        x, y = resp.x[k], resp.y[k]
        speed = omega / (2 * math.pi)
        fs = 64 * speed  # 64 samples per revolution
        n = int(round(fs / speed * 64))  # 64 revolutions for the spectrum
        t = np.arange(n) / fs
        clean = steady_signals(np.array([x]), np.array([y]), omega, t)
        noisy = add_noise(clean, self.snr_db, np.random.default_rng(self._rng_seed + self.node))
        spec = full_spectrum(noisy[0, 0] + 1j * noisy[0, 1], fs, speed)
        coefs = [tab.coefficients(q) for tab, q in zip(self._tables, flows)]
        modal = modal_analysis(rotor, omega, coefs, n_modes=6)
        return dict(resp=resp, node=self.node, x=x, y=y, t=t, clean=clean[0], noisy=noisy[0], fs=fs,
                    speed=speed, spectrum=spec, modal=modal, flows=flows,
                    q_threshold=[tab.q_threshold for tab in self._tables])

    async def _refresh(self, *events):
        if not self._ready or self._tables is None:
            return
        try:
            state = await self.jobs.run(lambda progress: self._state(), label="response", quiet=True)
        except Cancelled:
            return
        except Exception as exc:  # noqa: BLE001
            self._fail(exc)
            return
        self._error.visible = False
        self._pipe.send(state)
        self._summary.object = self._summary_text(state)

    async def _on_campbell(self, event):
        if self._tables is None:
            return
        ratios = tuple(q / t.q_threshold for q, t in zip((self.op.q1, self.op.q2), self._tables))
        speeds = 2 * math.pi * np.linspace(max(self.machine.speed_min, 5.0), self.machine.speed_max, 30)
        key = ("campbell", self.machine.source, tuple(round(r, 3) for r in ratios))
        cached = resources.memo_get(key)
        if cached is None:
            try:
                cached = await self.campbell_jobs.run(resources.compute_stability, self.machine.source, speeds,
                                                      ratios, process=True, label="Campbell diagram")
            except Cancelled:
                return
            except Exception as exc:  # noqa: BLE001
                self._fail(exc)
                return
            resources.memo_put(key, cached)
        self._campbell_pane.object = self._campbell(dict(result=cached, ratios=ratios, speed=self.op.speed))

    def _fail(self, exc: Exception):
        self._error.object = f"**Could not compute the response**: {exc}"
        self._error.visible = True

    # --- plots -------------------------------------------------------------------------------------------
    def _drawing(self, data):
        m = self.machine
        xs = np.concatenate([[0.0], np.cumsum([e.length for e in m.elements])]) * 1e3
        shaft = [(xs[i], -e.diameter / 2e-3, xs[i + 1], e.diameter / 2e-3) for i, e in enumerate(m.elements)]
        discs = [(xs[d.node - 1] - d.width / 2e-3, -d.outer_diameter / 2e-3, xs[d.node - 1] + d.width / 2e-3,
                  d.outer_diameter / 2e-3) for d in m.discs]
        top = max(d[3] for d in discs) if discs else 100.0
        bearings = []
        for b in m.bearings:
            x0 = xs[b.node - 1]
            r = b.radius * 1e3
            bearings += [(x0 - b.length / 2e-3, r, x0 + b.length / 2e-3, r + 25),
                         (x0 - b.length / 2e-3, -r - 25, x0 + b.length / 2e-3, -r)]
        el = (hv.Rectangles(shaft, ["x (mm)", "radius (mm)", "x1", "y1"]).opts(color="#9aa5b1", line_color="black")
              * hv.Rectangles(discs).opts(color="#51606f", line_color="black")
              * hv.Rectangles(bearings).opts(color="#e8a33d", line_color="black"))
        meas = list(m.center_nodes) + list(m.outside_nodes)
        labels = hv.Labels([(xs[n - 1], -top - 40, str(n)) for n in range(1, m.n_nodes + 1)],
                           ["x (mm)", "radius (mm)"], "node").opts(text_font_size="8pt", text_color="gray")
        probes = hv.Points([(xs[n - 1], top + 30) for n in meas], ["x (mm)", "radius (mm)"],
                           label="measurement planes").opts(marker="inverted_triangle", size=10, color="#2c5f8a")
        node = data["node"] if data else self.node
        sel = hv.Points([(xs[node - 1], top + 30)], ["x (mm)", "radius (mm)"], label="node shown").opts(
            marker="inverted_triangle", size=14, color="red")
        unb = hv.Points([(xs[m.unbalance_node - 1], 0.0)], ["x (mm)", "radius (mm)"], label="unbalance").opts(
            marker="star", size=14, color="#d62728")
        return (el * labels * probes * sel * unb).opts(
            title="The machine to scale: shaft, discs, bearings (orange), measurement planes (▼)",
            frame_width=860, data_aspect=1, xlim=(-50.0, xs[-1] + 50.0), ylim=(-top - 70, top + 60),
            show_legend=False, xlabel="axial position x (mm)", ylabel="radius (mm)", framewise=True)

    def _orbit(self, data):
        opts = dict(frame_width=300, frame_height=300, legend_position="bottom_right", framewise=True)
        kd = ["x (µm)", "y (µm)"]
        if not data:
            return (hv.Curve([], *kd) * hv.Scatter([], *kd) * hv.Points([], kd)).opts(title="Orbit", **opts)
        th = np.linspace(0, 2 * math.pi, 181)
        x = (data["x"] * np.exp(1j * th)).real * 1e6
        y = (data["y"] * np.exp(1j * th)).real * 1e6
        n_show = min(data["noisy"].shape[1], 64 * self.revolutions)
        noisy = data["noisy"][:, :n_show] * 1e6
        lim = 1.25 * max(np.abs(noisy).max(), 1e-9)
        return (hv.Scatter((noisy[0], noisy[1]), *kd, label="probes (noisy)").opts(color="#9ecae1", size=3)
                * hv.Curve((x, y), *kd, label="steady orbit").opts(color="#08519c", line_width=2)
                * hv.Points([(x[0], y[0])], kd, label="t = 0 (keyphasor)").opts(color="black", size=8)).opts(
            title=f"Orbit at node {data['node']} (forward: counter-clockwise)", xlim=(-lim, lim), ylim=(-lim, lim),
            **opts)

    def _signals(self, data):
        opts = dict(responsive=True, min_height=340, legend_position="top_right", framewise=True,
                    title="Probe signals")
        if not data:
            return (hv.Curve([], "t (ms)", "displacement (µm)") * hv.Curve([], "t (ms)", "displacement (µm)")).opts(**opts)
        n_show = min(data["noisy"].shape[1], 64 * self.revolutions)
        t = data["t"][:n_show] * 1e3
        nz = data["noisy"][:, :n_show] * 1e6
        return (hv.Curve((t, nz[0]), "t (ms)", "displacement (µm)", label="x (horizontal)").opts(color="#1f77b4")
                * hv.Curve((t, nz[1]), "t (ms)", "displacement (µm)", label="y (vertical)").opts(color="#d62728")
                ).opts(**opts)

    def _spectrum(self, data):
        opts = dict(responsive=True, min_height=320, framewise=True)
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
        opts = dict(responsive=True, min_height=320, legend_position="right", framewise=True,
                    title="Damped mode shapes at the operating speed (horizontal component)")
        if not data:
            return hv.Overlay([hv.Curve([], kd, vd) for _ in range(4)]).opts(**opts)
        m = self.machine
        xs = np.concatenate([[0.0], np.cumsum([e.length for e in m.elements])]) * 1e3
        modal = data["modal"]
        curves = []
        for j in range(min(4, modal.modes.shape[1])):
            shape = modal.modes[:, j]
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

    def _campbell(self, data):
        kd, vd = "shaft speed (Hz)", "damped natural frequency (Hz)"
        opts = dict(responsive=True, min_height=380, legend_position="right", framewise=True,
                    title="Campbell diagram (press the button above; film recomputed at every speed)")
        if not data:
            return hv.Overlay([hv.Curve([], kd, vd)]).opts(**opts)
        res = data["result"].modes
        speeds = res.speeds / (2 * math.pi)
        fr = res.damped_frequencies_hz
        tracks = [hv.Curve((speeds, fr[:, j]), kd, vd, label=f"mode {j + 1}") for j in range(min(8, fr.shape[1]))]
        one_x = hv.Curve((speeds, speeds), kd, vd, label="1X").opts(color="black", line_dash="dashed")
        marks = []
        crit = res.first_critical_speed
        if crit is not None:
            marks.append((crit / (2 * math.pi), crit / (2 * math.pi), "first critical"))
        if res.unstable_mode is not None:
            u = res.unstable_mode
            marks.append((u.speed_hz, u.frequency_hz, "instability threshold"))
        pts = hv.Points([(a, b) for a, b, _ in marks], [kd, vd]).opts(color="red", size=10, marker="x")
        text = "; ".join(f"{name} {a:.1f} Hz" for a, _, name in marks) or "no crossing in range"
        r = "/".join(f"{x:.2f}" for x in data["ratios"])
        return (hv.Overlay(tracks) * one_x * pts * hv.VLine(data["speed"], label="operating speed").opts(
            color="green")).opts(**dict(opts, title=f"Campbell diagram at Q/Q_T = {r}: {text}",
                                        ylim=(0.0, 1.5 * speeds[-1])))

    def _summary_text(self, s) -> str:
        spec = s["spectrum"]
        zf, zb = s["resp"].zf[s["node"] - 1], s["resp"].zb[s["node"] - 1]
        phi = math.degrees(s["resp"].phi[s["node"] - 1])
        modal = s["modal"]
        q = [f"{q / M3S_PER_MLMIN:.0f} ml/min ({q / qt:.2f} Q_T)" for q, qt in zip(s["flows"], s["q_threshold"])]
        fr = ", ".join(f"{f:.1f}" for f in modal.damped_frequencies_hz[:4])
        return "\n".join([
            f"#### Node {s['node']} at {s['speed']:.1f} Hz",
            f"Q1 = {q[0]}, Q2 = {q[1]}", "",
            "| feature | model | from the noisy signal |", "|---|---|---|",
            f"| \\|Zf\\| forward 1X | {abs(zf) * 1e6:.2f} µm | {abs(spec.line(1.0)) * 1e6:.2f} µm |",
            f"| \\|Zb\\| backward 1X | {abs(zb) * 1e6:.2f} µm | {abs(spec.line(-1.0)) * 1e6:.2f} µm |",
            f"| fb = \\|Zf\\|/\\|Zb\\| | {abs(zf) / abs(zb):.3f} | "
            f"{abs(spec.line(1.0)) / abs(spec.line(-1.0)):.3f} |",
            f"| orbit angle φ | {phi:.1f}° | |",
            "", f"Damped natural frequencies: {fr} Hz; {'stable' if modal.stable else '**unstable**'} at this speed.",
        ])

