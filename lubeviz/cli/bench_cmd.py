"""`lubeviz bench film` (SPEC §7): performance figures as JSON."""

from __future__ import annotations

import math

from ..bench.film import bench_film, bench_mesh, bench_smoothness
from ..progress import StderrBar
from .common import add_common, finite_float


def register(sub) -> None:
    p = sub.add_parser("bench", help="performance figures of BENCHMARKS.md")
    add_common(p)
    p.add_argument("what", choices=("film", "mesh", "smoothness", "rotor", "stability", "identify", "flows", "table",
                                    "coverage", "budget", "diagnose", "read", "broken", "loop"),
                   help="film: solver timings; mesh: mesh study; smoothness: roughness of K, C over Q; "
                        "rotor: assembly, response, modes, 15 s record (ROSS alongside); stability: critical speed and "
                        "instability threshold across 50-150 %% Q_T; "
                        "identify: tables, one identification (and --reproduce: the 128 cases; "
                        "--accuracy: tables vs direct solves); "
                        "flows: a machine of N bearings (default the fan): its first identification on an empty "
                        "cache, the fit of its N flows, diagnoses of five of its records (--extra-bearing: N + 1); "
                        "table: the dimensionless (S, Q/Q_T) table: full-range cold build, size, accuracy over "
                        "speed 5-150 Hz x viscosity x0.5-2 x clearance x0.8-1.5, cold first identification; "
                        "coverage: error, 95 %% interval coverage and chi2 flag rate over --records clean independent "
                        "records (with and without the model budget, by speed band); budget: the model budget "
                        "against the model-vs-independent feature differences; diagnose: every effect at two "
                        "strengths on independent records, named / ambiguous / unexplained, flows before and after; "
                        "read: the record reader's peak memory on a ~195 MB CSV and .npz, each read in a fresh process; "
                        "broken: --records independent records broken as a measurement breaks (columns exchanged or "
                        "negated, a copied channel, units slips, mains pickup, or clean), diagnosed: right / wrong "
                        "alone / intervals holding; "
                        "loop: the residual loop's rates over >= 150 independent cases (clean, each effect at two "
                        "strengths, sets, pairs, out of the library): confusion matrix, rates with Wilson intervals, "
                        "silent wrong answers, time per diagnosis")
    p.add_argument("--records", type=int, default=120, help="coverage: independent records (default 120)")
    p.add_argument("--static", action="store_true",
                   help="coverage: records with the static shaft position and the oil's viscosity x0.7-1.3 of the "
                        "declared, identified with the oil free: flows' and oil's error and coverage")
    p.add_argument("--large-orbit", action="store_true",
                   help="coverage: large-orbit records at the machine's operating speed (each flow --orbit-flows x "
                        "its Q_T, the unbalance --unbalance-scales x the machine's, made by --orbit-source), "
                        "identified with large_orbit declared at each --orbit-harmonics: error, coverage, chi2 flag "
                        "rate, time (give --records; minutes per record, cached; --rows to go on after a stop)")
    p.add_argument("--orbit-flows", default="0.75,1.25", metavar="LOW,HIGH",
                   help="coverage --large-orbit: each flow drawn uniform in LOW-HIGH x its Q_T (default 0.75,1.25)")
    p.add_argument("--unbalance-scales", default="0.5,1", metavar="LOW,HIGH",
                   help="coverage --large-orbit: the unbalance drawn uniform in LOW-HIGH x the machine's (default "
                        "0.5,1: the paper's orbits; another machine's are large at another multiple, the fan's "
                        "at 2.5,4)")
    p.add_argument("--orbit-harmonics", default="5,16",
                   help="coverage --large-orbit: the balance's harmonics to identify with, comma-separated (default 5,16)")
    p.add_argument("--orbit-time-rounds", type=int, default=0, metavar="N",
                   help="coverage --large-orbit: time rounds after the balance's (0-5, default 0; minutes each a record)")
    p.add_argument("--orbit-workers", type=int, default=2, metavar="N",
                   help="coverage --large-orbit: records made and identified on N processes at once (default 2)")
    p.add_argument("--seed", type=int, default=2026,
                   help="coverage, budget, loop: the corpus seed (2026: the budget's calibration corpus; another seed "
                        "is a held-out check)")
    p.add_argument("--calibrations", default="",
                   help="coverage: other budget calibration factors to try on the same records, comma-separated")
    p.add_argument("--budgets", default="",
                   help="coverage: model budgets to try on the same records, each as NAME=VALUE pairs of "
                        "ModelBudget (e.g. 'coefficient_k=0.0025,shaft_damping_high=3'), budgets separated by ';'")
    p.add_argument("--seeds", type=int, default=2, help="diagnose: records per effect and strength (default 2)")
    p.add_argument("--cases", default="",
                   help="diagnose: only these effects' records, comma-separated (e.g. 'large_orbit'); the others' "
                        "flows are still drawn, so each record is the one of the full run")
    p.add_argument("--orbit-source", choices=("balance", "time"), default=None,
                   help="diagnose, coverage --large-orbit: how the large-orbit records are made: harmonic balance on "
                        "the source's 200 x 200 films (diagnose's default), or the time integration on the declared "
                        "films (coverage's default; every harmonic; minutes "
                        "per record, cached)")
    p.add_argument("--n-clean", type=int, default=40, help="loop: clean records among the cases (default 40)")
    p.add_argument("--processes", type=int, default=None,
                   help="loop: cases made and diagnosed at once, one worker process each (default 2); coverage: "
                        "records drawn, made and identified at once (default 1: the corpus of one stream; more: "
                        "each record its own stream, another corpus for the same seed)")
    p.add_argument("--limit", type=int, default=None,
                   help="loop: only the first N cases (drawn round-robin over the kinds; the same cases as the "
                        "full run's)")
    p.add_argument("--rows", default=None, metavar="PATH",
                   help="loop, coverage --large-orbit: append each case's (record's) rows to this JSON-lines file "
                        "as it ends, and skip those it already holds (a long run goes on where a stopped one ended)")
    p.add_argument("--no-ross", action="store_true", help="rotor: skip the side-by-side ROSS timings")
    p.add_argument("--extra-bearing", action="store_true",
                   help="flows: the machine's first [[supports]] replaced by a sleeve bearing (N + 1 flows)")
    p.add_argument("--reproduce", action="store_true",
                   help="identify: also time the paper's whole protocol, both locations, both modes (cold tables)")
    p.add_argument("--accuracy", action="store_true",
                   help="identify: also measure the tables' error in fb and phi against direct solves")
    p.add_argument("--secant-amplitude-um", type=finite_float, default=None,
                   help="smoothness: use secant coefficients over +-this amplitude (um) instead of the tangent")
    p.add_argument("--points", type=int, default=200,
                   help="table: random operating points of the accuracy measurement")
    p.add_argument("--repeat", type=int, default=5, help="repetitions (the median is reported)")
    p.set_defaults(run=run_bench)


