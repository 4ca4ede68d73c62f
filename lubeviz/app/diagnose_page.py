"""Diagnose page: the residual loop on a record. Load a record (upload, or simulate a sample that carries
an effect the plain model lacks), run the diagnosis in the background (one progress step per candidate
effect, Cancel), and see the residual of every feature before and after, the ranked candidates with
their evidence, the chi^2 map over Q1 x Q2 with the searches, the verdict, and a report to download.

Display only: the sample comes from `identify.forward.chain.simulate`, the diagnosis and its maps from
`api.diagnose` (the CLI's one pipeline), its summary from `diagnose.diagnosis_dict`, the report from
`diagnose.report.report_html`.
"""

from __future__ import annotations

import dataclasses
import io
import math

import holoviews as hv
import numpy as np
import pandas as pd
import panel as pn
import param

from ..api import DiagnosisSettings, diagnose
from ..diagnose import diagnosis_dict
from ..diagnose.settings import REPORT_MAP_POINTS
from ..diagnose.loop import interval_words, not_seen_sentence
from ..diagnose.report import (AFTER_COLOUR as AFTER, BEFORE_COLOUR as BEFORE, WORK_ORDER_FIELDS, report_file_name,
                               report_html, report_maps, scan_svg)
from ..effects import EFFECTS, label_title, quantity_words
from ..errors import LubevizError
from ..identify.forward.chain import simulate
from ..identify.forward.measured import measure
from ..model.machine import Machine
from ..model.operating import initial_flows, operating_point
from ..progress import Cancelled
from ..signals.records import MAX_RECORD_BYTES, read_record_bytes
from ..units import M3S_PER_MLMIN
from . import plotting, resources  # noqa: F401 - plotting sets the HoloViews defaults
from .jobs import JobPanel, stopped_words
from .session import SessionState
from .text import TABLE_CSS, badge, file_label, plain, signs, table_html, truth_words, without_upload_dirs
from .widgets import (RecordDropper, not_loaded_message, quantity_slider, record_warnings_markdown, refused_message,
                      show_effect)

hv.extension("bokeh", logo=False)

UPLOAD_LIMIT_MB = 50
# The sample's true flows as fractions of each bearing's Q_T (the published one of the paper's machine, where they
# make 420 and 600 ml/min; else the tables', once the page is shown): one starved, one flooded, and so on.
SAMPLE_FRACTIONS = (420.0 / 546.0, 600.0 / 546.0, 0.9, 1.3, 0.6, 1.5)

EXPLAIN = """
### The residual loop
The plain model knows only the bearings' supply flows. When a record holds something else — oil hotter than
declared, a worn bearing, a second unbalance, soft pedestals, a probe turned or miscalibrated, a bowed
shaft — the best flows leave a **residual**: features the model cannot match, in standard deviations
of the noise and of the model's own uncertainty. The diagnosis tries every effect of the library in
every placement, fitted together with the flows, ranks them by AIC (χ² + 2 × parameters) and names the
one that brings the residual back to noise — or says that several do equally well (and which
measurement would tell them apart), or that none does. The flows are then identified again with it.

**Try it**: pick an effect below, *Simulate a sample with this effect*, then *Diagnose*.
"""


def _per_bearing(q) -> str:
    """'546 / 545 ml/min'-style flows (m^3/s), one per bearing."""
    return " / ".join(f"{v / M3S_PER_MLMIN:.0f}" for v in q)


WORK_ORDER_HINTS = {"asset": "e.g. P-101 B feed pump", "location": "e.g. unit 2, pump house",
                    "operator": "your name", "comment": "what was seen, what was done"}


def _unit(effect, key: str) -> str:
    """' µm' for a fitted parameter `key` of `effect` (a pair's 'name.param' of its partner too); '' without one."""
    name = key.rsplit(".", 1)[-1]
    for e in getattr(effect, "effects", (effect,)):
        if name in getattr(e, "continuous", ()):
            unit = e.unit(name)
            return f" {dict(um='µm', deg='°').get(unit, unit)}" if unit else ""
    return ""


DIAGNOSABLE = [n for n, cls in EFFECTS.items() if cls.diagnosed]  # oil_temperature is `viscosity` in °C


