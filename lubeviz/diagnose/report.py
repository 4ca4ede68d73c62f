"""The diagnosis as one self-contained HTML file, to attach to a work order.

No network is needed to open it and no JavaScript runs in it: the text is plain HTML with its own
stylesheet and the figures are inline SVG drawn here with plain Python (this module imports neither
bokeh nor matplotlib, so the CLI writes the report on a base install). Contents, in the order an
engineer reads them: what to do (the verdict and one action per bearing), the flows before and after
the residual loop with their 95 % intervals and lubrication verdicts, the residual of every feature in
sigma before and after (a bar chart with the +/-2 sigma band), the ranked candidate effects with their
evidence, what would separate look-alikes, the record, the model's uncertainty budget, the date and the
lubeviz version.

    html = report_html(diagnosis, record=record, machine_name="paper machine")
    write_report(diagnosis, "work-order-1234.html", record=record)
"""

from __future__ import annotations

import datetime as _dt
import math
from html import escape
from pathlib import Path
from typing import Sequence

import numpy as np

from .. import __version__
from ..identify.forward.budget import ModelBudget
from .loop import fit_flows, fit_flows_std, fitted_effects, interval_words, not_seen_sentence
from ..effects import EFFECTS, label_title, parse_effect, quantity_words
from ..words import signs
from ..identify.fit.result import VERDICT_BAND as BAND
from ..model.quantity import Quantity
from ..units import M3S_PER_MLMIN, MLMIN_PER_M3S

BEFORE_COLOUR = "#9a9a9a"
AFTER_COLOUR = "#2c5f8a"
VERDICT_COLOURS = {"starved": "#f6d7b0", "normal": "#cfe8cf", "over-supplied": "#cfe0f3"}
RESIDUAL_CLIP = 30.0  # sigma: taller bars are cut and labelled with their value

CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:24px auto;max-width:980px;color:#222;
     line-height:1.4}
h1{font-size:1.5em;margin-bottom:0}h2{font-size:1.15em;border-bottom:1px solid #ccc;padding-bottom:2px;
     margin-top:1.6em}
