"""`lubeviz identify FILE...` and `lubeviz reproduce --location center|outside` (SPEC §7)."""

from __future__ import annotations

import re
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
    p.add_argument("--effect", action="append", default=[], metavar="NAME[:key=value,...]",
                   help="declare an effect (SPEC §7, repeatable): the parameters given are held, the others "
                        "fitted with the flows, e.g. viscosity:bearing=both or probe_rotation:plane=1,angle_deg=4")
    p.add_argument("--oil-check", action="store_true",
                   help="for a record at one speed without the static position, give the flows' intervals with the "
                        "oil viscosity free within x0.75-1.33 (builds the tables of that range once if needed; the time: "
                        "BENCHMARKS.md \"Dimensionless tables\")")
    p.add_argument("--orbit-harmonics", type=int, default=None, metavar="N",
                   help="with --effect large_orbit: harmonics of the periodic orbit, 5-32 (default 16; diagnose "
                        "uses 5). More harmonics follow the film's sharp turn where it is thinnest, at more time a "
                        "record; the flows' sigma carries the truncation at any count. Error and time per count: "
                        "BENCHMARKS.md \"Rates over time-integration records\"")
    p.add_argument("--orbit-time-rounds", type=int, default=None, metavar="N",
                   help="with --effect large_orbit: after the balance, N rounds (0-5, default 0) that integrate the "
                        "model in time at the answer (one time integration of several minutes each, two near "
                        "Q_T) and take the balance's truncation out of it. Error and time: BENCHMARKS.md "
                        "\"Time rounds on all 12 records\"")
    p.set_defaults(run=run_identify)

    p = sub.add_parser("reproduce", help="the paper's 64-case protocol, Tables 4-8")
    add_common(p)
    p.add_argument("--location", choices=("center", "outside"), required=True,
                   help="measurement planes: the bearing centres or the machine's outside nodes (the paper's 6, 20 or 5, 21)")
    p.add_argument("--mode", choices=("both", "paper", "best"), default="both")
    p.add_argument("--seed", type=int, default=2024, help="noise seed of the protocol")
    p.set_defaults(run=run_reproduce)


def _check_effects(args) -> None:
    """The declared effects parsed against the machine of the first record (a bearing, plane or support may be
    named as in its model file); a record that cannot be read is left to the identification's own message."""
    from ..effects import parse_effects
    from ..errors import LubevizError
    from ..identify.batch import read_for_machine

    if not any(re.search(r"\b(bearing|plane|support)\s*=\s*(?!\d|both\b|all\b)", e) for e in args.effect):
        parse_effects(args.effect)  # no part named: no record read for it
        return
    try:
        machine = read_for_machine(args.files[0], args.machine)[1]
    except LubevizError:
        machine = None
    parse_effects(args.effect, machine)


def run_identify(args) -> dict:
    from ..identify.batch import identify_files
    from ..identify.fit.settings import IdentificationSettings
    from ..identify.output.export import result_dict

    t0 = time.perf_counter()
    _check_effects(args)  # a bad effect is a bad-input error before any work
    settings = IdentificationSettings(mode=args.mode, oil_check="always" if args.oil_check else "warn",
                                      **({} if args.orbit_harmonics is None else
                                         {"orbit_harmonics": args.orbit_harmonics}),
                                      **({} if args.orbit_time_rounds is None else
                                         {"orbit_time_rounds": args.orbit_time_rounds}))
    results = identify_files(args.files, args.machine, settings, workers=args.workers, progress=StderrBar(),
                             effect_specs=tuple(args.effect))
    for path, item, _ in results:
        for w in () if item is None else tuple(item.warnings) + tuple(item.result.warnings):
            sys.stderr.write(f"lubeviz identify: {path}: warning: {w}\n")
    if len(results) == 1:
        path, item, err = results[0]
        if err is not None:
            raise InputError(err)
        out = result_dict(item)
        out["seconds_total"] = time.perf_counter() - t0
        _text(args, results)
        return out
    records = [result_dict(item) if err is None else {"file": path, "error": err} for path, item, err in results]
    failed = [r for r in records if "error" in r]
    if failed:
        sys.stderr.write(f"lubeviz identify: {len(failed)} of {len(records)} records failed: "
                         + "; ".join(f"{r['file']}: {r['error']}" for r in failed)[:500] + "\n")
    _text(args, results)
    return {"records": records, "failed": len(failed), "seconds": time.perf_counter() - t0}


def _text(args, results) -> None:
    """Without --json: what a person reads (every number of the JSON stays in --json)."""
    if args.json:
        return
    from ..identify.output.export import error_text, result_text

    for path, item, err in results:
        print("\n".join(result_text(item) if err is None else error_text(path, err)))
    args.json_text_done = True


def run_reproduce(args) -> dict:
    from ..identify.paper.reproduce import PAPER_RESULTS, report_lines, reproduce
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
