"""Identify page: upload a measured record, see its signals, orbits and full spectra, identify every unknown supply
flow with its uncertainty and a verdict, compare model and measured features, export the result.

Display only: reading (`signals.records.read_record_bytes`), features (`identify.forward.measured.measure`),
the search (`api.identify_record`) and the export (`identify.output.export.result_dict`/`result_csv`)
are the headless package's.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from pathlib import Path

import holoviews as hv
import numpy as np
import pandas as pd
import panel as pn

from ..errors import LubevizError
from ..api import identify_record
from ..identify.batch import OIL_ASSUMED, check_model_speed, model_speed
from ..identify.output.export import feature_unit, result_csv, result_dict
from ..identify.fit.least_squares import Z95
from ..identify.forward.measured import measure
from ..identify.fit.settings import IdentificationSettings
from ..model.machine import Machine
from ..progress import Cancelled
from ..signals.records import MAX_RECORD_BYTES, read_record_bytes
from ..signals.spectrum import full_spectrum
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel, stopped_words
from .session import SessionState
from .text import TABLE_CSS, badge, file_label, plain, signs, table_html, truth_words, without_upload_dirs
from .widgets import RecordDropper, not_loaded_message, record_warnings_markdown, refused_message

hv.extension("bokeh", logo=False)

SAMPLE = Path(__file__).resolve().parents[2] / "assets" / "sample_record.csv"  # the paper's machine
SAMPLES_DIR = SAMPLE.parent / "samples"  # one per shipped example machine, named as its model file
SAMPLE_FRACTIONS = (0.8, 1.2, 1.0, 0.9, 1.3, 0.7)  # a machine without a sample file: flows simulated at these x Q_T
UPLOAD_LIMIT_MB = 50  # the browser refuses larger files before sending them (the reader allows more from disk)

EXPLAIN = f"""
### Identify the supply flows from a record
Upload a record of shaft vibration at one steady speed: the machine's measurement planes, each with two
proximity probes (CSV, NumPy `.npz` or MATLAB `.mat`). A CSV record starts with its header lines
`# speed_hz: 75`, `# sample_rate_hz: 10000` and `# units: um`, then one column per probe, `x1, y1, x2, y2, …`
(plane 1's X and Y probes first), one row per sample. Files up to {UPLOAD_LIMIT_MB} MB.
Or load the machine's sample record (for the paper's machine: bearings fed 420 and 600 ml/min, 12 dB noise;
for the other shipped machines a record made by direct film solves; for an uploaded machine one simulated by
the identification's own model at 0.8, 1.2, 1.0 … × Q_T).

**Best mode** (default) searches the whole flow box and fits all the orbit's invariants, weighted by the
noise measured in the record and the model's own uncertainty; each flow gets a 95 % interval, and the χ²
test says whether the model explains the record at all.
**Paper mode** is the method of the paper (Eq. 11 errors, Newton from 3 × 3 starts). The search paths are
drawn on the Maps page, which opens on the session's record.
"""


OIL_NOTE = ("_The flows assume the oil is as viscous as the model file declares: one record at one speed cannot tell "
            "hotter oil from more oil. An oil temperature in the record, the static shaft position (the probes' DC "
            "gap) or records at other speeds check it._")


def sample_file(machine) -> Path | None:
    """The sample record shipped for `machine` (a model file of `models/`), or None."""
    from ..model.parts import MODELS_DIR

    source = Path(machine.source)
    if source.parent.resolve() != MODELS_DIR.resolve():
        return None
    path = SAMPLE if source.stem == "paper_machine" else SAMPLES_DIR / f"{source.stem}.csv"
    return path if path.exists() else None


def verdict_text(r, k: int) -> str:
    """Bearing k's verdict as far as the record supports it: the verdict at both ends of the flow's 95 %
    interval (an open upper end counts as over-supplied); 'starved or normal' when the interval spans the
    band around Q_T; marked uncertain when the model does not explain the record."""
    from ..identify.fit.result import verdict_over_interval

    v = r.verdict(k)
    ends = verdict_over_interval(r.q[k], None if r.intervals is None else r.intervals[k], r.q_threshold[k])
    if ends[0] != ends[1]:
        return f"{badge(ends[0])} to {badge(ends[1])} (the interval spans the band around Q_T)"
    text = badge(v)
    return text + " (uncertain: the model does not explain the record)" if r.model_explains_data is False else text


class IdentifyPage(pn.viewable.Viewer):
    """The Identify page of one session."""

    def __init__(self, machine: Machine, state: SessionState, **params):
        super().__init__(**params)
        self.machine = machine
        self.state = state
        self.settings = IdentificationSettings(name="identification")
        self.jobs = JobPanel()
        self._item = None
        self._record_name: str | None = None  # what the page calls the record on screen (file or sample)
        self._upload = RecordDropper(
            accepted_filetypes=[".csv", ".npz", ".mat", "text/csv", "application/octet-stream"],
            max_file_size=f"{UPLOAD_LIMIT_MB}MB", limit_bytes=UPLOAD_LIMIT_MB * 1_000_000,
            sizing_mode="stretch_width", css_classes=["lubeviz-upload"])
        self._upload.param.watch(self._on_upload, "upload")
        self._upload.param.watch(self._on_refused, "refused")
        self._sample = pn.widgets.Button(name="Load the sample record", button_type="default",
                                         css_classes=["lubeviz-sample"])
        self._sample.on_click(self._on_sample)
        self._run = pn.widgets.Button(name="Identify the supply flows", button_type="primary", disabled=True,
                                      css_classes=["lubeviz-identify"])
        self._run.on_click(self._on_run)
        self._to_diagnose = pn.widgets.Button(name="Diagnose this record", button_type="default", disabled=True,
                                              description="Open the Diagnose page and look for what the model lacks "
                                                          "in this record", css_classes=["lubeviz-diagnose-this"])
        self._to_diagnose.on_click(self._on_to_diagnose)
        self._record_info = pn.pane.Markdown("No record yet.", sizing_mode="stretch_width",
                                             css_classes=["lubeviz-record-info"])
        self._message = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width",
                                      css_classes=["lubeviz-upload-error"])
        self._record_warnings = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width",
                                              css_classes=["lubeviz-record-warnings"])
        self._result = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-result"])
        self._warning = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width",
                                      css_classes=["lubeviz-model-warning"])
        # Holds the features' table, made afresh for each result (plain HTML: see text.table_html).
        self._features = pn.Column(sizing_mode="stretch_width")
        self._download_json = pn.widgets.FileDownload(callback=self._export_json, filename="identification.json",
                                                      label="Export JSON", button_type="success", disabled=True,
                                                      css_classes=["lubeviz-export-json"])
        self._download_csv = pn.widgets.FileDownload(callback=self._export_csv, filename="identification.csv",
                                                     label="Export CSV", button_type="success", disabled=True)
        self._signals = pn.pane.HoloViews(None, sizing_mode="stretch_width", linked_axes=False)
        # The planes' orbits in a wrapping row: side by side while they fit, one above the other in a narrow window.
        self._orbits = pn.FlexBox(flex_wrap="wrap", css_classes=["lubeviz-record-orbits"])
        self._spectra = pn.pane.HoloViews(None, sizing_mode="stretch_width", linked_axes=False,
                                          css_classes=["lubeviz-record-spectra"])
        settings = pn.Param(self.settings.param, parameters=["mode", "include_model_error", "max_iterations"],
                            show_name=False)
        controls = pn.Column("### Record", self._upload, self._sample, self._record_info, "### Identification",
                             settings, self._run, self.jobs, pn.Row(self._download_json, self._download_csv),
                             self._to_diagnose, width=340)
        results = pn.Column(self._message, self._record_warnings, self._result, self._warning, self._features,
                            sizing_mode="stretch_width")
        self._layout = pn.Column(
            # the results below the controls in a narrow window
            pn.FlexBox(controls, pn.Column(results, self._orbits, sizing_mode="stretch_width", min_width=420,
                                           styles={"flex": "1 1 420px"}), flex_wrap="wrap"),
            self._spectra, self._signals, pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"),
            sizing_mode="stretch_width")
        self.state.param.watch(self._on_record, "record")
        self._on_record()  # a record loaded on the Diagnose page before this page was first opened

    def __panel__(self):
        return self._layout

    # --- loading ----------------------------------------------------------------------------------------
    def _show_error(self, text: str):
        """The page's one place for a failure (the job status would repeat it: cleared)."""
        self._message.object = text
        self._message.visible = True
        self.jobs.status = ""

    def _not_loaded(self, filename: str, problem: str, read: bool = False):
        """`read`: the file was read (a job that may have stopped another: then said); else refused before that."""
        self._show_error(not_loaded_message(filename, problem, self._record_name)
                         + (stopped_words(self.jobs) if read else ""))

    async def _load(self, content, filename: str, name: str | None = None) -> bool | None:
        """Read and show a record; `name` is what the page calls it (default: the file's name).
        True when loaded, False when rejected (the message says why), None when superseded or cancelled."""
        self._message.visible = False
        try:
            record, measured = await self.jobs.run(self._read, content, filename, label=f"reading {filename}",
                                                   quiet=True, tell_stopped=True)
        except Cancelled:
            return None
        except LubevizError as exc:
            self._not_loaded(filename, without_upload_dirs(exc), read=True)
            return False
        except Exception as exc:  # noqa: BLE001 - never let a bad upload stop the app
            self._not_loaded(filename, f"{filename}: unexpected problem ({type(exc).__name__}): "
                                       f"{without_upload_dirs(exc)}", read=True)
            return False
        self._use(record, measured, name or filename)
        return True

    def _use(self, record, measured, name: str) -> None:
        """Make a record read or simulated here the session's (every page shows it: `_on_record`)."""
        self.state.use(record, measured, name, loaded_on="Identify")

    def _on_record(self, *events) -> None:
        """Show the session's record, loaded here or on the Diagnose page, and drop the last one's results."""
        state = self.state
        record, measured = state.record, state.measured
        if record is None:
            return
        self._record_name = state.record_name
        if state.loaded_on != "Identify":
            self._message.visible = False  # a failed upload here is not about the record now shown
        self._item = None
        self._result.object = ""
        self._warning.visible = False
        self._features.objects = []
        self._download_json.disabled = self._download_csv.disabled = True
        self._run.disabled = False
        self._to_diagnose.disabled = False
        self._record_info.object = self._info(record, measured)
        self._record_warnings.object = record_warnings_markdown(record, self.machine)
        self._record_warnings.visible = bool(self._record_warnings.object)
        self._draw_record(record, measured)

    def _on_to_diagnose(self, event) -> None:
        """Open the Diagnose page on the session's record and diagnose it there (no second upload)."""
        if self.state.record is None:
            return
        self.state.diagnosis_asked = True
        self.state.ask("Diagnose")

    def _read(self, content, filename, progress):
        record = read_record_bytes(content, filename, **self.machine.record_defaults())
        return record, measure(record)

    async def _on_upload(self, event):
        if event.new is None:
            return
        filename, content = event.new  # every drop, the same file again included
        filename = file_label(filename)  # the base name, shortened: never a path on the page
        size = len(content) if content is not None else 0
        if size > MAX_RECORD_BYTES:
            self._not_loaded(filename, f"{filename}: {size / 1e6:.1f} MB is too large")
            self._upload.rejected = True
            return
        loaded = await self._load(content, filename)
        if loaded is not None:
            self._upload.rejected = not loaded

    def _on_refused(self, event):
        if event.new is not None:
            self._not_loaded(file_label(event.new[0]), refused_message(*event.new, UPLOAD_LIMIT_MB))

    async def _on_sample(self, event):
        path = sample_file(self.machine)
        if path is not None:
            await self._load(path.read_bytes(), path.name, name=f"sample record ({path.name})")
            return
        self._message.visible = False
        try:
            record, measured = await self.jobs.run(self._simulated_sample, label="simulating a sample record",
                                                   tell_stopped=True)
        except Cancelled:
            return
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._show_error(f"**No sample.** {plain(exc)}")
            return
        self._use(record, measured, record.source)

    def _simulated_sample(self, progress):
        """A record of a machine that ships no sample: the model's own (the chain), at SAMPLE_FRACTIONS of Q_T."""
        from ..identify.forward.chain import simulate

        m = self.machine
        planes = m.measurement_planes
        chain = resources.chain(m, m.operating_speed, [p.node for p in planes], [p.probe_angles_deg for p in planes],
                                progress=progress)
        theta = chain.start()
        theta[:chain.n_flows] = [SAMPLE_FRACTIONS[k % len(SAMPLE_FRACTIONS)] * q
                                 for k, q in enumerate(chain.q_threshold)]
        record = simulate(chain, theta, snr_db=12.0, rng=np.random.default_rng(1))
        flows = ", ".join(f"{q / M3S_PER_MLMIN:.0f}" for q in theta[:chain.n_flows])
        record = dataclasses.replace(record, source=f"simulated sample ({flows} ml/min, the model's own)")
        return record, measure(record)

    def _info(self, record, measured) -> str:
        n = record.displacement.shape[-1]
        dur = n / record.sample_rate_hz
        snr = measured.line_snr
        lines = [
            f"**{plain(self._record_name)}**" + ("" if self.state.loaded_on in (None, "Identify") else
                                                 f" (loaded on the {self.state.loaded_on} page)"), "",
            f"speed {record.speed_hz:g} Hz; {record.sample_rate_hz:g} samples/s; {dur:.2f} s "
            f"({dur * record.speed_hz:.0f} revolutions)", "",
            f"{len(record.nodes)} planes at nodes {', '.join(str(n) for n in record.nodes)}; probes at "
            + ", ".join(f"{a[0]:g}°/{a[1]:g}°" for a in record.probe_angles_deg), "",
            "1X lines over noise: forward " + "/".join(f"{v:.0f}" for v in snr[:, 0]) + ", backward "
            + "/".join(f"{v:.0f}" for v in snr[:, 1]) + " σ",
        ]
        truth = self.state.truth
        if truth:
            lines += ["", truth_words(truth, self.machine)]
        return "\n".join(lines)

    # --- identification ---------------------------------------------------------------------------------
    async def _on_run(self, event):
        if self.state.record is None:
            return
        record, measured, name = self.state.record, self.state.measured, self._record_name
        settings = IdentificationSettings(**{k: getattr(self.settings, k) for k in self.settings.param
                                             if k != "name"})
        self._message.visible = False
        self._run.disabled = True
        try:
            item = await self.jobs.run(self._identify, record, measured, settings, label="identification")
        except Cancelled:
            return
        except LubevizError as exc:
            self._show_error(f"**No identification.** {plain(exc)}")
            return
        except Exception as exc:  # noqa: BLE001
            self._show_error(f"**No identification**: unexpected problem: {plain(exc)}")
            return
        finally:
            self._run.disabled = False
        self._item = item
        self.state.settings = settings
        self.state.identification = item.result
        self._download_json.disabled = self._download_csv.disabled = False
        self._show_result(item, name)

    def _identify(self, record, measured, settings, progress):
        speed = model_speed(self.machine, record)
        check_model_speed(self.machine, speed)
        if settings.mode == "paper":  # the paper's method: two bearings, its table model
            model = resources.forward_model(self.machine, speed, record.nodes, progress=progress)
            return identify_record(record, self.machine, settings, model=model, measured=measured, progress=progress)
        return identify_record(record, self.machine, settings, tables=resources.tables(self.machine, speed, progress),
                               measured=measured, progress=progress)

    def _show_result(self, item, name: str):
        r = item.result
        oil_note = any(w.startswith(OIL_ASSUMED) for w in r.warnings)
        flows = [p for p in r.params if p.is_flow]
        qt = r.q_threshold / M3S_PER_MLMIN
        lines = [f"### Identified supply flows of {plain(name)}",
                 "| bearing | flow | 95 % interval (noise and model) | Q_T | Q / Q_T | verdict |",
                 "|---|---|---|---|---|---|"]
        for k, p in enumerate(flows):
            iv = p.interval
            if iv is not None:
                digits = 0 if qt[k] >= 100 else 1  # a bearing fed tens of ml/min: its interval in tenths
                hi = "open (flooded: more oil changes nothing measurable)" if iv[1] is None else f"{iv[1]:.{digits}f}"
                interval = f"{iv[0]:.{digits}f} – {hi} ml/min"
            else:
                interval = "—" if p.std is None else f"± {Z95 * p.std:.1f} ml/min"
            lines.append(f"| {k + 1} (node {self.machine.bearings[k].node}) | **Q{k + 1} = {p.value:.1f} ml/min** | "
                         f"{interval} | {qt[k]:.0f} ml/min | {p.value / qt[k]:.2f} | {verdict_text(r, k)} |")
        others = [p for p in r.params if not p.is_flow]
        for owner in dict.fromkeys(p.owner for p in others):
            lines.append(f"\n**{plain(owner)}**: " + "; ".join(plain(p.text()) for p in others if p.owner == owner))
        lines.append("")
        # best mode's count is every Levenberg-Marquardt step over its starts and refinements; the page's "Newton
        # iterations per start" bounds paper mode's only (issue 38: "Max iterations 15" beside "101 iterations")
        steps = (f"{r.iterations} Newton iterations (at most {self.settings.max_iterations} per start)"
                 if r.mode == "paper" else f"{r.iterations} Levenberg-Marquardt steps over all starts")
        extra = f"{r.mode} mode; {'converged' if r.converged else '**not converged**'}: {steps}, " \
                f"{r.starts_tried} start(s), {r.evaluations} model evaluations, {r.seconds * 1e3:.0f} ms."
        if r.chi2 is not None:
            extra += f" χ² = {r.chi2:.1f} for {r.dof} degrees of freedom (p = {r.p_value:.3g})."
        lines.append(extra)
        if oil_note:  # true of every record at one speed without the static position: a note, not a warning
            lines += ["", OIL_NOTE]
        self._result.object = "\n".join(lines)
        warn = []
        if r.model_explains_data is False:
            warn.append(f"**The model does not explain this record** (p < {r.level:g}, noise and model uncertainty "
                        "included): the flows above are the best fit of a model that misses something, and their "
                        "intervals are widened by it. The **Diagnose** page traces what is missing.")
        for w in r.warnings:
            if not w.startswith(("the model does not explain", "not unique", OIL_ASSUMED)):
                warn.append(plain(signs(w[0].upper() + w[1:] + ".")))
        if not r.unique:
            alt = "; ".join(" / ".join(f"{q / M3S_PER_MLMIN:.0f}" for q in a[:len(flows)]) + " ml/min"
                            for a in r.alternatives)
            warn.append(f"**Not unique**: other flows fit as well ({alt}).")
        if not r.converged:
            warn.append(f"The search did not converge: {plain(r.message)}")
        self._warning.object = "\n\n".join(warn)
        self._warning.visible = bool(warn)
        names = list(r.features_names)
        meas = r.features_measured
        model = r.features_model
        std_m = self.state.measured.subset(names).std if self.state.measured is not None else np.full(len(names), np.nan)
        units = [feature_unit(n) for n in names]  # as the CSV export writes them
        conv = np.array([u[1] for u in units])
        sig = r.features_sigma if r.features_sigma is not None else std_m
        z = (model - meas) / sig
        table = pd.DataFrame({
            "feature": names, "unit": [u[0] for u in units],
            "measured": np.round(meas * conv, 5), "σ noise": np.round(std_m * conv, 5),
            "σ noise + model": np.round(sig * conv, 5), "model": np.round(model * conv, 5),
            "difference / σ": np.round(z, 2)})
        beyond = [n for n, v in zip(names, z) if abs(v) > 3]
        # a feature the model misses by more than 3 sigma (noise and model) is marked, and named below
        tab = pn.pane.HTML(table_html(table, marked=[i for i, v in enumerate(z) if abs(v) > 3]),
                           stylesheets=[TABLE_CSS], sizing_mode="stretch_width", css_classes=["lubeviz-features"])
        note = pn.pane.Markdown(
            f"Beyond 3σ (noise and model): **{plain(', '.join(beyond))}** — the **Diagnose** page looks for the "
            "cause."
            if beyond else "Every feature is within 3σ of the model (noise and model uncertainty).",
            sizing_mode="stretch_width", css_classes=["lubeviz-beyond"])
        self._features.objects = [tab, note]

    def _export_json(self):
        return io.StringIO(json.dumps(result_dict(self._item), indent=2)) if self._item else io.StringIO("{}")

    def _export_csv(self):
        return io.StringIO(result_csv(self._item)) if self._item else io.StringIO("")

    # --- plots ------------------------------------------------------------------------------------------
    def _draw_record(self, record, measured):
        xy = record.xy() * 1e6  # (P planes, 2, n) µm in X, Y
        t = record.t
        n_show = min(xy.shape[-1], int(round(5 * record.sample_rate_hz / record.speed_hz)))
        kd = "t (s)"
        curves = []
        for k in range(xy.shape[0]):
            for j, axis in enumerate("xy"):
                curves.append(hv.Curve((t[:n_show], xy[k, j, :n_show]), kd, "displacement (µm)",
                                       label=f"{axis}{k + 1} (node {record.nodes[k]})"))
        self._signals.object = hv.Overlay(curves).opts(title="Probe signals (first 5 revolutions)", responsive=True,
                                                       min_height=280, legend_position="right")
        orbits, spectra = [], []
        th = np.linspace(0, 2 * math.pi, 181)
        for k in range(xy.shape[0]):
            m = min(xy.shape[-1], 2000)
            raw = hv.Scatter((xy[k, 0, :m], xy[k, 1, :m]), "x (µm)", "y (µm)", label="samples").opts(
                size=2, color="#9ecae1")
            fx = (measured.x[k] * np.exp(1j * th)).real * 1e6
            fy = (measured.y[k] * np.exp(1j * th)).real * 1e6
            fit = hv.Curve((fx, fy), "x (µm)", "y (µm)", label="1X fit").opts(color="#08519c", line_width=2)
            lim = 1.2 * max(float(np.abs(xy[k, :, :m]).max()), 1e-9)
            orbits.append((raw * fit).opts(title=f"Orbit, plane {k + 1} (node {record.nodes[k]})", frame_width=260,
                                           frame_height=260, xlim=(-lim, lim), ylim=(-lim, lim),
                                           legend_position="bottom_right"))
            spec = full_spectrum(record.complex_signal(k), record.sample_rate_hz, record.speed_hz)
            f = spec.freq_hz
            amp = np.abs(spec.amplitude) * 1e6
            keep = np.abs(f) <= 4.5 * record.speed_hz
            spectra.append(hv.Spikes((f[keep], amp[keep]), "frequency (Hz)", "amplitude (µm)").opts(
                title=f"Full spectrum, plane {k + 1} (+ forward, − backward)", responsive=True, min_height=260,
                line_width=2, color="#2c5f8a"))
        self._orbits.objects = [pn.pane.HoloViews(orbit, linked_axes=False) for orbit in orbits]
        self._spectra.object = hv.Layout(spectra).cols(2).opts(shared_axes=False)
