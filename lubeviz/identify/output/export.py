"""The identification as a script and a person read it: the JSON record (SPEC §7), the text, the CSV table.

All three read one summary (`fit.result.summary`: every parameter, fitted and held, with its unit; the
test's statistics; the features), so a parameter shown in one is shown in all.
"""

from __future__ import annotations

import csv
import io
import math
import re

from ...units import MLMIN_PER_M3S
from ..fit.result import flooded_above, verdict_over_interval


def _flows(params) -> list:
    return [p for p in params if p.is_flow]


def result_dict(item) -> dict:
    """The JSON form of an identification (the CLI's `identify --json` record, the app's export)."""
    r = item.result
    s = r.summary()
    flows = _flows(r.params)
    names = s["features"]
    out = {"file": item.file}
    for p in flows:
        out[f"{p.key}_mlmin"] = p.value
    for p in flows:
        out[f"{p.key}_std_mlmin"] = p.std
    out.update({
        "q_threshold_mlmin": (r.q_threshold * MLMIN_PER_M3S).tolist(),
        "verdict": [r.verdict(k) for k in range(len(flows))],
        "converged": r.converged, "iterations": r.iterations, "starts_tried": r.starts_tried,
        "path": (r.path * MLMIN_PER_M3S).tolist(), "paths": [(p * MLMIN_PER_M3S).tolist() for p in r.paths],
        "features_measured": dict(zip(names, s["features_measured"])),
        "features_model": dict(zip(names, s["features_model"])),
        "features_sigma": None if s["features_sigma"] is None else dict(zip(names, s["features_sigma"])),
        "residual": s["residual"], "total_error": r.total_error, "mode": r.mode,
        "model_evaluations": r.evaluations, "nodes": list(item.nodes), "speed_hz": item.speed_hz,
        "set": item.set_name, "speeds_hz": list(item.speeds_hz) or [item.speed_hz],
        "unique": r.unique, "alternatives_mlmin": [a["flows_mlmin"] for a in s["alternatives"]],
        "alternatives": [{**{f"{p.key}_mlmin": a["flows_mlmin"][k] for k, p in enumerate(flows)}, "chi2": a["chi2"]}
                         for a in s["alternatives"]],
    })
    for p in flows:
        out[f"{p.key}_interval_mlmin"] = None if p.interval is None else list(p.interval)
    for k, p in enumerate(flows):
        iv = None if r.intervals_any_oil is None else r.intervals_any_oil[k]
        out[f"{p.key}_interval_any_oil_mlmin"] = None if r.intervals_any_oil is None else _ml(iv)
    out["flows"] = flows_list(item, r, flows)
    out.update({
        "oil_degeneracy": r.oil_degeneracy,
        "chi2": s["chi2"], "dof": s["dof"], "p_value": s["p_value"], "level": s["level"],
        "model_explains_data": s["explained"], "effects": r.effects,
        "lines_beyond_1x": [line.as_dict() for line in item.lines],
        "record_findings": [f.as_dict() for f in item.findings],
        "warnings": s["warnings"] + list(item.warnings),
        "message": r.message, "seconds": r.seconds,
    })
    return out


def flows_list(item, r, flows) -> list[dict]:
    """SPEC §8 `flows` of an identification (`flow_objects` with its thresholds and verdicts)."""
    return flow_objects(flows, getattr(item, "bearings", ()), r.q_threshold,
                        [r.verdict(k) for k in range(len(flows))])


def flow_objects(flows, bearings, q_threshold, verdicts) -> list[dict]:
    """SPEC §8 `flows`: one object per fluid-film bearing in the model file's order (its name and node, the flow, its
    std and 95 % interval, Q_T and the verdict; `identified`: whether the record gave it). `flows`: the fit's flow
    `FitParameter`s; `bearings`: (name, node, supply) each; `q_threshold` (m^3/s) and `verdicts` may be None."""
    names = list(bearings or ())
    out = []
    for k, p in enumerate(flows):
        name, node, supply = names[k] if k < len(names) else (f"bearing {k + 1}", None, "unknown")
        out.append({"bearing": name, "node": node, "q_mlmin": p.value, "q_std_mlmin": p.std,
                    "q_interval_mlmin": None if p.interval is None else list(p.interval),
                    "q_threshold_mlmin": None if q_threshold is None else float(q_threshold[k] * MLMIN_PER_M3S),
                    "verdict": None if verdicts is None else verdicts[k],
                    "supply": supply, "identified": bool(p.free) and supply == "unknown"})
    return out


def _ml(interval):
    if interval is None:
        return None
    low, high = interval
    return [low * MLMIN_PER_M3S, None if high is None else high * MLMIN_PER_M3S]


