"""`lubeviz diagnose FILE...` (SPEC §7): the residual loop, records of one `set:` together."""

from __future__ import annotations

import sys
import time

from ..errors import InputError
from ..progress import StderrBar
from .common import add_common




def register(sub) -> None:
    p = sub.add_parser("diagnose", help="find what the model lacks: residual -> candidate effects -> flows again")
    add_common(p)
    p.add_argument("files", nargs="+", metavar="FILE", help="records (.csv, .npz, .mat; SPEC §6); a set together")
    p.add_argument("--effects", default=None, metavar="NAME,NAME",
                   help="restrict the library to these effects (default: all), e.g. viscosity,pedestals")
    p.add_argument("--report", default=None, metavar="FILE.html",
                   help="write a self-contained HTML report (one record or set; with several, FILE gets -1, -2...)")
    p.add_argument("--level", type=float, default=0.01, help="significance level of the chi-square test (0.01)")
    for key, head in (("asset", "asset or tag"), ("location", "location"), ("operator", "operator"),
                      ("comment", "comment")):  # report.WORK_ORDER_FIELDS, without importing the numerics here
        p.add_argument(f"--{key}", default=None, metavar="TEXT",
                       help=f"the work order's {head}, printed at the top of the --report")
    p.set_defaults(run=run_diagnose)


def _candidates(text):
    from ..effects import EFFECTS

    if text is None:
        return None
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise InputError("--effects: expected comma-separated effect names")
    for n in names:
        if n not in EFFECTS:
            EFFECTS.parse(n)  # raises with the closest name
        if not EFFECTS[n].diagnosed:
            raise InputError(f"--effects: {n} is not fitted by a diagnosis (oil_temperature is the viscosity "
                             "in °C: give viscosity; a diagnosed factor is also told as a temperature)")
    return [EFFECTS[n] for n in names]


def run_diagnose(args) -> dict | list:
    from ..api import DiagnosisSettings, diagnose
    from ..diagnose import diagnosis_dict
    from ..diagnose.settings import REPORT_MAP_POINTS
    from ..identify.batch import machine_for, read_for_machine
    from ..signals.records import check_set, group_records

    if not 0 < args.level < 0.5:
        raise InputError(f"--level {args.level}: expected a probability between 0 and 0.5")
    candidates = _candidates(args.effects)
    t0 = time.perf_counter()
    records = [read_for_machine(f, args.machine)[0] for f in args.files]
    groups = group_records(records)
    bar = StderrBar()
    out = []
    for g, group in enumerate(groups, start=1):
        if len(group) > 1:
            check_set(group)
        machine, notes = machine_for(group[0], args.machine)
        settings = DiagnosisSettings(level=args.level, map_points=REPORT_MAP_POINTS if args.report else 0)
        run = diagnose(group, machine, settings, candidates=candidates, progress=bar)
        d, inputs = run.diagnosis, run.inputs
        label = "+".join(str(r.source) for r in group)
        item = diagnosis_dict(d, file=label)
        item["warnings"] = list(notes) + list(inputs.notes)
        for w in item["warnings"]:
            sys.stderr.write(f"lubeviz diagnose: warning: {w}\n")
        if args.report:
            from ..diagnose.report import WORK_ORDER_FIELDS, report_maps, write_report

            maps = report_maps(run.maps, d)
            path = args.report if len(groups) == 1 else args.report.replace(".html", f"-{g}.html")
            work_order = {key: getattr(args, key) for key, _ in WORK_ORDER_FIELDS}
            write_report(d, path, record=group[0], machine_name=machine.name,
                         bearing_nodes=[b.node for b in machine.bearings], maps=maps, work_order=work_order)
            item["report"] = path
        out.append(item)
    if not args.json:
        for item in out:
            print(f"{item['file']}: {item['verdict']}")
        args.json_text_done = True
    if len(out) == 1:
        out[0]["seconds_total"] = time.perf_counter() - t0
        return out[0]
    return out
