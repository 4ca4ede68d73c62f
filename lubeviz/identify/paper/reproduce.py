"""The paper's 64-case protocol (SPEC §5, Tables 4-8): synthesize, identify, tabulate.

Reference flows {409.5 ... 682.5} ml/min in each bearing; each reference record is simulated as the
paper does (film equilibria solved directly at the reference flows, not read from the tables; 15 s
from rest at dt = 1e-4 s, the last 5 s kept; 12 dB SNR; seeded per case), then identified with the
coefficient tables, in paper mode and in best mode.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...progress import ProgressFn, silent
from ...rotor.assembly import rotor_from_machine
from ...rotor.film_bearings import FilmBearings, film_bearings
from ...signals.synthesize import synthesize_record
from ..forward.model import ALL_FEATURES, ForwardModel
from ..forward.measured import measure
from .newton import identify
from ..fit.settings import IdentificationSettings
from ...units import MLMIN_PER_M3S

REFERENCE_FLOWS_MLMIN = (409.5, 448.5, 487.5, 526.5, 565.5, 604.5, 643.5, 682.5)
PAPER_RESULTS = {
    "center": {"mean_abs_error_pct": 0.52, "max_abs_error_pct": 3.0, "mean_iterations": 3, "max_iterations": 10,
               "hours_per_case": 1.2},
    "outside": {"mean_abs_error_pct": 0.36, "max_abs_error_pct": 2.0, "mean_iterations": 10, "max_iterations": 70,
                "hours_per_case": None},
}


@dataclass(frozen=True)
class CaseResult:
    q_ref: tuple[float, float]
    q_id: tuple[float, float]
    q_std: tuple[float, float] | None
    iterations: int
    evaluations: int
    converged: bool
    unique: bool
    seconds: float

    @property
    def error_pct(self) -> tuple[float, float]:
        return tuple(100.0 * (i / r - 1.0) for i, r in zip(self.q_id, self.q_ref))


def location_nodes(machine, location: str) -> tuple[int, int]:
    if location == "center":
        return tuple(machine.center_nodes)
    if location == "outside":
        return tuple(machine.outside_nodes)
    raise InputError(f"--location {location!r}: expected 'center' or 'outside'")


def reference_records(machine, nodes, *, flows_mlmin=REFERENCE_FLOWS_MLMIN, snr_db=12.0, seed=2024,
                      method="time", progress: ProgressFn = silent):
    """The 64 reference records (dict (q1, q2) ml/min -> Record), equilibria solved directly once per flow."""
    rotor = rotor_from_machine(machine)
    omega = 2 * math.pi * machine.operating_speed
    single = {}
    for k in range(2):
        prev = None
        for q in flows_mlmin:
            fb = film_bearings(machine, (q / MLMIN_PER_M3S, q / MLMIN_PER_M3S), omega, previous=prev)
            single[(k, q)] = fb.equilibria[k]
            prev = fb
    records = {}
    total = len(flows_mlmin) ** 2
    n = 0
    for i, q1 in enumerate(flows_mlmin):
        for j, q2 in enumerate(flows_mlmin):
            fb = FilmBearings(omega=omega, flows=(q1 / MLMIN_PER_M3S, q2 / MLMIN_PER_M3S),
                              equilibria=(single[(0, q1)], single[(1, q2)]))
            rng = np.random.default_rng([seed, i, j, nodes[0]])
            records[(q1, q2)] = synthesize_record(machine, fb.flows, nodes=nodes, snr_db=snr_db, rng=rng,
                                                  bearings=fb, rotor=rotor, method=method)
            n += 1
            progress(n, total, f"record {q1:g}/{q2:g} ml/min")
    return records


def run_cases(model: ForwardModel, records: dict, settings: IdentificationSettings,
              progress: ProgressFn = silent) -> list[CaseResult]:
    out = []
    for n, ((q1, q2), rec) in enumerate(records.items(), start=1):
        meas = measure(rec, ALL_FEATURES)
        r = identify(model, meas, settings)
        out.append(CaseResult(q_ref=(q1, q2), q_id=tuple(r.q * MLMIN_PER_M3S), q_std=None if r.q_std is None else
                              tuple(r.q_std * MLMIN_PER_M3S), iterations=r.iterations, evaluations=r.evaluations,
                              converged=r.converged, unique=r.unique, seconds=r.seconds))
        progress(n, len(records), f"{settings.mode} {q1:g}/{q2:g}")
    return out


def summarize(cases: list[CaseResult]) -> dict:
    err = np.array([c.error_pct for c in cases])
    out = {
        "cases": [{"q1_ref": c.q_ref[0], "q2_ref": c.q_ref[1], "q1_id": c.q_id[0], "q2_id": c.q_id[1],
                   "err1_pct": c.error_pct[0], "err2_pct": c.error_pct[1], "iterations": c.iterations,
                   "evaluations": c.evaluations, "converged": c.converged, "seconds": c.seconds,
                   **({"q1_std": c.q_std[0], "q2_std": c.q_std[1], "unique": c.unique} if c.q_std else {})}
                  for c in cases],
        "mean_abs_error_pct": float(np.mean(np.abs(err))),
        "max_abs_error_pct": float(np.max(np.abs(err))),
        "mean_iterations": float(np.mean([c.iterations for c in cases])),
        "max_iterations": int(max(c.iterations for c in cases)),
        "mean_evaluations": float(np.mean([c.evaluations for c in cases])),
        "converged": int(sum(c.converged for c in cases)),
        "mean_seconds_per_case": float(np.mean([c.seconds for c in cases])),
    }
    if all(c.q_std for c in cases):
        dev = np.array([[abs(i - r) / s for i, r, s in zip(c.q_id, c.q_ref, c.q_std)] for c in cases])
        out["coverage_1sigma"] = float(np.mean(dev <= 1.0))
        out["coverage_2sigma"] = float(np.mean(dev <= 2.0))
    return out


def grid_table(cases: list[CaseResult], value, flows=REFERENCE_FLOWS_MLMIN, fmt="{:6.2f}") -> list[str]:
    """Rows Q1_ref, columns Q2_ref, as the paper's Tables 4-8."""
    by = {c.q_ref: c for c in cases}
    lines = ["Q1ref\\Q2ref " + " ".join(f"{q:>6g}" for q in flows)]
    for q1 in flows:
        lines.append(f"{q1:>11g} " + " ".join(fmt.format(value(by[(q1, q2)])) for q2 in flows))
    return lines