class DiagnosePage(pn.viewable.Viewer):
    """The Diagnose page of one session."""

    effect_name = param.Selector(default="probe_rotation", objects={EFFECTS[n].kind(): n for n in EFFECTS},
                                 doc="Effect the simulated sample record carries")
    snr_db = param.Number(12.0, bounds=(0.0, 40.0), doc="Signal-to-noise ratio of the sample's probes (dB)")
    seed = param.Integer(1, bounds=(0, 1_000_000), doc="Seed of the sample's noise")
    candidates = param.ListSelector(default=DIAGNOSABLE, objects={EFFECTS[n].kind(): n for n in DIAGNOSABLE},
                                    doc="Effects the diagnosis tries (each in every placement)")

    def __init__(self, machine: Machine, state: SessionState, **params):
        super().__init__(**params)
        self.machine = machine
        self.state = state
        self.sample = operating_point(machine, flows=self._sample_flows(initial_flows(machine)), name="sample")
        self._started = False
        self.effect = None
        self.jobs = JobPanel()
        self._record = self._measured = self._truth = None
        self._result = None
        self._record_name: str | None = None  # what the page calls the record on screen (file or sample)
        self._upload = RecordDropper(
            accepted_filetypes=[".csv", ".npz", ".mat", "text/csv", "application/octet-stream"],
            max_file_size=f"{UPLOAD_LIMIT_MB}MB", limit_bytes=UPLOAD_LIMIT_MB * 1_000_000,
            sizing_mode="stretch_width", css_classes=["lubeviz-diagnose-upload"])
        self._upload.param.watch(self._on_upload, "upload")
        self._upload.param.watch(self._on_refused, "refused")
        self._effect_story = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-effect-story"],
                                              styles={"font-size": "0.9em"})
        self._effect_widgets = pn.Column(sizing_mode="stretch_width")
        self._sample_button = pn.widgets.Button(name="Simulate a sample with this effect", button_type="default",
                                                css_classes=["lubeviz-diagnose-sample"])
        self._sample_button.on_click(self._on_sample)
        self._run = pn.widgets.Button(name="Diagnose", button_type="primary", disabled=True,
                                      css_classes=["lubeviz-diagnose-run"])
        self._run.on_click(self._on_run)
        # What the engineer types for the work order: the report carries it as written (issue 38).
        self._work_order = {key: (pn.widgets.TextAreaInput if key == "comment" else pn.widgets.TextInput)(
            name=head, placeholder=WORK_ORDER_HINTS[key], sizing_mode="stretch_width",
            css_classes=[f"lubeviz-report-{key}"], **({"rows": 3} if key == "comment" else {}))
            for key, head in WORK_ORDER_FIELDS}
        self._download = pn.widgets.FileDownload(callback=self._report, filename=report_file_name(None),
                                                 label="Download report (HTML)", button_type="success",
                                                 disabled=True, css_classes=["lubeviz-download-report"])
        self._record_info = pn.pane.Markdown("No record yet.", sizing_mode="stretch_width",
                                             css_classes=["lubeviz-diagnose-record"])
        self._message = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width",
                                      css_classes=["lubeviz-diagnose-error"])
        self._record_warnings = pn.pane.Alert("", alert_type="warning", visible=False, sizing_mode="stretch_width",
                                              css_classes=["lubeviz-diagnose-record-warnings"])
        self._verdict = pn.pane.Alert("", alert_type="info", visible=False, sizing_mode="stretch_width",
                                      css_classes=["lubeviz-verdict"])
        self._flows = pn.pane.Markdown("", sizing_mode="stretch_width", css_classes=["lubeviz-diagnosis-flows"])
        self._candidates = pn.Column(sizing_mode="stretch_width")  # a table made afresh per result
        self._residuals = pn.pane.HoloViews(self._residual_plot(None), sizing_mode="stretch_width",
                                            linked_axes=False, css_classes=["lubeviz-residuals"])
        self._scans = pn.Column(sizing_mode="stretch_width")  # each node scan's profile (diagnose.report.scan_svg)
        self._maps = pn.FlexBox(flex_wrap="wrap")  # the two χ² maps side by side, or one above the other when narrow
        self._flow_sliders = pn.Column(*self._sliders(initial_flows(machine)), sizing_mode="stretch_width")
        flows = [self._flow_sliders]
        sample_settings = pn.Param(self.param, parameters=["effect_name", "snr_db", "seed"], show_name=False,
                                   widgets={"effect_name": {"type": pn.widgets.Select, "name": "Effect in the sample"},
                                            "snr_db": {"type": pn.widgets.FloatSlider, "name": "Sample SNR (dB)"},
                                            "seed": {"type": pn.widgets.IntInput, "name": "Noise seed"}})
        tried = pn.widgets.MultiChoice.from_param(self.param.candidates, name="Candidate effects to try",
                                                  sizing_mode="stretch_width")
        # The sample's controls in their own card, folded away while the session's record is a file: they set up
        # a simulated sample and say nothing about a user's record (issue 38).
        self._sample_card = pn.Card(sample_settings, self._effect_story, self._effect_widgets, *flows,
                                    self._sample_button, title="Or a sample that carries an effect",
                                    collapsed=False, sizing_mode="stretch_width", css_classes=["lubeviz-sample-card"])
        controls = pn.Column(
            "### Record", self._record_info, self._upload, self._sample_card,
            "### Diagnosis", tried, self._run, self.jobs, "### Report for the work order",
            *self._work_order.values(), self._download, width=340)
        results = pn.Column(self._message, self._record_warnings, self._verdict, self._flows, self._residuals,
                            sizing_mode="stretch_width")
        self._layout = pn.Column(
            pn.Row(controls, results, sizing_mode="stretch_width"),
            pn.pane.Markdown("### Candidate effects, best first", sizing_mode="stretch_width"), self._candidates,
            self._scans, self._maps, pn.pane.Markdown(EXPLAIN, sizing_mode="stretch_width"), sizing_mode="stretch_width")
        self.param.watch(lambda e: self._choose_effect(e.new), "effect_name")
        self._choose_effect(self.effect_name)
        self.state.param.watch(self._on_record, "record")
        self._on_record()  # a record loaded on the Identify page before this page was first opened

    def __panel__(self):
        return self._layout

    async def start(self):
        """Each time the page is shown: the first time, the sample's flows and sliders at fractions of each bearing's
        Q_T; then the diagnosis the Identify page asked for ("Diagnose this record"), if it did."""
        if not self._started:
            self._started = True
            await self._sample_at_q_t()
        if self.state.diagnosis_asked and self.state.record is not None:
            self.state.diagnosis_asked = False
            await self._on_run(None)

    async def _sample_at_q_t(self):
        """The sample's flows and sliders at fractions of each bearing's Q_T (from the coefficient tables, shared
        with the other pages), in place of the first guess they start from."""
        if "flooded_threshold_mlmin" in self.machine.reference:  # the published Q_T: the sample starts from it
            return
        try:
            tables = await self.jobs.run(resources.tables, self.machine, self.machine.operating_speed, quiet=True,
                                         label="bearing coefficient tables")
        except Exception:  # noqa: BLE001 - the sample keeps its first guess; a diagnosis reports its own errors
            return
        qt = [t.q_threshold for t in tables]
        self.sample.flows = self._sample_flows(qt)
        self._flow_sliders.objects = self._sliders(qt)

    @staticmethod
    def _sample_flows(q_threshold) -> list[float]:
        return [round(f * q / M3S_PER_MLMIN) * M3S_PER_MLMIN for f, q in zip(SAMPLE_FRACTIONS, q_threshold)]

    def _sliders(self, q_threshold) -> list:
        """The sample's flow sliders over 30-200 % of `q_threshold` (per bearing), in whole ml/min."""
        return [quantity_slider(self.sample, n, start=max(math.floor(0.3 * q / M3S_PER_MLMIN), 1) * M3S_PER_MLMIN,
                                end=math.ceil(2.0 * q / M3S_PER_MLMIN) * M3S_PER_MLMIN,
                                step=M3S_PER_MLMIN, label=f"Sample: true flow Q{k + 1} (ml/min)",
                                sizing_mode="stretch_width", css_classes=[f"lubeviz-sample-q{k + 1}"])
                for k, (n, q) in enumerate(zip(self.sample.flow_names, q_threshold))]

    # --- the sample's effect ----------------------------------------------------------------------------
    def _choose_effect(self, name: str):
        self.effect = show_effect(name, self.machine, self._effect_story, self._effect_widgets)

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

    def _loaded(self, record, measured, truth, name: str):
        """Make a record read or simulated here the session's (every page shows it: `_on_record`)."""
        self.state.use(record, measured, name, loaded_on="Diagnose", truth=truth)

    def _on_record(self, *events):
        """Show the session's record, loaded here or on the Identify page, and drop the last one's diagnosis."""
        state = self.state
        if state.record is None:
            return
        self._record, self._measured, self._truth = state.record, state.measured, state.truth
        self._record_name = state.record_name
        if state.loaded_on != "Diagnose":
            self._message.visible = False  # a failed upload here is not about the record now shown
        self._sample_card.collapsed = state.truth is None  # a user's record: the sample's controls fold away
        self._result = None
        self._verdict.visible = False
        self._flows.object = ""
        self._candidates.objects = []
        self._scans.objects = []
        self._maps.objects = []
        self._residuals.object = self._residual_plot(None)
        self._download.disabled = True
        self._run.disabled = False
        self._record_info.object = self._info_text(state.record, state.truth, state.record_name)
        self._record_warnings.object = record_warnings_markdown(state.record, self.machine)
        self._record_warnings.visible = bool(self._record_warnings.object)

    def _info_text(self, record, truth, name: str) -> str:
        """The record's box (Markdown): its name, speed, length and planes, the oil temperature and static
        position it carries, and the true flows only of a sample this page simulated (`truth`)."""
        n = record.displacement.shape[-1]
        dur = n / record.sample_rate_hz
        where = self.state.loaded_on
        lines = [f"**{plain(name)}**" + ("" if where in (None, "Diagnose") else f" (loaded on the {where} page)"), "",
                 f"speed {record.speed_hz:g} Hz; {dur:.2f} s ({dur * record.speed_hz:.0f} revolutions); "
                 f"{len(record.nodes)} planes at nodes {', '.join(str(n) for n in record.nodes)}"]
        t_oil = getattr(record, "oil_temperature_c", None)
        if t_oil is not None:
            oil = getattr(self.machine, "oil", None)
            lines += ["", f"oil temperature read: {t_oil:g} °C" + (
                f" (the diagnosis holds the oil at it: viscosity × {float(oil.factor(t_oil)):.2f} of the declared)"
                if oil is not None else " (not used: the model file declares no [oil])")]
        if getattr(record, "static_offset", None) is not None:
            lines += ["", "static shaft position: present (it separates hotter oil, wear and less oil)"]
        if truth:
            lines += ["", truth_words(truth, self.machine)]
        return "\n".join(lines)

    async def _on_sample(self, event):
        effect = self.effect.hold()
        theta = np.array(self.sample.flows)
        self._message.visible = False
        try:
            loaded = await self.jobs.run(self._simulate, effect, theta, self.snr_db, self.seed,
                                         label=f"simulating a sample with {effect.title()}", tell_stopped=True)
        except Cancelled:
            return
        except LubevizError as exc:
            self._show_error(f"**No sample.** {plain(exc)}")
            return
        except Exception as exc:  # noqa: BLE001 - shown on the page
            self._show_error(f"**No sample**: unexpected problem: {plain(exc)}")
            return
        self._loaded(*loaded, name=loaded[0].source)

    def _simulate(self, effect, theta, snr_db, seed, progress):
        m = self.machine
        base = resources.chain(m, m.operating_speed, m.center_nodes, progress=progress)
        resources.prepare_views(base, (effect,), progress=progress)  # a viscosity/clearance change: new tables
        record = simulate(base.with_effects((effect,)), theta, snr_db=snr_db, rng=np.random.default_rng(seed),
                          metadata={"effect": effect.spec()})
        record = dataclasses.replace(record, source=f"sample: {effect.title()}")
        truth = {"q_mlmin": [float(q / M3S_PER_MLMIN) for q in theta], "effect": effect.spec()}
        return record, measure(record), truth

    async def _on_upload(self, event):
        if event.new is None:
            return
        filename, content = event.new  # every drop, the same file again included
        filename = file_label(filename)  # the base name, shortened: never a path on the page
        if content is not None and len(content) > MAX_RECORD_BYTES:
            self._not_loaded(filename, f"{filename}: {len(content) / 1e6:.1f} MB is too large")
            self._upload.rejected = True
            return
        self._message.visible = False
        try:
            loaded = await self.jobs.run(self._read, content, filename, label=f"reading {filename}", quiet=True,
                                         tell_stopped=True)
        except Cancelled:
            return
        except LubevizError as exc:
            self._not_loaded(filename, without_upload_dirs(exc), read=True)
            self._upload.rejected = True
            return
        except Exception as exc:  # noqa: BLE001 - never let a bad upload stop the app
            self._not_loaded(filename, f"{filename}: unexpected problem ({type(exc).__name__}): "
                                       f"{without_upload_dirs(exc)}", read=True)
            self._upload.rejected = True
            return
        self._upload.rejected = False
        self._loaded(*loaded, name=filename)

    def _on_refused(self, event):
        if event.new is not None:
            self._not_loaded(file_label(event.new[0]), refused_message(*event.new, UPLOAD_LIMIT_MB))

    def _read(self, content, filename, progress):
        """An uploaded record and its features. No truth: a file's metadata may claim any flows (only a
        sample this page simulated has one)."""
        record = read_record_bytes(content, filename, **self.machine.record_defaults())
        return record, measure(record), None

    # --- the diagnosis ----------------------------------------------------------------------------------
    async def _on_run(self, event):
        if self._record is None:
            return
        chosen = list(self.candidates)
        if not chosen:
            self._show_error("**No diagnosis**: choose at least one candidate effect.")
            return
        self._message.visible = False
        self._run.disabled = True
        name = self._record_name
        try:
            result = await self.jobs.run(self._diagnose, self._record, self._measured, self._truth, chosen,
                                         label="diagnosis")
        except Cancelled:
            return
        except LubevizError as exc:
            self._show_error(f"**No diagnosis.** {plain(exc)}")
            return
        except Exception as exc:  # noqa: BLE001
            self._show_error(f"**No diagnosis**: unexpected problem: {plain(exc)}")
            return
        finally:
            self._run.disabled = False
        self._result = dict(result, name=name)
        self._show(self._result)

    def _diagnose(self, record, measured, truth, chosen, progress):
        pool = None if len(chosen) == len(DIAGNOSABLE) else [EFFECTS[n] for n in chosen]
        run = diagnose([record], self.machine, DiagnosisSettings(map_points=REPORT_MAP_POINTS), candidates=pool,
                       measured=[measured], truth=truth, progress=progress,
                       chain_for=lambda m, speed, nodes, angles, p: resources.chain(m, speed, nodes, angles, progress=p))
        d = run.diagnosis
        return dict(diagnosis=d, summary=diagnosis_dict(d), record=record, maps=list(run.maps), truth=truth,
                    notes=run.inputs.notes)

    def work_order(self) -> dict:
        """The work order's fields as typed on the page ({key: text}, `report.WORK_ORDER_FIELDS`)."""
        return {key: w.value for key, w in self._work_order.items()}

    # --- showing ----------------------------------------------------------------------------------------
    def _show(self, r):
        d, s = r["diagnosis"], r["summary"]
        kind = "success" if d.explained and not d.ambiguous else ("warning" if d.explained or d.ambiguous else "danger")
        added = {"explained": "**No effect needed.** ", "unexplained": "**No effect explains the record.** ",
                 "measurement fault": "**The measurement is broken: no effect was fitted.** "}.get(
            d.outcome, "" if d.added is None else f"**Effect added: {plain(d.added.title)}.** ")
        # The flows first: the browser receives each change as its own message, and whoever reads the verdict
        # (a user, a test) should find the flows it speaks of already there.
        self._flows.object = self._flows_text(d, s, r["truth"], r["name"])
        self._verdict.alert_type = kind
        notes = r.get("notes", ())
        self._verdict.object = added + plain(signs(d.verdict)) + "".join(f"\n\n_Note: {plain(signs(n))}_" for n in notes)
        self._verdict.visible = True
        self._residuals.object = self._residual_plot(d)
        table = self._candidates_table(d, s)
        self._candidates.objects = [pn.pane.HTML(table_html(table), stylesheets=[TABLE_CSS], sizing_mode="stretch_width",
                                                 css_classes=["lubeviz-candidates"])]
        self._scans.objects = ([pn.pane.Markdown("### Where along the shaft", sizing_mode="stretch_width")] + [
            pn.Column(pn.pane.HTML(scan_svg(sc), css_classes=["lubeviz-node-scan"]),
                      pn.pane.Markdown(plain(signs(sc.words()[0].upper() + sc.words()[1:])) + ".",
                                       sizing_mode="stretch_width")) for sc in d.scans]) if d.scans else []
        self._maps.objects = [pn.pane.HoloViews(self._map_plot(*m, r["truth"]), linked_axes=False,
                                                css_classes=["lubeviz-diagnose-map"]) for m in r["maps"]]
        self._download.filename = report_file_name(r["name"])
        self._download.disabled = False

    def _flows_text(self, d, s, truth, record_name: str) -> str:
        declared = d.before.q_threshold  # the plain model's flows are judged against the declared bearings
        qt = d.q_threshold if d.q_threshold is not None else declared  # the others against the machine as diagnosed
        cols = [("plain model", d.before, s["before"])] + ([("with " + plain(d.added.title), d.after, s["after"])]
                                                          if d.after is not None else [])
        head = "| bearing | " + " | ".join(f"{name}: flow (95 % interval) | verdict" for name, _, _ in cols) + \
               (" | truth |" if truth else " |")
        lines = [f"### Supply flows of {plain(record_name)}, before and after", head,
                 "|---" * (1 + 2 * len(cols) + (1 if truth else 0)) + "|"]
        for k in range(len(declared)):
            cells = [f"{k + 1} (node {self.machine.bearings[k].node})"]
            for name, f, fd in cols:
                iv = fd[f"q{k + 1}_interval_mlmin"]
                iv_text = "" if iv is None else f" ({iv[0]:.0f}–{'∞' if iv[1] is None else f'{iv[1]:.0f}'})"
                cells.append(f"**Q{k + 1} = {fd[f'q{k + 1}_mlmin']:.0f} ± {fd[f'q{k + 1}_std_mlmin']:.0f} ml/min**"
                             f"{iv_text}")
                cells.append(badge(d.verdicts_for(f)[k]))
            if truth:
                cells.append(f"{truth['q_mlmin'][k]:.0f} ml/min")
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
        lines.append("; ".join(f"{name}: χ² = {fd['chi2']:.1f} for {fd['dof']} dof (p = {fd['p_value']:.2g})"
                               for name, _, fd in cols) + f". Q_T = {_per_bearing(qt)} ml/min"
                     + ("" if np.allclose(qt, declared, rtol=0.01) else
                        f" as diagnosed (declared: {_per_bearing(declared)})")
                     + f". Diagnosis in {d.seconds:.1f} s.")
        if d.ambiguous:
            lines += ["", f"**Look-alikes**: {plain('; '.join(label_title(a) for a in d.ambiguous))} fit as well. "
                          "To tell them apart: "
                          f"{plain('; or '.join(d.separated_by))}."]
        elif d.separated_by:
            lines += ["", f"To confirm it: {plain('; or '.join(d.separated_by))}."]
        if d.rivals:  # pairs that fit nearly as well as the named effect (`diagnose.loop._rival_pairs`)
            pairs = plain("; ".join(label_title(a) for a in d.rivals))
            lines += ["", f"**Two faults at once** fit nearly as well: {pairs} (less likely than one, not ruled out "
                          "by this record)."]
        if d.not_seen:  # faults of a typical size the record cannot tell from none
            lines += ["", "**Not seen by this record**: " + plain(not_seen_sentence(d.not_seen))]
        if d.set_intervals is not None:  # an ambiguity, or an oil the record cannot pin (the verdict says which)
            lines += ["", "**Flows over every explanation that fits** (until a measurement separates them): "
                      f"{interval_words(d.set_intervals)}."]
        return "\n".join(lines)

    @staticmethod
    def _candidates_table(d, s) -> pd.DataFrame:
        rows = []
        for i, (c, e) in enumerate(zip(d.candidates, s["effects"]), start=1):
            ev = e["evidence"] or {}
            params = e["parameters"]
            fitted = ", ".join(f"{quantity_words(k.rsplit('.', 1)[-1])} {params[k]:.4g} ± {params[k + '_std']:.2g}"
                               f"{_unit(c, k)}" for k in params if k + "_std" in params)
            mark = "added" if d.added is not None and c.label == d.added.label else (
                "as good" if c.label in d.ambiguous else "")
            rows.append({"rank": i, "effect": c.title, "": mark, "ΔAIC": round(ev.get("delta_aic", math.nan), 1),
                         "χ²/dof": round(c.fit.chi2 / max(c.fit.dof, 1), 2) if c.fit is not None else math.nan,
                         "passes": "yes" if c.passes else "no", "fitted parameters ± 1σ": fitted or e["error"] or "",
                         **{f"Q{k} (ml/min)": round(ev.get(f"q{k}_mlmin", math.nan))
                            for k in range(1, len(d.before.q_threshold) + 1)}})
        return pd.DataFrame(rows)

    def _residual_plot(self, d):
        kd, vd = ["feature", "fit"], "residual (σ)"
        opts = dict(responsive=True, min_height=300, show_legend=True)
        band = hv.HSpan(-2.0, 2.0).opts(color="#9fd49f", alpha=0.35)
        if d is None:
            return (hv.Bars([], kd, vd).opts(ylim=(-3.0, 3.0)) * band).opts(
                title="Residual of each feature (run a diagnosis)", **opts)
        names = list(d.before.features_names)
        rows = [(n, "plain", float(v)) for n, v in zip(names, d.before.residual)]  # short: each bar is labelled
        title = "Residual of each feature (σ), plain model"
        if d.after is not None:
            after = dict(zip(d.after.features_names, d.after.residual))
            rows += [(n, "with effect", float(after.get(n, np.nan))) for n in names]
            title = f"Residual of each feature (σ), before and after {d.added.title}"
        top = max(3.0, 1.1 * float(np.nanmax(np.abs([r[2] for r in rows]))))  # the ±2σ band always shows
        bars = hv.Bars(rows, kd, vd).opts(color="fit", cmap=[BEFORE, AFTER], xlabel="", ylabel=vd, tools=["hover"],
                                          multi_level=False, framewise=True, ylim=(-top, top))
        return (bars * band).opts(title=title, **opts)

    def _map_plot(self, title, grid, fit, pair, truth):
        q1, q2, chi2 = grid
        i, j = pair
        a, b = q1 / M3S_PER_MLMIN, q2 / M3S_PER_MLMIN
        kd = [f"Q{i + 1} (ml/min)", f"Q{j + 1} (ml/min)"]
        z = np.log10(chi2 - np.nanmin(chi2) + 1.0).T
        mesh = hv.QuadMesh((a, b, z), kd, "log10(χ² − min + 1)").opts(cmap="viridis_r", colorbar=True, tools=["hover"])
        layers = [mesh]
        for path in fit.paths:
            p = np.asarray(path) / M3S_PER_MLMIN
            layers.append(hv.Curve((p[:, i], p[:, j]), *kd).opts(color="white", line_width=1.5, alpha=0.7))
        answer = fit.flow_values()[[i, j]] / M3S_PER_MLMIN
        layers.append(hv.Points([tuple(answer)], kd, label="fit").opts(color="white", size=10, marker="circle",
                                                                     line_color="black"))
        if truth:
            layers.append(hv.Points([(truth["q_mlmin"][i], truth["q_mlmin"][j])], kd, label="truth").opts(
                color="red", size=12, marker="x", line_width=3))
        return hv.Overlay(layers).opts(title=f"χ² over Q{i + 1} × Q{j + 1}, {title}", frame_width=330,
                                       frame_height=330, legend_position="top_right", framewise=True)

    def _report(self):
        r = self._result
        if r is None:
            return io.StringIO("")
        html = report_html(r["diagnosis"], record=r["record"], machine_name=self.machine.name,
                           bearing_nodes=[b.node for b in self.machine.bearings],
                           maps=report_maps(r["maps"], r["diagnosis"]), work_order=self.work_order())
        return io.StringIO(html)
