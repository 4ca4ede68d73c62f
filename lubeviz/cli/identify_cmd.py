"""`lubeviz identify FILE...` and `lubeviz reproduce --location center|outside` (SPEC §7)."""

from __future__ import annotations

import sys
import time


from ..errors import InputError
from ..progress import StderrBar
from .common import add_common


def register(sub) -> None:
    p = sub.add_parser("identify", help="identify the supply flows Q1, Q2 from measured records")
    add_common(p)
    p.add_argument("files", nargs="+", metavar="FILE", help="records (.csv, .npz, .mat; SPEC §6)")
    p.add_argument("--mode", choices=("best", "paper"), default="best", help="search method (default: best)")
    p.add_argument("--workers", type=int, default=None, help="processes for many records (default: all cores)")
    p.set_defaults(run=run_identify)

    p = sub.add_parser("reproduce", help="the paper's 64-case protocol, Tables 4-8")
    add_common(p)
    p.add_argument("--location", choices=("center", "outside"), required=True,
                   help="measurement planes: bearing centres (nodes 6, 20) or outside them (5, 21)")
    p.add_argument("--mode", choices=("both", "paper", "best"), default="both")
    p.add_argument("--seed", type=int, default=2024, help="noise seed of the protocol")
    p.set_defaults(run=run_reproduce)


def result_dict(item) -> dict:
    r = item.result
    names = list(r.features_names)
    out = {
        "file": item.file, "q1_mlmin": r.q[0] * 6e7, "q2_mlmin": r.q[1] * 6e7,
        "q1_std_mlmin": None if r.q_std is None else r.q_std[0] * 6e7,
        "q2_std_mlmin": None if r.q_std is None else r.q_std[1] * 6e7,
        "q_threshold_mlmin": (r.q_threshold * 6e7).tolist(),
        "verdict": [r.verdict(0), r.verdict(1)],
        "converged": r.converged, "iterations": r.iterations, "starts_tried": r.starts_tried,
        "path": (r.path * 6e7).tolist(), "paths": [(p * 6e7).tolist() for p in r.paths],
        "features_measured": dict(zip(names, r.features_measured.tolist())),
        "features_model": dict(zip(names, r.features_model.tolist())),
        "residual": r.residual.tolist(), "total_error": r.total_error, "mode": r.mode,
        "model_evaluations": r.evaluations, "nodes": list(item.nodes), "speed_hz": item.speed_hz,
        "unique": r.unique, "alternatives_mlmin": [(a * 6e7).tolist() for a in r.alternatives],
        "chi2": r.chi2, "dof": r.dof, "p_value": r.p_value, "model_explains_data": r.model_explains_data,
        "message": r.message, "seconds": r.seconds,
    }
    return out


def run_identify(args) -> dict:
    from ..identify.batch import identify_files

    t0 = time.perf_counter()
    results = identify_files(args.files, args.machine, args.mode, workers=args.workers, progress=StderrBar())
    if len(results) == 1:
        path, item, err = results[0]
        if err is not None:
            raise InputError(err)
        out = result_dict(item)
        out["seconds_total"] = time.perf_counter() - t0
        return out
    records = [result_dict(item) if err is None else {"file": path, "error": err} for path, item, err in results]
    failed = [r for r in records if "error" in r]
    if failed:
        sys.stderr.write(f"lubeviz identify: {len(failed)} of {len(records)} records failed: "
                         + "; ".join(f"{r['file']}: {r['error']}" for r in failed)[:500] + "\n")
    return {"records": records, "failed": len(failed), "seconds": time.perf_counter() - t0}


def run_reproduce(args) -> dict:
    from ..identify.reproduce import PAPER_RESULTS, report_lines, reproduce
    from ..model.machine import load_machine

    machine = load_machine(args.machine)
    modes = ("paper", "best") if args.mode == "both" else (args.mode,)
    out = reproduce(machine, args.location, modes=modes, progress=StderrBar(), seed=args.seed)
    first = out["results"][modes[0]][1]
    result = dict(first)
    result["mode"] = modes[0]
    for mode in modes[1:]:
        result[mode] = out["results"][mode][1]
    result.update({"location": args.location, "nodes": list(out["nodes"]), "paper": PAPER_RESULTS[args.location],
                   "tables_seconds": out["tables_seconds"], "records_seconds": out["records_seconds"],
                   "seconds": out["seconds"]})
    if not args.json:
        for line in report_lines(args.location, out["results"]):
            print(line)
        print(f"total {out['seconds']:.1f} s (tables {out['tables_seconds']:.1f} s, "
              f"records {out['records_seconds']:.1f} s)")
        args.json_text_done = True
    return result
