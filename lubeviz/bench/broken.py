"""`lubeviz bench broken`: independent records broken the way a measurement breaks (`verification.broken`),
each diagnosed as the CLI does, and judged: right, one wrong effect named alone, the flows' intervals held."""

from __future__ import annotations

import time

import numpy as np

from ..progress import ProgressFn, silent
from ..units import MLMIN_PER_M3S
from ..verification.broken import _SAME, KINDS, broken_record
from .records import _held, wilson


def judge(d, expect: dict, q_mlmin) -> dict:
    """What the diagnosis `d` got right of a record broken as `expect` says (see the module docstring)."""
    named = [] if d.added is None else [d.added.label, *d.ambiguous]
    alone = d.added.label if (d.added is not None and not d.ambiguous) else None
    kinds = [f.kind for f in d.findings]
    if "wiring" in expect:
        ok = _SAME.get(expect["wiring"], {expect["wiring"]})
        faults = {lab.split("fault=")[1].rstrip("]") for lab in named if lab.startswith("wiring[")}
        right = bool(faults & ok) and d.explained
        wrong_alone = alone is not None and not (alone.startswith("wiring[") and faults <= ok)
        held = _held(d, np.asarray(q_mlmin) / MLMIN_PER_M3S) if right else None
    elif "finding" in expect:
        texts = " ".join(f.text for f in d.findings)
        if expect["finding"] == "units":
            right = expect["text"] in texts
        else:
            right = expect["finding"] in kinds and expect["text"] in texts and d.added is None and not d.explained
        wrong_alone = alone is not None
        held = _held(d, np.asarray(q_mlmin) / MLMIN_PER_M3S) if expect["finding"] == "units" else None
    elif "pickup" in expect:
        right = (any(line.kind == "mains" and abs(line.frequency_hz - expect["pickup"]) < 1.0 for line in d.lines)
                 and not any(line.kind == "sub" and line.relative_to_1x > 0.05 for line in d.lines)
                 and d.stability is None)
        wrong_alone = alone is not None
        held = _held(d, np.asarray(q_mlmin) / MLMIN_PER_M3S)
    else:
        right = d.explained and d.added is None and not d.findings
        wrong_alone = alone is not None
        held = _held(d, np.asarray(q_mlmin) / MLMIN_PER_M3S)
    return {"right": bool(right), "wrong_alone": bool(wrong_alone), "held": held, "findings": kinds,
            "added": None if d.added is None else d.added.label, "ambiguous": list(d.ambiguous),
            "explained": bool(d.explained)}


def bench_broken(machine_path=None, *, n: int = 112, seed: int = 2026, speed_hz: float = 75.0,
                 progress: ProgressFn = silent) -> dict:
    """`n` independent records, each broken as KINDS[i % len(KINDS)] (every kind alike), diagnosed."""
    from ..diagnose import run_diagnosis
    from ..model.machine import load_machine
    from ..verification.independent import IndependentSpec, make_record, thresholds_mlmin

    t0 = time.perf_counter()
    machine = load_machine(machine_path)
    qt = thresholds_mlmin(speed_hz, machine_path)
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        kind = KINDS[i % len(KINDS)]
        q = qt * rng.uniform(0.75, 1.25, 2)
        spec = IndependentSpec(speed_hz=speed_hz, q1_mlmin=float(q[0]), q2_mlmin=float(q[1]), seed=5000 + i)
        clean = make_record(spec).record
        rec, expect = broken_record(clean.displacement.reshape(4, -1), clean.speed_hz, clean.sample_rate_hz, kind,
                                    rng, nodes=clean.nodes)
        d = run_diagnosis([rec], machine).diagnosis
        rows.append({"kind": kind, "q_mlmin": q.tolist(), "seconds": d.seconds, "verdict": d.verdict,
                     **judge(d, expect, q)})
        progress(i + 1, n, kind)
    summary = {}
    for kind in KINDS:
        rr = [r for r in rows if r["kind"] == kind]
        if rr:
            held = [r["held"] for r in rr if r["held"] is not None]
            summary[kind] = {"records": len(rr), "right": sum(r["right"] for r in rr),
                             "wrong_alone": sum(r["wrong_alone"] for r in rr),
                             "held": f"{sum(held)}/{len(held)}" if held else None}
    right = sum(r["right"] for r in rows)
    wrong = sum(r["wrong_alone"] for r in rows)
    held = [r["held"] for r in rows if r["held"] is not None]
    return {"records": n, "speed_hz": speed_hz, "seed": seed,
            "right": right, "right_rate_95": wilson(right, n),
            "wrong_alone": wrong, "wrong_alone_rate_95": wilson(wrong, n),
            "held": sum(held), "held_of": len(held), "held_rate_95": wilson(sum(held), len(held)) if held else None,
            "summary": summary, "rows": rows, "diagnose_seconds_median": float(np.median([r["seconds"] for r in rows])),
            "seconds": time.perf_counter() - t0}