def run_bench(args) -> dict:
    if args.repeat < 1:
        raise ValueError(f"--repeat {args.repeat}: expected at least 1")
    if args.what == "read":
        from ..bench.read import bench_read

        return bench_read()
    if args.what == "mesh":
        return bench_mesh(args.machine)
    if args.what == "smoothness":
        amp = args.secant_amplitude_um
        if amp is not None and amp <= 0.0:
            raise ValueError(f"--secant-amplitude-um {amp:g}: expected a positive amplitude")
        return bench_smoothness(args.machine, None if amp is None else amp * 1e-6, progress=StderrBar())
    if args.what == "rotor":
        from ..bench.rotor import bench_rotor

        return bench_rotor(args.machine, repeat=args.repeat, include_ross=not args.no_ross, progress=StderrBar())
    if args.what == "stability":
        from ..bench.rotor import bench_stability

        return bench_stability(args.machine, progress=StderrBar())
    if args.what == "identify":
        from ..bench.identify import bench_identify

        return bench_identify(args.machine, repeat=args.repeat, reproduce_all=args.reproduce, accuracy=args.accuracy,
                              progress=StderrBar())
    if args.what == "flows":
        from ..bench.flows import bench_flows

        return bench_flows(args.machine or "models/three_bearing_fan.toml", repeat=args.repeat,
                           extra_bearing=args.extra_bearing, progress=StderrBar())
    if args.what == "table":
        from pathlib import Path

        import lubeviz
        from ..identify.tables.accuracy import bench_table

        if args.points < 1:
            raise ValueError(f"--points {args.points}: expected at least 1")
        record = Path(lubeviz.__file__).resolve().parents[1] / "assets" / "sample_record.csv"
        return bench_table(args.machine, points=args.points, identify_record=record if record.exists() else None,
                           progress=StderrBar())
    if args.what == "broken":
        from ..bench.broken import bench_broken

        if args.records < 1:
            raise ValueError(f"--records {args.records}: expected at least 1")
        return bench_broken(args.machine, n=args.records, seed=args.seed, progress=StderrBar())
    if args.what == "loop":
        from ..bench.loop import bench_loop

        if args.n_clean < 0:
            raise ValueError(f"--n-clean {args.n_clean}: expected 0 or more")
        args.processes = 2 if args.processes is None else args.processes
        if args.processes < 1:
            raise ValueError(f"--processes {args.processes}: expected at least 1")
        if args.limit is not None and args.limit < 1:
            raise ValueError(f"--limit {args.limit}: expected at least 1")
        args.json = True  # rows and nested rates: only JSON reads them (stdout, with or without --json)
        return bench_loop(args.machine, n_clean=args.n_clean, seed=args.seed, processes=args.processes,
                          limit=args.limit, rows_path=args.rows, progress=StderrBar())
    if args.what in ("coverage", "budget", "diagnose"):
        from ..bench import records as vb

        if args.what == "coverage":
            if args.records < 1:
                raise ValueError(f"--records {args.records}: expected at least 1")
            try:
                cal = [float(c) for c in args.calibrations.split(",") if c.strip()]
            except ValueError:
                raise ValueError(f"--calibrations {args.calibrations!r}: expected numbers separated by commas") from None
            if any(not (0.0 < c <= 10.0) for c in cal):
                raise ValueError(f"--calibrations {args.calibrations!r}: expected factors in (0, 10]")
            if args.large_orbit:
                if cal or args.budgets.strip() or args.static:
                    raise ValueError("--large-orbit: its records are identified with large_orbit declared under the "
                                     "model budget; --static, --calibrations and --budgets do not apply")
                try:
                    hs = tuple(int(h) for h in args.orbit_harmonics.split(",") if h.strip())
                except ValueError:
                    raise ValueError(f"--orbit-harmonics {args.orbit_harmonics!r}: expected integers separated by "
                                     "commas") from None
                if not hs or any(not 5 <= h <= 32 for h in hs):
                    raise ValueError(f"--orbit-harmonics {args.orbit_harmonics!r}: expected harmonics in 5-32")
                if not 0 <= args.orbit_time_rounds <= 5:
                    raise ValueError(f"--orbit-time-rounds {args.orbit_time_rounds}: expected 0-5")
                if args.orbit_workers < 1:
                    raise ValueError(f"--orbit-workers {args.orbit_workers}: expected at least 1")
                flows = _range("--orbit-flows", args.orbit_flows, 0.05, 5.0)
                scales = _range("--unbalance-scales", args.unbalance_scales, 0.0, 50.0)
                return vb.bench_orbit(args.machine, n=args.records, seed=args.seed, source=args.orbit_source or "time",
                                      flows=flows, scales=scales, rows_path=args.rows,
                                      harmonics=hs, time_rounds=args.orbit_time_rounds, workers=args.orbit_workers,
                                      progress=StderrBar())
            if args.static:
                if cal or args.budgets.strip():
                    raise ValueError("--static: its records are identified with the oil free under the model budget; "
                                     "--calibrations and --budgets apply to the clean coverage corpus only")
                return vb.bench_static(args.machine, n=args.records, seed=args.seed, progress=StderrBar())
            processes = 1 if args.processes is None else args.processes
            if processes < 1:
                raise ValueError(f"--processes {processes}: expected at least 1")
            return vb.bench_coverage(args.machine, n=args.records, seed=args.seed, calibrations=cal,
                                     budgets=_budgets(args.budgets), processes=processes, progress=StderrBar())
        if args.what == "budget":
            return vb.bench_budget(args.machine, n=args.records, seed=args.seed, progress=StderrBar())
        if args.seeds < 1:
            raise ValueError(f"--seeds {args.seeds}: expected at least 1")
        cases = tuple(c.strip() for c in args.cases.split(",") if c.strip())
        known = [name.split(" ")[0] for name, _ in vb.DIAGNOSE_CASES]
        unknown = [c for c in cases if c not in known]
        if unknown:
            raise ValueError(f"--cases {args.cases!r}: unknown {', '.join(unknown)}; expected some of "
                             f"{', '.join(dict.fromkeys(known))}")
        return vb.bench_diagnose(args.machine, seeds=args.seeds, cases=cases or None,
                                 orbit_source=args.orbit_source or "balance",
                                 progress=StderrBar())
    return bench_film(args.machine, repeat=args.repeat, progress=StderrBar())