.sub{color:#666;margin-top:2px}
.verdict{border-left:6px solid #2c5f8a;background:#f3f7fb;padding:10px 14px;margin:12px 0}
.verdict.bad{border-color:#b03a2e;background:#fbf1f0}.verdict.warn{border-color:#d68910;background:#fdf6ea}
table{border-collapse:collapse;margin:8px 0;font-size:0.92em}
th,td{border:1px solid #ccc;padding:4px 8px;text-align:left;vertical-align:top}th{background:#f0f0f0}
td.num{text-align:right;font-variant-numeric:tabular-nums}
.starved{background:#f6d7b0}.normal{background:#cfe8cf}.over-supplied{background:#cfe0f3}
.small{font-size:0.85em;color:#555}ul.actions li{margin:4px 0}
svg{display:block;margin:8px 0;max-width:100%;height:auto}
@media print{body{margin:0}}
"""


# --- numbers as text ---------------------------------------------------------------------------------

def _mlmin(q) -> float:
    return float(q) / M3S_PER_MLMIN


def _flow(fit, k: int) -> str:
    return f"{_mlmin(fit_flows(fit)[k]):.0f} ± {_mlmin(fit_flows_std(fit)[k]):.0f} ml/min"


def _flows_cell(fit) -> str:
    return ", ".join(f"{_mlmin(q):.0f}" for q in fit_flows(fit))


def _and(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def _interval(fit, k: int) -> str:
    iv = fit.intervals.get(f"q{k + 1}") if fit.intervals else None
    if iv is None:
        return "–"
    lo, hi = iv
    return f"[{_mlmin(lo):.0f}, {'unbounded' if hi is None else f'{_mlmin(hi):.0f}'}]"


def _q_threshold(d) -> np.ndarray | None:
    """Each bearing's Q_T for the machine as diagnosed (a worn bearing's own), what its flows are judged against."""
    qt = d.q_threshold if getattr(d, "q_threshold", None) is not None else getattr(d.before, "q_threshold", None)
    return None if qt is None else np.asarray(qt, dtype=float)


def _fmt(v) -> str:
    if isinstance(v, (float, np.floating)):
        return f"{v:.4g}"
    return str(v)


def _titles(labels) -> str:
    """Candidates' labels as an engineer reads them (`effects.label_title`), joined."""
    return "; ".join(label_title(label) for label in labels)


def _quantity(name: str) -> str:
    """A fitted parameter's name in words: 'angle' for angle_deg, a pair's 'probe_rotation.angle_deg' likewise."""
    return quantity_words(name.rsplit(".", 1)[-1])


def _unit(unit: str) -> str:
    return {"um": "µm", "deg": "°", "N m": "N·m"}.get(unit, unit)


def _effect_parameters(c) -> str:
    """'angle 4.99 ± 0.32 °; plane 1': fitted ones with their std, then the held ones (the fit's
    `FitParameter`s, then the effect's placement), in words."""
    if c.fit is None:
        return escape(c.error or "fit failed")
    fitted = [p for p in c.fit.params if p.free and not p.is_flow]
    parts = [f"<b>{escape(_quantity(p.name))}</b> {p.value:.4g} ± {p.std:.2g} {escape(_unit(p.unit))}" for p in fitted]
    if getattr(c, "unbalance_scale", None) is not None:  # large orbits: read from the record's 1X, not fitted
        parts.append(f"unbalance {c.unbalance_scale:.2f} × the declared one (the orbit's size, from the 1X)")
    names = {p.name for p in fitted}
    held = [f"{escape(_quantity(n))} {escape(_fmt(v))}" for n, v in c.effect.values().items() if n not in names]
    return "; ".join(parts) + (f" <span class='small'>(held: {', '.join(held)})</span>" if held else "")


# --- what to do --------------------------------------------------------------------------------------

def _actions(d, nodes) -> list[str]:
    """One sentence per thing to do, in the order to do them (HTML, escaped)."""
    out = []
    outcome = d.outcome
    if outcome == "measurement fault":
        return [f"<b>Correct the record first</b>: {escape('. '.join(f.text for f in d.findings if f.fault))}. "
                "Its features describe the fault, not the machine: no effect was fitted and the flows mean nothing."]
    if d.findings:
        out.append(f"<b>Check the record</b>: {escape('. '.join(f.text for f in d.findings))}. The flows rest on "
                   "amplitude ratios and angles, which a scale error does not change.")
    if outcome in ("unexplained", "effect added, still not explained"):
        out.append("<b>Do not act on the flows alone</b>: the model does not explain this record, even with "
                   "the best effect of the library. Check the machine (alignment, rub, looseness) and the "
                   "measurement (probe wiring, calibration, a steady speed) and record again.")
    if outcome == "ambiguous":
        out.append(f"<b>Several explanations fit equally well</b> ({escape(_titles((d.added.label,) + d.ambiguous))}). "
                   "Before acting on them, take one of the measurements that separate them (listed under “Telling "
                   "look-alikes apart”). The flows below are those of the best-ranked, provisionally"
                   + ("." if d.set_intervals is None else
                      "; over all of them the flows are known only within " + escape(interval_words(d.set_intervals))
                      + "."))
    elif d.added is not None:
        told = ([(e, {}) for e in d.added.effects] if d.after is None else fitted_effects(d.added, d.after))
        story = escape(signs(" ".join(e.told(std) for e, std in told)))
        sep = escape("; or ".join(d.added.separated_by))
        out.append(f"<b>The model needed {escape(d.added.title)}</b>: {story} Confirm it"
                   + (f" by {sep}." if sep else "."))
    if d.not_seen:  # faults of a typical size the explained record cannot tell from none
        out.append("<b>Not seen by this record</b>, so not cleared by it: " + escape(not_seen_sentence(d.not_seen)))
    if d.rivals:  # pairs that fit nearly as well as the named effect (`diagnose.loop._rival_pairs`)
        out.append("<b>Two faults at once fit nearly as well</b> (" + escape(_titles(d.rivals)) + "): less likely "
                   "than one, but not ruled out by this record; the flows' interval below carries them.")
    if d.set_intervals is not None and outcome != "ambiguous":  # an explanation the record cannot rule out
        out.append("<b>Other explanations fit as well</b> (the verdict says which): over all of them the flows are "
                   "known only within " + escape(interval_words(d.set_intervals)) + ". Take one of the measurements "
                   "listed under “Telling look-alikes apart” before acting on the flows below.")
    f = d.final
    qt = d.thresholds_for(f)
    if qt is not None and outcome != "unexplained":
        for k in range(len(qt)):
            q = fit_flows(f)[k]
            v = d.verdicts_for(f)[k]
            where = f"Bearing {k + 1}" + (f" (node {nodes[k]})" if nodes else "")
            own = (d.q_threshold_declared is not None and abs(qt[k] / d.q_threshold_declared[k] - 1) > 0.01)
            ratio = (f"{q / qt[k]:.0%} of its flooded threshold Q_T = {_mlmin(qt[k]):.0f} ml/min"
                     + (" (its own, as diagnosed; the declared bearing's is "
                        f"{_mlmin(d.q_threshold_declared[k]):.0f})" if own else ""))
            if v == "starved":
                out.append(f"<b>{where} is starved</b>: {_mlmin(q):.0f} ml/min, {ratio}. Check its oil supply "
                           "(filter, orifice, supply pressure and line) and restore the flow to at least Q_T.")
            elif v == "over-supplied":
                out.append(f"{where} receives more oil than the film needs: {_mlmin(q):.0f} ml/min, {ratio}. No "
                           "lubrication risk; the supply could be reduced if oil or power is a concern.")
            else:
                out.append(f"{where} is fed normally: {_mlmin(q):.0f} ml/min, {ratio}. Nothing to do.")
    return out


# --- SVG figures -------------------------------------------------------------------------------------

def _svg(width: int, height: int, body: list[str], label: str) -> str:
    return (f'<svg width="{width}" height="{height}" '
            f'viewBox="0 0 {width} {height}" role="img" aria-label="{escape(label)}" style="max-width:100%;height:auto" '
            f'font-family="Helvetica,Arial,sans-serif" font-size="11">' + "".join(body) + "</svg>")


def _text(x, y, s, anchor="middle", size=11, colour="#222", extra="") -> str:
    return (f'<text x="{x:.1f}" y="{y:.1f}" text-anchor="{anchor}" font-size="{size}" fill="{colour}" {extra}>'
            f"{escape(str(s))}</text>")


def residual_svg(names: Sequence[str], before: np.ndarray, after: np.ndarray | None = None, *,
                 width: int = 760, height: int = 300) -> str:
    """Bars of each feature's whitened residual (sigma) before (grey) and after (blue) the effect, with
    the +/-2 sigma band: what a fit within noise leaves is inside the band."""
    names = list(names)
    before = np.asarray(before, dtype=float)
    after = None if after is None else np.asarray(after, dtype=float)
    vals = np.abs(np.concatenate([before, after if after is not None else []]))
    top = min(max(3.0, 1.15 * float(np.nanmax(vals)) if vals.size else 3.0), RESIDUAL_CLIP)
    left, right, up, down = 50, 10, 30, 50
    pw, ph = width - left - right, height - up - down

    def y(v):
        return up + ph / 2 - max(-top, min(top, v)) / top * ph / 2

    body = [f'<rect x="{left}" y="{y(2):.1f}" width="{pw}" height="{y(-2) - y(2):.1f}" fill="#e9f3e9"/>',
            _text(left + pw - 4, y(2) - 3, "±2σ: within noise", anchor="end", size=10, colour="#3a7a3a")]
    step = 1 if top <= 6 else (2 if top <= 12 else (5 if top <= 30 else 10))
    for t in np.arange(-math.floor(top / step) * step, top + 1e-9, step):
        body.append(f'<line x1="{left}" x2="{left + pw}" y1="{y(t):.1f}" y2="{y(t):.1f}" stroke="#ddd"/>')
        body.append(_text(left - 5, y(t) + 4, f"{t:g}", anchor="end", size=10))
    body.append(f'<line x1="{left}" x2="{left + pw}" y1="{y(0):.1f}" y2="{y(0):.1f}" stroke="#555"/>')
    body.append(_text(14, up + ph / 2, "residual (σ)", extra=f'transform="rotate(-90 14 {up + ph / 2:.1f})"'))
    n = max(len(names), 1)
    slot = pw / n
    series = [("before", before, BEFORE_COLOUR)] + ([("after", after, AFTER_COLOUR)] if after is not None else [])
    bw = slot * 0.7 / len(series)
    for i, name in enumerate(names):
        x0 = left + i * slot + slot * 0.15
        for j, (which, v, colour) in enumerate(series):
            r = float(v[i])
            ya, yb = sorted((y(0), y(r)))
            x = x0 + j * bw
            body.append(f'<rect x="{x:.1f}" y="{ya:.1f}" width="{bw - 1:.1f}" height="{max(yb - ya, 0.5):.1f}" '
                        f'fill="{colour}"><title>{escape(name)} {which}: {r:+.2f} σ</title></rect>')
            if abs(r) > 2:
                ty = (ya - 3) if r > 0 else (yb + 11)
                body.append(_text(x + bw / 2, ty, f"{r:+.1f}", size=9, colour=colour))
        body.append(_text(left + (i + 0.5) * slot, up + ph + 16, name))
    lx = left
    for which, _, colour in series:
        body.append(f'<rect x="{lx}" y="8" width="12" height="12" fill="{colour}"/>')
        body.append(_text(lx + 16, 18, f"{which} the effect" if after is not None else "plain fit", anchor="start"))
        lx += 140
    if top >= RESIDUAL_CLIP:
        body.append(_text(left + pw, 18, f"bars cut at ±{RESIDUAL_CLIP:g} σ", anchor="end", size=10, colour="#777"))
    return _svg(width, height, body, "residual of each feature in sigma, before and after the effect")


def scan_svg(scan, *, width: int = 760, height: int = 170) -> str:
    """A node scan's profile: each node's chi2 above the best node's (bars, cut at 30), the line at SCAN_DCHI2
    below which a node fits the record as well (green bars)."""
    from .scan import SCAN_DCHI2

    low = min(scan.chi2)
    top = 30.0
    left, right, up, down = 50, 10, 24, 34
    pw, ph = width - left - right, height - up - down
    slot = pw / max(len(scan.nodes), 1)

    def y(v):
        return up + ph - min(max(v, 0.0), top) / top * ph

    kind = EFFECTS[scan.effect_name].kind() if scan.effect_name in EFFECTS else scan.effect_name
    body = [_text(left, 14, f"{kind[0].upper() + kind[1:]}: χ² at each node above the best node's", anchor="start"),
            f'<line x1="{left}" x2="{left + pw}" y1="{y(SCAN_DCHI2):.1f}" y2="{y(SCAN_DCHI2):.1f}" stroke="#3a7a3a" '
            'stroke-dasharray="4 3"/>',
            _text(left + pw, y(SCAN_DCHI2) - 3, f"+{SCAN_DCHI2:g}: fits as well", anchor="end", size=10,
                  colour="#3a7a3a"),
            f'<line x1="{left}" x2="{left + pw}" y1="{y(0):.1f}" y2="{y(0):.1f}" stroke="#555"/>']
    for t in (10, 20, 30):
        body.append(_text(left - 5, y(t) + 4, f"{t:g}", anchor="end", size=10))
    fitting = set(scan.fitting)
    for i, (node, c) in enumerate(zip(scan.nodes, scan.chi2)):
        d = c - low if math.isfinite(c) else top
        colour = "#3a9a3a" if node in fitting else "#999"
        x = left + i * slot + 0.15 * slot
        body.append(f'<rect x="{x:.1f}" y="{y(d):.1f}" width="{0.7 * slot:.1f}" height="{max(y(0) - y(d), 0.5):.1f}" '
                    f'fill="{colour}"><title>node {node}: χ² {c:.1f}</title></rect>')
        body.append(_text(left + (i + 0.5) * slot, up + ph + 14, node, size=10))
    body.append(_text(left + pw / 2, height - 4, "node", size=10))
    return _svg(width, height, body, f"{scan.effect_name}: fit over the nodes")


def flows_svg(before, after, q_threshold, *, truth_mlmin=None, width: int = 760, height: int = 190,
              q_threshold_before=None) -> str:
    """Each bearing's flow on a Q/Q_T axis (0.25-2) shaded starved / normal / over-supplied: the plain
    fit (grey, against `q_threshold_before`, the declared bearings', when given) and the fit with the effect
    (blue, against `q_threshold`, the machine as diagnosed), each with its 95 % interval; the truth when known."""
    left, right = 90, 20
    pw = width - left - right
    lo, hi = 0.25, 2.0

    def x(r):
        return left + (min(max(r, lo), hi) - lo) / (hi - lo) * pw

    body = []
    rows = [(k, 45 + 70 * k) for k in range(len(q_threshold))]
    for k, yc in rows:
        for a, b, v in ((lo, BAND[0], "starved"), (BAND[0], BAND[1], "normal"), (BAND[1], hi, "over-supplied")):
            body.append(f'<rect x="{x(a):.1f}" y="{yc - 22}" width="{x(b) - x(a):.1f}" height="44" '
                        f'fill="{VERDICT_COLOURS[v]}"/>')
        body.append(_text(left - 8, yc + 4, f"bearing {k + 1}", anchor="end"))
        fits = [("plain fit", before, BEFORE_COLOUR, -9)] + ([("with the effect", after, AFTER_COLOUR, 9)]
                                                             if after is not None else [])
        for which, f, colour, dy in fits:
            qt = q_threshold_before if (f is before and q_threshold_before is not None) else q_threshold
            r = fit_flows(f)[k] / qt[k]
            iv = f.intervals.get(f"q{k + 1}") if f.intervals else None
            if iv is not None:
                a = iv[0] / qt[k]
                b = hi if iv[1] is None else iv[1] / qt[k]
                body.append(f'<line x1="{x(a):.1f}" x2="{x(b):.1f}" y1="{yc + dy}" y2="{yc + dy}" '
                            f'stroke="{colour}" stroke-width="2"/>')
                if iv[1] is None:
                    body.append(f'<path d="M{x(hi) - 6:.1f},{yc + dy - 4} L{x(hi):.1f},{yc + dy} '
                                f'L{x(hi) - 6:.1f},{yc + dy + 4}" fill="none" stroke="{colour}" stroke-width="2"/>')
            body.append(f'<circle cx="{x(r):.1f}" cy="{yc + dy}" r="5" fill="{colour}">'
                        f"<title>bearing {k + 1}, {which}: {_mlmin(fit_flows(f)[k]):.0f} ml/min ({r:.2f} Q_T)"
                        "</title></circle>")
        if truth_mlmin is not None:
            r = _mlmin_to_ratio(truth_mlmin[k], q_threshold[k])
            body.append(f'<path d="M{x(r):.1f},{yc - 20} l5,8 l-5,8 l-5,-8 z" fill="#111">'
                        f"<title>true flow {truth_mlmin[k]:.0f} ml/min</title></path>")
    base = rows[-1][1] + 30
    body.append(f'<line x1="{left}" x2="{left + pw}" y1="{base}" y2="{base}" stroke="#555"/>')
    for r in (0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0):
        body.append(f'<line x1="{x(r):.1f}" x2="{x(r):.1f}" y1="{base}" y2="{base + 4}" stroke="#555"/>')
        body.append(_text(x(r), base + 15, f"{r:g}"))
    body.append(_text(left + pw / 2, base + 30, "supply flow / flooded threshold Q_T"))
    bands = (("starved", lo, BAND[0]), ("normal", BAND[0], BAND[1]), ("over-supplied", BAND[1], hi))
    for j, (v, a, b) in enumerate(bands):
        body.append(_text((x(a) + x(b)) / 2, 14, v, size=10, colour="#555"))
    legend = [("plain fit", BEFORE_COLOUR), ("with the effect", AFTER_COLOUR)] if after is not None else \
        [("plain fit", BEFORE_COLOUR)]
    lx = left
    for label, colour in legend:
        body.append(f'<circle cx="{lx + 5}" cy="{height - 8}" r="5" fill="{colour}"/>')
        body.append(_text(lx + 14, height - 4, label + " (95 % interval)", anchor="start", size=10))
        lx += 190
    if truth_mlmin is not None:
        body.append(_text(lx, height - 4, "◆ true flow", anchor="start", size=10))
    return _svg(width, height + 0, body, "supply flows relative to the flooded threshold, before and after")


def _mlmin_to_ratio(q_mlmin: float, q_threshold: float) -> float:
    return float(q_mlmin) * M3S_PER_MLMIN / q_threshold


# Viridis (matplotlib's, 10 stops), reversed as the Diagnose page draws its chi^2 maps: the best fit yellow, the worst
# dark violet (issue 38: the report's grey ramp was faint and unlike the app's).
_VIRIDIS = ("#440154", "#482878", "#3e4989", "#31688e", "#26828e", "#1f9e89", "#35b779", "#6ece58", "#b5de2b",
            "#fde725")


def _viridis_r(v: float) -> str:
    """The reversed viridis colour of `v` in [0, 1] (0: yellow, 1: dark violet), interpolated between its stops."""
    if not np.isfinite(v):
        return "#ffffff"
    x = (1.0 - min(max(float(v), 0.0), 1.0)) * (len(_VIRIDIS) - 1)
    k = min(int(x), len(_VIRIDIS) - 2)
    f = x - k
    a, b = (np.array([int(h[i:i + 2], 16) for i in (1, 3, 5)]) for h in _VIRIDIS[k:k + 2])
    r, g, bl = np.rint((1 - f) * a + f * b).astype(int)
    return f"#{r:02x}{g:02x}{bl:02x}"


def map_svg(q1, q2, chi2, *, paths=(), truth_mlmin=None, title: str = "", width: int = 380,
            pair: tuple[int, int] = (0, 1)) -> str:
    """chi^2 over the flows of bearings `pair` (0-based; ml/min; yellow the best fit, dark violet the worst, as on the
    Diagnose page) with search paths
    [(label, (n, >= 2) m^3/s, colour): their columns `pair`]; `truth_mlmin`: every bearing's true flow."""
    q1, q2 = np.asarray(q1) / M3S_PER_MLMIN, np.asarray(q2) / M3S_PER_MLMIN
    qa, qb = pair
    c = np.log10(np.asarray(chi2, dtype=float) - np.nanmin(chi2) + 1.0)
    c = c / max(float(np.nanmax(c)), 1e-12)
    left, up, size = 55, 24, width - 75
    e1 = np.concatenate([[q1[0]], (q1[1:] + q1[:-1]) / 2, [q1[-1]]])
    e2 = np.concatenate([[q2[0]], (q2[1:] + q2[:-1]) / 2, [q2[-1]]])

    def px(v):
        return left + (v - q1[0]) / (q1[-1] - q1[0]) * size

    def py(v):
        return up + size - (v - q2[0]) / (q2[-1] - q2[0]) * size

    body = [_text(left + size / 2, 15, title)] if title else []
    for i in range(len(q1)):
        for j in range(len(q2)):
            body.append(f'<rect x="{px(e1[i]):.1f}" y="{py(e2[j + 1]):.1f}" width="{px(e1[i + 1]) - px(e1[i]) + 0.3:.1f}" '
                        f'height="{py(e2[j]) - py(e2[j + 1]) + 0.3:.1f}" fill="{_viridis_r(c[i, j])}"/>')
    for label, path, colour in paths:
        p = np.asarray(path)[:, [qa, qb]] / M3S_PER_MLMIN  # the pair's (the search's other parameters are not drawn)
        body.append(f'<polyline points="{" ".join(f"{px(a):.1f},{py(b):.1f}" for a, b in p)}" fill="none" '
                    'stroke="#ffffff" stroke-width="4"/>')  # a white edge: the path reads on any colour
        pts = " ".join(f"{px(a):.1f},{py(b):.1f}" for a, b in p)
        body.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2"/>')
        body.append(f'<circle cx="{px(p[-1, 0]):.1f}" cy="{py(p[-1, 1]):.1f}" r="4" fill="{colour}">'
                    f"<title>{escape(label)}: {p[-1, 0]:.0f}, {p[-1, 1]:.0f} ml/min</title></circle>")
    if truth_mlmin is not None:
        a, b = px(truth_mlmin[qa]), py(truth_mlmin[qb])
        body.append(f'<path d="M{a - 5:.1f},{b - 5:.1f} L{a + 5:.1f},{b + 5:.1f} M{a - 5:.1f},{b + 5:.1f} '
                    f'L{a + 5:.1f},{b - 5:.1f}" stroke="#c0392b" stroke-width="2.5"><title>true flows</title></path>')
    body.append(f'<rect x="{left}" y="{up}" width="{size}" height="{size}" fill="none" stroke="#555"/>')
    for v in np.linspace(q1[0], q1[-1], 5):
        body.append(_text(px(v), up + size + 14, f"{v:.0f}", size=10))
    for v in np.linspace(q2[0], q2[-1], 5):
        body.append(_text(left - 4, py(v) + 4, f"{v:.0f}", anchor="end", size=10))
    body.append(_text(left + size / 2, up + size + 30, f"Q{qa + 1} (ml/min)"))
    body.append(_text(12, up + size / 2, f"Q{qb + 1} (ml/min)",
                      extra=f'transform="rotate(-90 12 {up + size / 2:.1f})"'))
    return _svg(width, up + size + 40, body, title or f"chi-square map over Q{qa + 1} and Q{qb + 1}")


# --- the document ------------------------------------------------------------------------------------

def _flows_table(d, nodes, truth) -> str:
    qt = _q_threshold(d)
    head = ["bearing", "plain fit", "95 % interval", "verdict"]
    if d.after is not None:
        head += ["with the effect", "95 % interval", "verdict"]
    if truth is not None:
        head.append("true flow")
    rows = []
    for k in range(len(fit_flows(d.before))):
        cells = [f"{k + 1}" + (f" (node {nodes[k]})" if nodes else "")]
        for f in [d.before] + ([d.after] if d.after is not None else []):
            ref = d.thresholds_for(f)  # the plain model: the bearings as declared; with the effect: as diagnosed
            v = d.verdicts_for(f)[k] if ref is not None else "–"
            cells += [f"<td class='num'>{_flow(f, k)}</td>", f"<td class='num'>{_interval(f, k)}</td>",
                      f"<td class='{v}'>{v}" + (f" ({fit_flows(f)[k] / ref[k]:.2f} Q_T)" if ref is not None else "") + "</td>"]
        if truth is not None:
            cells.append(f"<td class='num'>{truth[k]:.0f} ml/min</td>")
        rows.append("<tr><td>" + cells[0] + "</td>" + "".join(cells[1:]) + "</tr>")
    stats = [("plain fit", d.before)] + ([("with the effect", d.after)] if d.after is not None else [])
    foot = "; ".join(f"{w}: χ² = {f.chi2:.1f} for {f.dof} dof, p = {f.p_value:.3g}"
                     + (" (explains the record)" if f.explained else " (does <b>not</b> explain the record)")
                     for w, f in stats)
    declared = d.q_threshold_declared
    changed = declared is not None and qt is not None and np.any(np.abs(qt / declared - 1) > 0.01)
    qt_text = "" if qt is None else (
        f" Flooded thresholds of the bearings as diagnosed: Q_T = {_and(f'{_mlmin(v):.0f}' for v in qt)} ml/min"
        + (f" (as declared: {_and(f'{_mlmin(v):.0f}' for v in declared)})" if changed else "")
        + f"; starved below {BAND[0]:g} Q_T, over-supplied above {BAND[1]:g} Q_T.")
    return ("<table><tr>" + "".join(f"<th>{h}</th>" for h in head) + "</tr>" + "".join(rows) + "</table>"
            + f"<p class='small'>{foot}.{qt_text} “unbounded”: the record does not limit the flow from above "
              "(a flooded bearing changes little as more oil arrives).</p>")


def _candidates_table(d) -> str:
    if not d.candidates:
        return "<p>No candidate effect was tried.</p>"
    best = d.candidates[0].aic
    rows = [f"<tr><td>–</td><td>plain model (no effect)</td><td class='num'>{d.before.aic - best:+.1f}</td>"
            f"<td class='num'>{d.before.chi2 / max(d.before.dof, 1):.2f}</td><td>{'yes' if d.before.explained else 'no'}"
            f"</td><td>–</td><td class='num'>{_flows_cell(d.before)}</td></tr>"]
    added = d.added.label if d.added is not None else None
    for i, c in enumerate(d.candidates, start=1):
        mark = " ★ added" if c.label == added else (" ≈ as good" if c.label in d.ambiguous else "")
        if c.fit is None:
            rows.append(f"<tr><td>{i}</td><td>{escape(c.title)}</td><td colspan='5'>{escape(c.error)}</td></tr>")
            continue
        f = c.fit
        style = " style='font-weight:bold'" if mark.startswith(" ★") else ""
        rows.append(f"<tr{style}><td>{i}</td>"
                    f"<td>{escape(c.title)}{escape(mark)}</td><td class='num'>{c.aic - best:+.1f}</td>"
                    f"<td class='num'>{f.chi2 / max(f.dof, 1):.2f}</td><td>{'yes' if c.passes else 'no'}</td>"
                    f"<td>{_effect_parameters(c)}</td>"
                    f"<td class='num'>{_flows_cell(f)}</td></tr>")
    return ("<table><tr><th>#</th><th>effect</th><th>ΔAIC</th><th>χ²/dof</th><th>passes</th>"
            "<th>fitted parameters ± 1σ</th><th>flows implied (ml/min)</th></tr>" + "".join(rows) + "</table>"
            "<p class='small'>Ranked by Akaike's information criterion AIC = χ² + 2k (k: free parameters); ΔAIC "
            "to the best. “passes”: what the effect leaves is noise and model uncertainty (p above the test "
            "level). Two candidates within ΔAIC 4 are not told apart by this record.</p>")


# The work order's fields a report carries (the Diagnose page's boxes, `lubeviz diagnose --asset ...`): key, heading.
WORK_ORDER_FIELDS = (("asset", "Asset / tag"), ("location", "Location"), ("operator", "Operator"),
                     ("comment", "Comment"))


def _work_order_table(work_order: dict | None) -> str:
    """The work order's fields as a table (each escaped: typed by a person, shown as written); '' when none."""
    rows = [(head, str((work_order or {}).get(key) or "").strip()) for key, head in WORK_ORDER_FIELDS]
    rows = [(h, v) for h, v in rows if v]
    if not rows:
        return ""
    return ("<table class='work-order'>" + "".join(
        f"<tr><th>{escape(h)}</th><td>{escape(v).replace(chr(10), '<br>')}</td></tr>" for h, v in rows) + "</table>")


def report_file_name(record_name: str | None, when: _dt.date | None = None) -> str:
    """The report's file name: 'lubeviz-<the record's name>-<date>.html', the name reduced to letters, digits, '-', '_'
    and '.' (a file name any system takes)."""
    import re

    stem = Path(str(record_name or "record")).stem if record_name else "record"
    stem = re.sub(r"[^A-Za-z0-9._-]+", "-", stem).strip("-.") or "record"
    return f"lubeviz-{stem[:60]}-{(when or _dt.date.today()).isoformat()}.html"


def _truth_words(truth: dict) -> str:
    """A simulated record's truth in words: its flows, its effect as `Effect.told` says it."""
    parts = []
    q = truth.get("q_mlmin")
    if q is not None:
        parts.append("true flows " + ", ".join(f"Q{k + 1} = {v:.0f}" for k, v in enumerate(q)) + " ml/min")
    if truth.get("effect"):
        try:
            parts.append(signs(parse_effect(truth["effect"]).told()))
        except Exception:  # noqa: BLE001 - a truth from elsewhere: as given
            parts.append(f"effect {truth['effect']}")
    parts += [f"{k}: {v}" for k, v in truth.items() if k not in ("q_mlmin", "effect")]
    return "; ".join(parts)


def _record_section(record, measured_names) -> str:
    if record is None:
        return "<p>No record details were given.</p>"
    n = record.displacement.shape[-1]
    dur = n / record.sample_rate_hz
    rows = [("file", record.source or "(not from a file)"),
            ("machine", record.machine or "(the default model)"),
            ("speed", f"{record.speed_hz:g} Hz ({60 * record.speed_hz:.0f} rpm)"),
            ("sampling", f"{record.sample_rate_hz:g} samples/s, {n} samples"),
            ("duration", f"{dur:.2f} s ({dur * record.speed_hz:.0f} revolutions)"),
            ("planes", f"{record.n_planes} at nodes {', '.join(str(n) for n in record.nodes)}; probe angles "
                       + "; ".join(f"{a:g}°/{b:g}°" for a, b in record.probe_angles_deg)),
            ("static position", "recorded (shaft centreline)" if record.rest_position is not None else "not recorded"),
            ("features used", ", ".join(measured_names))]
    if record.set_name:
        rows.append(("set", record.set_name))
    for k, v in sorted(record.metadata.items()):
        rows.append((f"metadata: {k}", _truth_words({"effect": v}) if k == "effect" else v))  # a sample's, in words
    return "<table>" + "".join(f"<tr><th>{escape(str(a))}</th><td>{escape(str(b))}</td></tr>" for a, b in rows) + "</table>"


def _budget_section() -> str:
    b = ModelBudget()
    items = "".join(f"<li>{escape(p.doc)}: {getattr(b, n):.3g}</li>" for n, p in b.param.objects("existing").items()
                    if isinstance(p, Quantity))
    return ("<p>The residuals are whitened by the record's noise <i>and</i> by what the model does not know, "
            "each a relative 1σ uncertainty propagated through the whole model at the fitted point. A "
            "residual outside ±2σ is therefore more than noise or model tolerance: something the model "
            f"lacks.</p><ul class='small'>{items}</ul>")


def report_html(diagnosis, *, record=None, title: str = "Lubrication diagnosis", machine_name: str | None = None,
                bearing_nodes: Sequence[int] | None = None, maps: Sequence = (), generated: _dt.datetime | None = None,
                work_order: dict | None = None) -> str:
    """The diagnosis as one self-contained HTML document (str).

    `record`: the measured record (its file, speed, planes and duration are listed); `bearing_nodes`: the
    machine's bearing nodes, named in the text; `maps`: optional chi^2 maps [(title, (qi, qj, chi2), paths,
    pair)] with `paths` and `pair` as in `map_svg`; `generated`: the date printed (default now, local time);
    `work_order`: what the engineer typed for the work order ({field: text}, WORK_ORDER_FIELDS), shown as written
    under the title (empty fields left out).
    """
    d = diagnosis
    generated = generated or _dt.datetime.now().astimezone()
    nodes = tuple(bearing_nodes) if bearing_nodes else None
    truth = d.truth.get("q_mlmin") if d.truth else None
    outcome = d.outcome
    cls = {"explained": "", "effect added": "", "ambiguous": "warn"}.get(outcome, "bad")
    qt = _q_threshold(d)
    parts = [f"<h1>{escape(title)}</h1>",
             "<p class='sub'>" + escape(" · ".join(filter(None, [machine_name, record.source if record else None,
                                                                   generated.strftime("%Y-%m-%d %H:%M %Z")]))) + "</p>",
             _work_order_table(work_order),
             "<h2>What to do</h2>",
             f"<div class='verdict {cls}'>" + ("" if d.verdict.lower().startswith(outcome.split()[0]) else
                                                f"<b>{escape(outcome.capitalize())}.</b> ") + f"{escape(signs(d.verdict))}</div>",
             "<ul class='actions'>" + "".join(f"<li>{a}</li>" for a in _actions(d, nodes)) + "</ul>",
             "<h2>Supply flows</h2>", _flows_table(d, nodes, truth)]
    if qt is not None:
        parts.append(flows_svg(d.before, d.after, qt, truth_mlmin=truth, q_threshold_before=d.q_threshold_declared))
    names = list(d.before.features_names)
    after = None
    if d.after is not None:
        idx = {n: i for i, n in enumerate(d.after.features_names)}
        after = np.array([d.after.residual[idx[n]] if n in idx else np.nan for n in names])
    parts += ["<h2>Residual of each feature</h2>",
              "<p>Model minus measurement, in standard deviations (noise and model uncertainty together). "
              "Bars outside the green band are what the plain model cannot explain; after the effect is added "
              "they should fall inside it.</p>",
              residual_svg(names, d.before.residual, after)]
    if maps:
        i, j = maps[0][3] if len(maps[0]) > 3 else (0, 1)
        parts.append(f"<h2>The search over Q{i + 1} × Q{j + 1}</h2><div style='display:flex;flex-wrap:wrap;gap:12px'>"
                     + "".join(map_svg(*m[1], paths=m[2] if len(m) > 2 else (), truth_mlmin=truth, title=m[0],
                                       pair=m[3] if len(m) > 3 else (0, 1)) for m in maps) + "</div>"
                     "<p class='small'>χ² over the flows (yellow: the best fit, dark violet: the worst, as on the Diagnose page); lines: the fits' search paths, "
                     "ending at the answer; ✕: the true flows when known.</p>")
    parts += ["<h2>Candidate effects</h2>", _candidates_table(d)]
    if d.scans:
        parts += ["<h2>Where along the shaft</h2>",
                  "<p>Each effect that acts at a place was fitted at every node where it can act.</p>"]
        for sc in d.scans:
            parts += [scan_svg(sc), f"<p class='small'>{escape(signs(sc.words()[0].upper() + sc.words()[1:]))}.</p>"]
    if d.ambiguous or d.separated_by:
        sep = "".join(f"<li>{escape(s)}</li>" for s in d.separated_by)
        # the look-alikes are named once, in "What to do"; here only what tells them apart (issue 38)
        parts += ["<h2>Telling look-alikes apart</h2>",
                  ("<p>The explanations named under “What to do” fit this record as well as one another. Any of these "
                   "measurements tells them apart:</p>" if d.ambiguous else
                   "<p>The effect named is clearly the best of the library for this record; to confirm it:</p>"),
                  f"<ul>{sep}</ul>"]
    if truth is not None or (d.truth and d.truth.get("effect")):
        parts += ["<h2>Known truth (simulated record)</h2>", "<p>" + escape(_truth_words(d.truth)) + "</p>"]
    parts += ["<h2>Record</h2>", _record_section(record, names),
              "<h2>Model uncertainty budget</h2>", _budget_section(),
              f"<p class='small'>lubeviz {escape(__version__)} · diagnosis computed in {d.seconds:.1f} s · report "
              f"generated {escape(generated.isoformat(timespec='seconds'))}. Method: Oliveira, Cunha &amp; Daniel "
              "(supply-flow identification from the full spectrum) with lubeviz's residual loop.</p>"]
    return ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<title>{escape(title)}</title><style>{CSS}</style></head><body>\n" + "\n".join(parts)
            + "\n</body></html>\n")


def report_maps(maps, diagnosis) -> list:
    """A run's maps (`pipeline.FlowMap`) as `report_html` draws them, (title, grid, paths, pair): each with
    its fit's search path, the plain model's in BEFORE_COLOUR, the one with the effect in AFTER_COLOUR."""
    return [(title, grid, [(title, fit.paths[-1], BEFORE_COLOUR if fit is diagnosis.before else AFTER_COLOUR)]
             if fit.paths else [], pair) for title, grid, fit, pair in maps]


def write_report(diagnosis, path, **kwargs) -> Path:
    """Write `report_html(diagnosis, **kwargs)` to `path` (UTF-8); returns the path."""
    path = Path(path)
    path.write_text(report_html(diagnosis, **kwargs), encoding="utf-8")
    return path