def result_text(item) -> list[str]:
    """The identification as a person reads it (the CLI without --json), as a fit report: each flow with its
    95 % interval (never a +- from noise alone), Q_T and the verdict; every other parameter, fitted or
    held, with its unit; the test's outcome, alternatives and lines."""
    r = item.result
    s = r.summary()
    speeds = "/".join(f"{v:g}" for v in (item.speeds_hz or (item.speed_hz,)))
    nodes = " and ".join(str(n) for n in item.nodes)
    out = [f"{item.file} ({speeds} Hz, planes at nodes {nodes}, {r.mode} mode)"]
    for k, p in enumerate(_flows(r.params)):
        qt = r.q_threshold[k] * MLMIN_PER_M3S
        iv = p.interval
        open_end = "open (flooded)" if iv is not None and flooded_above(iv[0], qt) else "open"
        span = ("no interval" if iv is None else
                f"95 % interval {iv[0]:.0f}-{open_end if iv[1] is None else format(iv[1], '.0f')}")
        ends = verdict_over_interval(p.value, iv, qt)
        verdict = ends[0] if ends[0] == ends[1] else f"{ends[0]} to {ends[1]} (the interval spans Q_T's band)"
        out.append(f"  Q{k + 1} = {p.value:.1f} ml/min, {span}; Q_T = {qt:.0f} ml/min "
                   f"({p.value / qt:.2f} Q_T): {verdict}")
    others = [p for p in r.params if not p.is_flow]
    for owner in dict.fromkeys(p.owner for p in others):
        out.append(f"  {owner}: " + "; ".join(p.text() for p in others if p.owner == owner))
    for f in item.findings:
        out.append(f"  {'THE RECORD CANNOT BE WHAT IT DECLARES' if f.impossible else 'check the record'}: {f.text}")
    if s["chi2"] is not None:
        told = ("the model explains the record" if s["explained"] else
                "THE MODEL DOES NOT EXPLAIN THE RECORD (intervals widened; run lubeviz diagnose)")
        out.append(f"  {told}: chi2 = {s['chi2']:.1f} for {s['dof']} dof, p = {s['p_value']:.2g}")
    lo = r.effect_details.get("large_orbit")
    if lo:
        out += _large_orbit_lines(lo)
    for a in s["alternatives"]:
        out.append("  another fit passes as well: " + _flows_mlmin_text(a["flows_mlmin"]))
    for ln in item.lines:
        d = ln.as_dict()
        out.append(f"  beyond 1X: {d['kind']} at plane {d['plane']}, {100 * d['relative_to_1x']:.1f} % of 1X")
    return out


def _flows_mlmin_text(flows_mlmin) -> str:
    """'Q1, Q2, Q3 = 420, 600, 180 ml/min': every flow given, named by its place in the file."""
    return (", ".join(f"Q{k + 1}" for k in range(len(flows_mlmin))) + " = "
            + ", ".join(f"{v:.0f}" for v in flows_mlmin) + " ml/min")


def _large_orbit_lines(lo: dict) -> list[str]:
    ratio = ", ".join(f"{v:.2f}" for v in lo["ratio_2x_model"])
    plain = _flows_mlmin_text(lo["plain_q_mlmin"])
    out = [f"  large orbits: the film force along the orbit ({lo['rounds']} harmonic balances with "
           f"{lo.get('harmonics', 5)} harmonics; the linear model alone gives {plain}, "
           f"chi2 {lo['plain_chi2']:.0f}); its 2X/1X at the planes: {ratio}; the orbit's size implies "
           f"{lo.get('unbalance_scale', 1.0):.2f} x the declared unbalance"]
    if lo.get("stability"):
        out.append(f"  stability at these flows: {lo['stability']}")
    return out


def error_text(file: str, error: str) -> list[str]:
    return [f"{file}: not identified: {error}"]


CSV_COLUMNS = ("quantity", "bearing_or_feature", "value", "unit", "sigma", "model", "low_95", "high_95")


def feature_unit(name: str) -> tuple[str, float]:
    """The unit a feature is written in (as the pages show it) and the factor from its SI value."""
    base = name.rsplit(":", 1)[-1]
    if base.startswith(("phi", "arg")):
        return "deg", 180.0 / math.pi
    if re.fullmatch(r"s[xy]\d+", base):  # a plane's static position (forward.chain.static_features), m
        return "um", 1e6
    return "-", 1.0


def result_csv(item) -> str:
    """The identification as one CSV table, every number with its unit (as the pages show it): the flows
    with their 1 sigma and 95 % interval, Q_T and the verdict of each bearing, every other parameter
    (fitted with its 1 sigma, or held), then each feature (measured value, its 1 sigma with the model
    budget, the model's value), then the test's statistics."""
    r = item.result
    s = r.summary()
    d = result_dict(item)
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(CSV_COLUMNS)

    def g(v, fmt=".6g"):
        return "" if v is None else format(v, fmt)

    for k, p in enumerate(_flows(r.params), start=1):
        iv = p.interval or (None, None)
        w.writerow(["supply_flow", k, g(p.value), "ml/min", g(p.std), "", g(iv[0]),
                    "open" if p.interval and iv[1] is None else g(iv[1])])
        w.writerow(["flow_threshold_Q_T", k, g(r.q_threshold[k - 1] * MLMIN_PER_M3S), "ml/min", "", "", "", ""])
        w.writerow(["verdict", k, r.verdict(k - 1), "", "", "", "", ""])
    for p in r.params:
        if not p.is_flow:
            value = g(p.value) if isinstance(p.value, float) else str(p.value)
            iv = p.interval or (None, None)
            w.writerow(["effect_parameter" if p.free else "effect_parameter_held", p.key, value, p.unit,
                        g(p.std), "", g(iv[0]), g(iv[1])])
    sigma = dict(zip(s["features"], s["features_sigma"] or [None] * len(s["features"])))
    for name, value, model in zip(s["features"], s["features_measured"], s["features_model"]):
        unit, f = feature_unit(name)
        w.writerow(["feature", name, g(value * f, ".9g"), unit, g(None if sigma[name] is None else sigma[name] * f),
                    g(model * f, ".9g"), "", ""])
    for key, unit in (("chi2", ""), ("dof", ""), ("p_value", ""), ("level", ""), ("model_explains_data", ""),
                      ("mode", ""), ("converged", ""), ("iterations", ""), ("unique", ""), ("speed_hz", "Hz")):
        w.writerow([key, "", d[key], unit, "", "", "", ""])
    return out.getvalue()
