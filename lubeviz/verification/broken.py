"""`lubeviz bench broken`: broken measurements of independent records, diagnosed as the CLI does.

Each record is the independent source's (`independent.make_record`, flows 75-125 % Q_T, 12 dB), then broken
the way a cable, a channel map or a spreadsheet breaks a measurement: columns exchanged or negated, a column
copied onto another, a plane (or the whole record) in other units than declared, mains pickup added; or left
clean (the control). The breaks are column operations written here by hand, not the effect library's tables.
Each is diagnosed by `diagnose.run_diagnosis`, the CLI's and the page's one pipeline.

Per kind: right (the mix-up named first or in the ambiguity set; a copied channel or a plane in other units
reported as a measurement fault with no effect fitted; a units slip named with the right units; pickup
named as pickup and not read as whirl; the clean record explained with no finding), wrong alone (one effect
named alone that is not the break), and whether the reported flows' 95 % intervals hold the truth (for the
measurement faults no flows are claimed).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..progress import ProgressFn, silent
from ..units import MLMIN_PER_M3S

# column operations on (x1, y1, x2, y2), by hand: what each mix-up does to the columns a record holds
_MIXUPS = {
    "planes_swapped": lambda c: c[[2, 3, 0, 1]],
    "x_y_swapped": lambda c: c[[1, 0, 3, 2]],
    "x1_y1_swapped": lambda c: c[[1, 0, 2, 3]],
    "x2_y2_swapped": lambda c: c[[0, 1, 3, 2]],
    "x1_inverted": lambda c: c * np.array([-1, 1, 1, 1])[:, None],
    "y1_inverted": lambda c: c * np.array([1, -1, 1, 1])[:, None],
    "x2_inverted": lambda c: c * np.array([1, 1, -1, 1])[:, None],
    "y2_inverted": lambda c: c * np.array([1, 1, 1, -1])[:, None],
    "plane1_inverted": lambda c: c * np.array([-1, -1, 1, 1])[:, None],
    "plane2_inverted": lambda c: c * np.array([1, 1, -1, -1])[:, None],
}
# both probes of one plane reversed or of the other: the same to every invariant but the planes' phase, which
# an unbalance's phase does not fix either way: either is right
_SAME = {"plane1_inverted": {"plane1_inverted", "plane2_inverted"},
         "plane2_inverted": {"plane1_inverted", "plane2_inverted"}}
KINDS = (*_MIXUPS, "copied_channel", "plane_units", "units", "mains", "none")
_UNIT_SLIPS = (("m", "um"), ("um", "mils"), ("mm", "um"))  # (written in, declared as)
_CHANNELS = ("x1", "y1", "x2", "y2")


def broken_record(columns, speed_hz, rate_hz, kind: str, rng: np.random.Generator):
    """The record of `columns` ((4, n) metres, x1 y1 x2 y2) broken as `kind`, and what a diagnosis should say
    of it: {'wiring': fault} / {'finding': kind, 'text': ...} / {'pickup': Hz} / {} (clean)."""
    from ..signals.records import record_from_arrays

    cols, units, expect = np.array(columns, dtype=float), "m", {}
    if kind in _MIXUPS:
        cols, expect = _MIXUPS[kind](cols), {"wiring": kind}
    elif kind == "copied_channel":
        i, j = rng.choice(4, size=2, replace=False)
        cols[j] = cols[i]
        expect = {"finding": "copied_channels", "text": f"{_CHANNELS[min(i, j)]} and {_CHANNELS[max(i, j)]}"}
    elif kind == "plane_units":  # one plane written in mm, the file saying um
        k = int(rng.integers(2))
        cols = cols / 1e-6
        cols[2 * k:2 * k + 2] *= 1e-3
        units, expect = "um", {"finding": "plane_scale", "text": f"plane {k + 1}'s columns look like mm declared as um"}
    elif kind == "units":
        real, said = _UNIT_SLIPS[int(rng.integers(len(_UNIT_SLIPS)))]
        from ..units import length_factor

        cols, units = cols / length_factor(real), said
        expect = {"finding": "units", "text": f"look like {real} declared as {said}"}
    elif kind == "mains":
        f = float(rng.choice([50.0, 60.0]))
        t = np.arange(cols.shape[1]) / rate_hz
        size = float(rng.uniform(0.2, 0.6)) * float(np.std(cols[:2]))
        cols = cols + size * (np.sin(2 * math.pi * f * t + rng.uniform(0, 2 * math.pi)) +
                              0.3 * np.sin(4 * math.pi * f * t + rng.uniform(0, 2 * math.pi)))[None, :] \
            * rng.uniform(0.7, 1.3, 4)[:, None]
        expect = {"pickup": f}
    elif kind != "none":
        raise ValueError(f"unknown break {kind!r}; expected one of {', '.join(KINDS)}")
    rec = record_from_arrays(*cols, speed_hz=speed_hz, sample_rate_hz=rate_hz, units=units)
    return dataclasses.replace(rec, source=f"{kind}.csv"), expect


def judge(d, expect: dict, q_mlmin) -> dict:
    """What the diagnosis `d` got right of a record broken as `expect` says (see the module docstring)."""
    from ..bench.records import _held

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
    from ..bench.records import wilson
    from .independent import IndependentSpec, make_record, thresholds_mlmin

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
                                    rng)
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