def report_lines(location: str, results: dict) -> list[str]:
    paper = PAPER_RESULTS[location]
    lines = []
    for mode, (cases, summary) in results.items():
        lines.append(f"== {mode} mode, measured {location} ==")
        lines.append("Error of Q1 identified (%)  [paper: Table " + ("4" if location == "center" else "7") + "]")
        lines += grid_table(cases, lambda c: c.error_pct[0])
        lines.append("Error of Q2 identified (%)  [paper: Table " + ("5" if location == "center" else "8") + "]")
        lines += grid_table(cases, lambda c: c.error_pct[1])
        lines.append("Iterations")
        lines += grid_table(cases, lambda c: c.iterations, fmt="{:6d}")
        lines.append("Time per case (ms)  [paper: Table 6, hours]")
        lines += grid_table(cases, lambda c: 1e3 * c.seconds, fmt="{:6.1f}")
        s = summary
        lines.append(f"mean |error| {s['mean_abs_error_pct']:.3f} % (paper {paper['mean_abs_error_pct']} %), "
                     f"max {s['max_abs_error_pct']:.2f} % (paper < {paper['max_abs_error_pct']} %), "
                     f"iterations mean {s['mean_iterations']:.1f} / max {s['max_iterations']} (paper "
                     f"{paper['mean_iterations']} / {paper['max_iterations']}), converged {s['converged']}/64, "
                     f"model evaluations mean {s['mean_evaluations']:.1f}")
        if "coverage_1sigma" in s:
            lines.append(f"uncertainty coverage: {100 * s['coverage_1sigma']:.0f} % within 1 sigma "
                         f"(expected 68 %), {100 * s['coverage_2sigma']:.0f} % within 2 sigma (expected 95 %)")
        lines.append("")
    return lines


def reproduce(machine, location: str, *, modes=("paper", "best"), progress: ProgressFn = silent,
              tables=None, seed: int = 2024, method: str = "time") -> dict:
    """Run the protocol at one location; returns {mode: (cases, summary)} and timing."""
    from ..tables.cache import machine_tables

    t0 = time.perf_counter()
    nodes = location_nodes(machine, location)
    tables = machine_tables(machine, progress=progress) if tables is None else tables
    t_tables = time.perf_counter() - t0
    model = ForwardModel(machine, tables, nodes)
    records = reference_records(machine, nodes, seed=seed, method=method, progress=progress)
    t_records = time.perf_counter() - t0 - t_tables
    results = {}
    for mode in modes:
        # the records are this model's own (the paper's protocol): no model-vs-machine difference to carry,
        # so best mode weighs by the record's noise alone, and its 1/2-sigma coverage checks exactly that
        settings = IdentificationSettings(mode=mode, include_model_error=False)
        cases = run_cases(model, records, settings, progress)
        results[mode] = (cases, summarize(cases))
    return {"results": results, "seconds": time.perf_counter() - t0, "tables_seconds": t_tables,
            "records_seconds": t_records, "nodes": nodes}