def _budgets(text: str) -> list[dict]:
    """--budgets: 'name=value,name=value;name=value' -> one dict of ModelBudget values per budget."""
    from ..identify.forward.budget import ModelBudget

    out = []
    for part in (p.strip() for p in text.split(";")):
        if not part:
            continue
        values = {}
        for item in part.split(","):
            name, eq, value = item.partition("=")
            name = name.strip()
            if not eq or name not in ModelBudget.param or name == "name":
                known = ", ".join(n for n in ModelBudget.param if n != "name")
                raise ValueError(f"--budgets {text!r}: {item.strip()!r} is not NAME=VALUE of a budget term ({known})")
            try:
                values[name] = float(value)
            except ValueError:
                raise ValueError(f"--budgets {text!r}: {name} = {value.strip()!r} is not a number") from None
        try:
            ModelBudget(**values)
        except ValueError as exc:
            raise ValueError(f"--budgets {text!r}: {exc}") from None
        out.append(values)
    return out


def _range(option: str, text: str, low: float, high: float) -> tuple[float, float]:
    """`text` "LOW,HIGH" as two numbers with low < LOW <= HIGH <= high (else a ValueError naming `option`)."""
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"{option} {text!r}: expected two numbers LOW,HIGH") from None
    if not (low < lo <= hi <= high) or not all(math.isfinite(v) for v in (lo, hi)):
        raise ValueError(f"{option} {text!r}: expected {low:g} < LOW <= HIGH <= {high:g}")
    return lo, hi
