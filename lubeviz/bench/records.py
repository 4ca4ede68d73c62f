"""Rates over many independent records: the figures of BENCHMARKS.md "Identification you can trust" and
"Diagnosis" (`lubeviz bench coverage`, `lubeviz bench diagnose`).

Every record comes from `independent.make_record` (another film mesh and linearization, another rotor
mesh and damping, time integration), never from the identification's own model. Rates are given with
their Wilson 95 % interval.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..errors import LubevizError
from ..progress import ProgressFn, silent
from ..units import MLMIN_PER_M3S
from .workers import append_saved, one_thread, one_thread_each, read_saved


def wilson(k: int, n: int, z: float = 1.959964) -> list[float]:
    """Wilson score interval of a rate k/n."""
    if n == 0:
        return [0.0, 1.0]
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return [max(0.0, c - h), min(1.0, c + h)]


def _rate(flags) -> dict:
    flags = [bool(f) for f in flags]
    return {"rate": float(np.mean(flags)) if flags else None, "k": int(sum(flags)), "n": len(flags),
            "wilson95": wilson(int(sum(flags)), len(flags))}


def _flow_errors(rows) -> dict:
    if "error_pct" not in rows[0]:
        return {}
    each = np.abs([e for r in rows for e in r["error_pct"]])
    below = np.abs([e for r in rows for e, up in zip(r["error_pct"], r["above_qt"]) if not up])
    return {"flow_error_pct_median": float(np.median(each)),
            "flow_error_pct_median_below_qt": float(np.median(below)) if below.size else None}


def _summary(rows) -> dict:
    if not rows:
        return {}
    err = np.array([r["max_abs_error_pct"] for r in rows])
    return {
        "records": len(rows),
        "error_pct_median": float(np.median(err)), "error_pct_p90": float(np.percentile(err, 90)),
        "error_pct_max": float(err.max()),
        # each flow on its own; below its Q_T (a flooded film hardly depends on its supply: its error says little)
        **_flow_errors(rows),
        **{f"coverage_q{k + 1}": _rate(r["holds"][k] for r in rows) for k in range(len(rows[0]["holds"]))},
        # on each side of Q_T (the film's kink: starved below, flooded above)
        **{f"coverage_q{k + 1}_{side}_qt": _rate(r["holds"][k] for r in rows if r["above_qt"][k] == (side == "above"))
           for k in range(len(rows[0]["holds"])) for side in ("below", "above")},
        "flagged": _rate(not r["explained"] for r in rows),
        "off_over_5pct_without_truth_in_alternatives": int(sum(r["max_abs_error_pct"] > 5 and not r["truth_in_alt"]
                                                              for r in rows)),
        "fit_ms_median": float(np.median([r["seconds"] for r in rows]) * 1e3),
    }


BAND_EDGES = (2 / 3, 5 / 6, 16 / 15, 4 / 3)  # the speed bands, over the machine's operating speed (the paper's
# 75 Hz: 50-62.5, 62.5-80, 80-100 Hz; the corpus's speeds, `corpus_speeds`, span the first edge to the last)


def _bands(machine) -> list[tuple[str, float, float]]:
    """(label, low, high) Hz of the rate benches' speed bands on `machine` (the last one closed)."""
    edges = [f * machine.operating_speed for f in BAND_EDGES]
    tol = 1e-9 * machine.operating_speed  # a corpus speed on an edge (the paper's 80 Hz) goes to the band above
    return [(f"{lo:.4g}-{hi:.4g} Hz", lo - tol, hi + (tol if i == len(edges) - 2 else -tol))
            for i, (lo, hi) in enumerate(zip(edges[:-1], edges[1:]))]


def _by_band(out: dict, machine, rows) -> None:
    for label, lo, hi in _bands(machine):
        out[label] = _summary([r for r in rows if lo <= r["speed_hz"] < hi])


def _inside(low, high, value) -> bool:
    """`value` in [low, high]; an upper end None is open."""
    return bool(low <= value <= (math.inf if high is None else high))


def _flow_row(speed_hz: float, q, r) -> dict:
    """One record's row of a rate bench: true flows `q` (ml/min) against the identification `r`."""
    qi = r.q * MLMIN_PER_M3S
    holds = [True if iv is None else _inside(iv[0] * MLMIN_PER_M3S, None if iv[1] is None else iv[1] * MLMIN_PER_M3S,
                                             q[k]) for k, iv in enumerate(r.intervals)]
    return {"speed_hz": speed_hz, "q_mlmin": q.tolist(), "q_id_mlmin": qi.tolist(),
            "max_abs_error_pct": float(np.max(np.abs(qi / q - 1)) * 100), "error_pct": ((qi / q - 1) * 100).tolist(),
            "holds": holds,
            "above_qt": [bool(q[k] > r.q_threshold[k] * MLMIN_PER_M3S) for k in range(len(q))],
            "explained": bool(r.model_explains_data), "chi2": r.chi2, "seconds": r.seconds,
            "truth_in_alt": any(np.all(np.abs(a * MLMIN_PER_M3S / q - 1) < 0.05) for a in r.alternatives)}


def _coverage_budgets(calibrations=(), budgets=()) -> list:
    """[(key, ModelBudget or None)]: the shipped budget (None), each other calibration, each budget of `budgets`
    (dicts of `ModelBudget` values) and the noise alone, in the rows' order."""
    from ..identify.forward.budget import ModelBudget

    variants = [(" ".join(f"{k}={v:g}" for k, v in b.items()), ModelBudget(**b)) for b in budgets]
    return ([("budget", None)] + [(f"calibration {c:g}", ModelBudget(calibration=float(c))) for c in calibrations]
            + variants + [("noise_only", ModelBudget.none())])


def _coverage_rows(machine, spec, calibrations=(), budgets=()) -> dict:
    """One clean record of the coverage corpus made (`independent.make_record`) and identified under each of
    `_coverage_budgets`: {key: row}, or {"not_made": ...} when the source cannot make it (a figure of the bench,
    not its end)."""
    from ..identify.batch import identify_record
    from ..verification.independent import make_record

    try:
        rec = make_record(spec).record
    except LubevizError as exc:
        return {"not_made": {"speed_hz": spec.speed_hz, "q_mlmin": list(spec.flows_mlmin), "error": str(exc)}}
    q = np.array(spec.flows_mlmin)
    return {key: {**_flow_row(spec.speed_hz, q, identify_record(rec, machine, budget=budget).result),
                  "nodes": list(spec.nodes), "probe_angles_deg": [list(a) for a in spec.probe_angles_deg]}
            for key, budget in _coverage_budgets(calibrations, budgets)}


def _coverage_job(machine_path, seed: int, i: int, calibrations, budgets) -> dict:
    """Record i of the corpus `bench_coverage` draws with worker processes: one clean spec from its own stream
    (`np.random.default_rng([seed, i])`), made and identified (`_coverage_rows`)."""
    from ..model.machine import load_machine
    from ..verification.independent import clean_corpus

    spec = clean_corpus(1, np.random.default_rng([int(seed), int(i)]), machine=machine_path)[0]
    return _coverage_rows(load_machine(machine_path), spec, calibrations, budgets)


def bench_coverage(machine_path=None, *, n: int = 120, seed: int = 2026, calibrations=(), budgets=(),
                   processes: int = 1, progress: ProgressFn = silent) -> dict:
    """Clean independent records (seeds x speeds `corpus_speeds` x flows 30-180 % Q_T x centre/outside planes x
    X/Y or 45/135 probes): error, 95 % interval coverage and chi^2 flag rate, with the model budget and with
    the noise alone; by speed band. `calibrations`: other values of the budget's calibration factor to try
    on the same records (the default budget's calibration comes from `bench_budget` at seed 2026, so a
    held-out check uses another seed). `budgets`: other budgets (dicts of `ModelBudget` values, e.g. one
    term scaled alone), likewise.

    `processes` 1: the corpus of every session before (`clean_corpus(n, default_rng(seed))`, one draw after the
    other). More: each record drawn from its own stream (`default_rng([seed, i])`), made and identified by one of
    that many worker processes (one thread each): another corpus for the same seed, the same whatever the count of
    processes. A draw whose operating point must decay is checked on the source's films, minutes a record on a
    machine of four bearings: the rehearsal train's rate needs the workers."""
    from ..identify.forward.budget import ModelBudget
    from ..model.machine import load_machine
    from ..verification.independent import clean_corpus

    if isinstance(processes, bool) or not isinstance(processes, (int, np.integer)) or processes < 1:
        raise ValueError(f"processes = {processes!r}: expected a positive integer")
    t0 = time.perf_counter()
    machine = load_machine(machine_path)
    keys = [key for key, _ in _coverage_budgets(calibrations, budgets)]
    results = {}
    if processes == 1:
        specs = clean_corpus(n, np.random.default_rng(seed), machine=machine_path)
        for i, spec in enumerate(specs):
            results[i] = _coverage_rows(machine, spec, calibrations, budgets)
            progress(i + 1, len(specs), f"{spec.speed_hz:g} Hz" + (" (not made)" if "not_made" in results[i] else ""))
    else:
        from concurrent.futures import ProcessPoolExecutor, as_completed
        from multiprocessing import get_context

        mp = None if machine_path is None else str(machine_path)
        with one_thread_each():
            pool = ProcessPoolExecutor(max_workers=int(processes), mp_context=get_context("spawn"),
                                       initializer=one_thread)
            try:
                futures = {pool.submit(_coverage_job, mp, seed, i, tuple(calibrations), tuple(budgets)): i
                           for i in range(int(n))}
                for f in as_completed(futures):
                    results[futures[f]] = f.result()
                    progress(len(results), int(n), f"record {futures[f] + 1}")
            finally:
                pool.shutdown(wait=True, cancel_futures=True)
    ordered = [results[i] for i in sorted(results)]
    failed = [res["not_made"] for res in ordered if "not_made" in res]
    rows = {key: [res[key] for res in ordered if "not_made" not in res] for key in keys}
    out = {"records": len(ordered) - len(failed), "not_made": failed, "seed": seed, "processes": int(processes),
           "calibration": ModelBudget().calibration, "seconds": time.perf_counter() - t0}
    for key, rr in rows.items():
        out[key] = {"all": _summary(rr)}
        _by_band(out[key], machine, rr)
    out["rows"] = rows["budget"]
    return out


ORBIT_FLOWS = (0.75, 1.25)  # `bench_orbit`'s defaults: each flow over its Q_T, uniform ...
ORBIT_SCALES = (0.5, 1.0)  # ... and the machine's unbalance, times this (the paper's unbalance at 1; its 2X against
# the 1X: docs/notes/large-orbits.md, "What it says about the paper's machine"). Another machine's orbit is large
# at another multiple of its own unbalance (the fan's at 2.5-4: docs/notes/any-machine.md): `scales`.


def orbit_jobs(machine_path=None, *, n: int, seed: int, speed_hz: float | None = None, flows=ORBIT_FLOWS,
               scales=ORBIT_SCALES) -> list:
    """`bench_orbit`'s draws: n pairs (IndependentSpec, unbalance scale), every fluid-film bearing's flow uniform in
    `flows` x its Q_T at `speed_hz` (default the machine's operating speed), the unbalance uniform in `scales` x the
    machine's; record i seeded seed * 1000 + i. On the paper's machine the draws of every session before."""
    from ..model.machine import load_machine
    from ..verification.independent import IndependentSpec, thresholds_mlmin

    speed = float(load_machine(machine_path).operating_speed if speed_hz is None else speed_hz)
    qt = thresholds_mlmin(speed, machine_path)
    rng = np.random.default_rng(seed)
    jobs = []
    for i in range(n):
        q = qt * rng.uniform(*flows, qt.size)
        scale = float(rng.uniform(*scales))
        jobs.append((IndependentSpec(speed_hz=speed, q_mlmin=tuple(float(v) for v in q), seed=seed * 1000 + i,
                                     machine=None if machine_path is None else str(machine_path)), scale))
    return jobs


def bench_orbit(machine_path=None, *, n: int = 12, seed: int = 2026, speed_hz: float | None = None,
                source: str = "time", harmonics=(5, 16), time_rounds: int = 0, workers: int = 2,
                flows=ORBIT_FLOWS, scales=ORBIT_SCALES, rows_path=None, progress: ProgressFn = silent) -> dict:
    """Large-orbit records on any machine (`orbit_record.make_orbit_record`, `source` "time": the time integration,
    every harmonic; "balance": the source's 6-harmonic balance on 200 x 200 films) drawn by `orbit_jobs` (flows
    `flows` x Q_T, the unbalance `scales` x the machine's), identified with `large_orbit` declared at each of
    `harmonics` (and `time_rounds` time rounds after the balance's, `IdentificationSettings.orbit_time_rounds`):
    error, 95 % interval coverage, chi2 flag rate and time per record, with Wilson intervals. Each record is made
    (cached on disk) and identified by one of `workers` worker processes (one thread each). A record the source
    cannot make (no periodic orbit near the linear one, a balance that does not settle) is counted apart
    (`not_made`), not as a miss of the identification. `rows_path`: a JSON-lines file each record's rows are
    appended to as they end; a record already there (the same draw and settings) is not identified again."""
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from multiprocessing import get_context

    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers = {workers!r}: expected a positive integer")
    t0 = time.perf_counter()
    jobs = orbit_jobs(machine_path, n=n, seed=seed, speed_hz=speed_hz, flows=flows, scales=scales)
    hs = tuple(int(h) for h in harmonics)
    mp = None if machine_path is None else str(machine_path)
    args = [(mp, spec, scale, source, hs, int(time_rounds), int(workers) > 1) for spec, scale in jobs]
    keys = [_orbit_key(a) for a in args]
    done = read_saved(rows_path, "key", "rows")  # the records a stopped run identified
    results = {i: done[k] for i, k in enumerate(keys) if k in done}
    progress(len(results), n, f"making and identifying the records ({source})")
    if workers <= 1:
        for i, a in enumerate(args):
            if i not in results:
                _keep(results, i, _orbit_rows(*a), rows_path, keys, progress, n)
    else:
        # spawned workers take the environment as it is when they start (numpy reads it on import): one thread each
        with one_thread_each():
            pool = ProcessPoolExecutor(max_workers=int(workers), mp_context=get_context("spawn"),
                                       initializer=one_thread)
            try:
                futures = {pool.submit(_orbit_rows, *a): i for i, a in enumerate(args) if i not in results}
                for f in as_completed(futures):
                    _keep(results, futures[f], f.result(), rows_path, keys, progress, n)
            finally:
                pool.shutdown(wait=True, cancel_futures=True)  # a Cancelled progress leaves no record running
    ordered = [results[i] for i in range(n)]
    made = [res for res in ordered if "not_made" not in res]
    rows = {h: [res[str(h)] for res in made] for h in hs}
    out = {"records": len(made), "drawn": n, "seed": seed, "speed_hz": jobs[0][0].speed_hz if jobs else speed_hz,
           "source": source, "flows_over_qt": list(flows), "unbalance_scales": list(scales),
           "time_rounds": int(time_rounds), "workers": int(workers), "seconds": time.perf_counter() - t0,
           "not_made": [{"q_mlmin": res["q_mlmin"], "unbalance_scale": res["unbalance_scale"],
                         "error": res["not_made"]} for res in ordered if "not_made" in res]}
    for h, rr in rows.items():
        out[f"harmonics {h}"] = orbit_summary(rr)
    out["rows"] = {str(h): rr for h, rr in rows.items()}
    return out


def _keep(results: dict, i: int, rows: dict, rows_path, keys, progress, n: int) -> None:
    results[i] = rows
    if rows_path is not None:
        append_saved(rows_path, "key", keys[i], "rows", rows)
    progress(len(results), n, f"record {i + 1}")


def _orbit_key(args) -> str:
    """A record's key in `bench_orbit`'s rows file: its draw and the settings it is identified with."""
    import json

    machine_path, spec, scale, source, hs, time_rounds, _ = args
    return json.dumps({"machine": machine_path, "speed_hz": spec.speed_hz, "q_mlmin": list(spec.flows_mlmin),
                       "seed": spec.seed, "scale": scale, "source": source, "harmonics": list(hs),
                       "time_rounds": time_rounds}, sort_keys=True)


def _pct(flows_mlmin, q) -> list:
    return (np.asarray(flows_mlmin) / q * 100 - 100).tolist()


def _orbit_rows(machine_path, spec, scale, source, harmonics, time_rounds, pooled=False) -> dict:
    """`bench_orbit`'s rows of one record, {str(harmonics): row}, or {"not_made": the source's error} (a process of
    its pool runs this; `pooled`: it is one of several, one per core)."""
    from ..effects import parse_effect
    from ..identify.batch import identify_record
    from ..identify.fit.settings import IdentificationSettings
    from ..model.machine import load_machine
    from ..verification.orbit_record import make_orbit_record

    if pooled:
        from ..rotor import orbit_balance

        orbit_balance.FILM_THREADS = 1  # BLAS's threads: the pool's environment (`bench_orbit`)
    machine = load_machine(machine_path)
    q = np.array(spec.flows_mlmin)
    try:
        made = make_orbit_record(spec, unbalance_scale=scale, method=source)
    except LubevizError as exc:  # no periodic orbit the source can make: not a miss of the identification
        return {"not_made": str(exc), "q_mlmin": q.tolist(), "unbalance_scale": scale}
    out = {}
    for h in harmonics:
        try:
            ident = identify_record(made.record, machine, IdentificationSettings(orbit_harmonics=h,
                                                                                 orbit_time_rounds=time_rounds),
                                    effects=(parse_effect("large_orbit"),))
            r = ident.result
        except LubevizError as e:  # a balance that does not settle (or a refusal): a miss, counted, not the end
            out[str(h)] = {"failed": str(e), "q_mlmin": q.tolist(), "unbalance_scale": scale}
            continue
        lo = r.effects["large_orbit"]
        out[str(h)] = {**_flow_row(spec.speed_hz, q, r), "unbalance_scale": scale,
                       "ratio_2x": list(made.truth["ratio_2x"]), "half_order": made.truth.get("half_order"),
                       "signed_error_pct": _pct(r.q * MLMIN_PER_M3S, q),
                       "sigma_pct": (np.asarray(r.q_std) / r.q * 100).tolist(),
                       "warnings": list(ident.warnings)[:5],
                       **({"time_rounds": [{"signed_error_pct_after": _pct(t["flows_after_mlmin"], q),
                                            "gap_1x_percent": t["gap_1x_percent"],
                                            "settled_percent": t["settled_percent"],
                                            "chi2": t["chi2"], "seconds": t["seconds"],
                                            "not_kept": [{"signed_error_pct_at": _pct(o["flows_at_mlmin"], q),
                                                          "signed_error_pct_after": _pct(o["flows_after_mlmin"], q),
                                                          "chi2": o["chi2"], "consistent": o["consistent"]}
                                                         for o in t["not_kept"]]} for t in lo["time_rounds"]],
                          # the time rounds' own intervals (no truncation term, no union with the balance's)
                          "time_round_covered": [_inside(low, high, qk) for (low, high), qk in
                                                 zip(lo["time_round_intervals_mlmin"], q)]}
                          if lo.get("time_rounds") else {})}
    return out


def orbit_summary(rows) -> dict:
    """`bench_orbit`'s figures at one harmonic count from its rows: the error, coverage and flag rates over the
    identifications that finished; `failed`, the rate of those that did not (a balance that did not settle),
    which count as misses in `within_1pct`."""
    done = [r for r in rows if "failed" not in r]
    return {**_summary(done), "records": len(rows), "failed": _rate("failed" in r for r in rows),
            "within_1pct": _rate("failed" not in r and r["max_abs_error_pct"] <= 1.0 for r in rows),
            "sigma_pct_median": float(np.median([max(r["sigma_pct"]) for r in done])) if done else None,
            **({"time_round_coverage": _rate(all(r["time_round_covered"]) for r in timed)}
               if (timed := [r for r in done if "time_round_covered" in r]) else {}),
            "fit_s_median": float(np.median([r["seconds"] for r in done])) if done else None}


STATIC_OIL_RANGE = (0.7, 1.3)  # `bench_static`: the oil's true viscosity over the declared one, uniform


def bench_static(machine_path=None, *, n: int = 100, seed: int = 2026, progress: ProgressFn = silent) -> dict:
    """Records with the static shaft position (SPEC §6 `static: absolute`) and an oil whose viscosity differs
    from the declared one by a factor uniform in STATIC_OIL_RANGE (the corpus of `bench_coverage` otherwise:
    50-100 Hz, flows 30-180 % Q_T, both plane and probe layouts), identified with the oil free on both bearings
    (`viscosity:bearing=both`): the flows' and the factor's error, the 95 % coverage of the flows' profile
    intervals and of the factor's +-1.96 std, the chi^2 flag rate. A draw whose slowest mode does not decay
    with its oil (thinner oil whirls sooner) is drawn again."""
    from ..effects import parse_effect
    from ..identify.batch import identify_record
    from ..model.machine import load_machine
    from ..verification.independent import clean_corpus, make_record, max_growth_rate

    t0 = time.perf_counter()
    machine = load_machine(machine_path)
    rng = np.random.default_rng(seed)
    specs = []
    for _ in range(5):  # batches of draws until n decay with their oil
        for base in clean_corpus(n - len(specs), rng, machine=machine_path, static=True):
            factor = float(rng.uniform(*STATIC_OIL_RANGE))
            spec = dataclasses.replace(base, effects=(f"viscosity:factor={factor:.6g}",))
            if max_growth_rate(spec) < -5.0 / (spec.total_s - spec.duration_s):
                specs.append((spec, factor))
        if len(specs) == n:
            break
    oil = (parse_effect("viscosity:bearing=both"),)
    rows = []
    for i, (spec, factor) in enumerate(specs, start=1):
        rec = make_record(spec).record
        q = np.array([spec.q1_mlmin, spec.q2_mlmin])
        r = identify_record(rec, machine, effects=oil).result
        f, f_std = r.effects["viscosity"]["factor"], r.effects["viscosity"]["factor_std"]
        rows.append({**_flow_row(spec.speed_hz, q, r), "factor": factor, "factor_id": f, "factor_std": f_std,
                     "factor_error_pct": float((f / factor - 1) * 100),
                     "factor_holds": bool(abs(f - factor) <= 1.959964 * f_std)})
        progress(i, len(specs), f"{spec.speed_hz:g} Hz, oil x{factor:.2f}")
    ferr = np.abs([r["factor_error_pct"] for r in rows])
    out = {"records": len(rows), "seed": seed, "oil_range": list(STATIC_OIL_RANGE), "all": _summary(rows),
           "coverage_factor": _rate(r["factor_holds"] for r in rows),
           "factor_error_pct_median": float(np.median(ferr)), "factor_error_pct_p90": float(np.percentile(ferr, 90)),
           "factor_error_pct_max": float(ferr.max()), "seconds": time.perf_counter() - t0}
    _by_band(out, machine, rows)
    out["rows"] = rows
    return out


DIAGNOSE_CASES = (
    ("viscosity", ("viscosity:factor=0.8", "viscosity:factor=0.65")),
    ("clearance", ("clearance:bearing=1,clearance_um=140", "clearance:bearing=1,clearance_um=165")),
    ("unbalance2", ("unbalance2:node=15,ratio=0.3,phase_deg=90", "unbalance2:node=15,ratio=0.6,phase_deg=200")),
    ("pedestals", ("pedestals:bearing=2,mass_kg=50,stiffness_n_m=2e8,damping_ns_m=1e4",
                   "pedestals:bearing=2,mass_kg=50,stiffness_n_m=8e7,damping_ns_m=1e4")),
    ("probe_rotation", ("probe_rotation:plane=1,angle_deg=3", "probe_rotation:plane=1,angle_deg=8")),
    ("probe_gain", ("probe_gain:channel=y2,gain=1.08", "probe_gain:channel=y2,gain=1.2")),
    ("bow", ("bow:node=13,amplitude_um=40,phase_deg=45", "bow:node=13,amplitude_um=90,phase_deg=160")),
    ("seal (not in the library)", ("seal:node=10,kxy_n_m=2e6,kxx_n_m=1e7", "seal:node=10,kxy_n_m=2e6,kxx_n_m=2e7")),
    # the machine's own unbalance scaled: records of `orbit_record` (harmonic balance on the source's films)
    ("large_orbit", ("large_orbit:unbalance_scale=0.6", "large_orbit:unbalance_scale=1")),
)


def bench_diagnose(machine_path=None, *, seeds: int = 2, speed_hz: float = 75.0, candidates=None, cases=None,
                   orbit_source: str = "balance", progress: ProgressFn = silent) -> dict:
    """For each effect and two strengths, independent records (12 dB, flows 75-125 % Q_T, seeded): plain
    identification, then diagnosis; the named effect, the residual and the flow errors before and after.
    `cases`: only the records of these effects (the first word of a DIAGNOSE_CASES name); the flows of the
    others are drawn all the same, so each record is the one of the full run. `orbit_source`: the large-orbit
    records' method (`orbit_record.make_orbit_record`: "balance", or "time" for the time integration)."""
    from ..diagnose import diagnose
    from ..diagnose.loop import OTHER_FORCE
    from ..identify.batch import beyond_1x, record_checks
    from ..identify.forward.chain import ForwardChain
    from ..identify.forward.measured import measure
    from ..model.machine import load_machine
    from ..verification.independent import IndependentSpec, make_record, thresholds_mlmin
    from ..verification.orbit_record import make_orbit_record, make_orbit_records

    t0 = time.perf_counter()
    machine = load_machine(machine_path)
    qt = thresholds_mlmin(speed_hz, machine_path)
    rng = np.random.default_rng(7)
    chain = ForwardChain(machine, speed_hz)
    rows = []
    total = len(DIAGNOSE_CASES) * 2 * seeds
    plan, i = [], 0  # (index, name, level, text, flows): the records to make; the index counts every draw, also
    # those of the cases left out, so each record is the one of the full run
    for name, strengths in DIAGNOSE_CASES:
        for level, text in enumerate(strengths, start=1):
            for s in range(seeds):
                i += 1
                q = qt * rng.uniform(0.75, 1.25, 2)
                if cases is None or name.split(" ")[0] in cases:
                    plan.append((i, name, level, text, q))

    def orbit_job(i, text, q):
        spec = IndependentSpec(speed_hz=speed_hz, q1_mlmin=float(q[0]), q2_mlmin=float(q[1]), seed=100 + i)
        return spec, float(text.rpartition("=")[2])

    # the large-orbit orbits not yet cached, two at once (each is serial)
    make_orbit_records([orbit_job(i, text, q) for i, name, _, text, q in plan if name == "large_orbit"],
                       method=orbit_source)
    for i, name, level, text, q in plan:
        if name == "large_orbit":
            spec, scale = orbit_job(i, text, q)
            rec = make_orbit_record(spec, unbalance_scale=scale, method=orbit_source).record
        else:
            spec = IndependentSpec(speed_hz=speed_hz, q1_mlmin=float(q[0]), q2_mlmin=float(q[1]),
                                   effects=(text,), seed=100 + i)
            rec = make_record(spec).record
        m = measure(rec)
        d = diagnose(chain, m, candidates=candidates, lines=beyond_1x(rec)[0],
                     findings=record_checks([rec], [m], machine))
        truth = name.split(" ")[0]
        named = d.added.effect.effect_name if (d.added is not None and not d.ambiguous) else None
        in_set = truth in ([] if d.added is None else [d.added.effect.effect_name]) + [
            lab.split("[")[0] for lab in d.ambiguous]
        err_b = np.abs(d.before.flow_values() * MLMIN_PER_M3S / q - 1) * 100
        err_a = np.abs(d.final.flow_values() * MLMIN_PER_M3S / q - 1) * 100
        held = _held(d, q / MLMIN_PER_M3S)
        rows.append({"effect": name, "strength": level, "spec": text, "q_mlmin": q.tolist(),
                     "plain_chi2": d.before.chi2, "plain_explained": bool(d.before.explained),
                     "named": named, "added": None if d.added is None else d.added.label,
                     "ambiguous": list(d.ambiguous), "right_first": named == truth,
                     "right_in_set": bool(in_set), "explained_after": d.explained,
                     "chi2_after": None if d.after is None else d.after.chi2,
                     "dof_after": None if d.after is None else d.after.dof,
                     "flow_error_pct_before": err_b.tolist(), "flow_error_pct_after": err_a.tolist(),
                     "truth_held": held,
                     "not_forced": bool((d.added is None and not d.explained) or OTHER_FORCE in d.ambiguous),
                     "verdict": d.verdict, "seconds": d.seconds})
        progress(i, total, f"{name} {level}")
    summary = {}
    for name, _ in DIAGNOSE_CASES:
        for level in (1, 2):
            rr = [r for r in rows if r["effect"] == name and r["strength"] == level]
            if not rr:
                continue
            summary[f"{name} #{level}"] = {
                "spec": rr[0]["spec"], "records": len(rr),
                "plain_flagged": sum(not r["plain_explained"] for r in rr),
                "right_first": sum(r["right_first"] for r in rr), "right_in_set": sum(r["right_in_set"] for r in rr),
                "unexplained": sum(r["added"] is None and not r["plain_explained"] for r in rr),
                "not_forced": sum(r["not_forced"] for r in rr),
                "truth_held": sum(r["truth_held"] for r in rr),
                "flow_error_pct_before_max": float(max(max(r["flow_error_pct_before"]) for r in rr)),
                "flow_error_pct_after_max": float(max(max(r["flow_error_pct_after"]) for r in rr)),
                "chi2_before_median": float(np.median([r["plain_chi2"] for r in rr])),
                "chi2_after_median": (float(np.median([r["chi2_after"] for r in rr]))
                                      if all(r["chi2_after"] is not None for r in rr) else None),
            }
    return {"speed_hz": speed_hz, "seeds": seeds, "orbit_source": orbit_source, "summary": summary, "rows": rows,
            "diagnose_seconds_median": float(np.median([r["seconds"] for r in rows])),
            "seconds": time.perf_counter() - t0}


def _held(d, q_true) -> bool:
    """Whether the flows' reported 95 % intervals hold the truth (every identified flow): the ambiguity set's
    interval when the diagnosis is ambiguous, else the final fit's profile interval. A flow the model file gives
    (a known or flooded supply: no parameter of the fit) is not judged."""
    ivs = d.set_intervals or tuple(d.final.intervals.get(f"q{k + 1}") for k in range(len(q_true)))
    names = getattr(d.final, "names", None)
    for k, iv in enumerate(ivs):
        if names is not None and f"q{k + 1}" not in names:
            continue
        if iv is None or q_true[k] < iv[0] or (iv[1] is not None and q_true[k] > iv[1]):
            return False
    return True


def bench_budget(machine_path=None, *, n: int = 120, seed: int = 2026, progress: ProgressFn = silent) -> dict:
    """The model budget against what it is meant to cover: the feature differences between the model and
    the independent source (clean steady state, no noise) at the true flows of the coverage corpus (same
    n and seed as `bench_coverage`, so its film solves are cached), in units of the budget's predicted
    sigma. The budget holds when the RMS of that ratio lies within a factor of 2 of 1 (0.5-2), per
    feature and per speed band. Also the maximum-likelihood calibration factor of the budget's terms as
    stated (calibration 1): sqrt(sum_r chi2_r / sum_r n_r), chi2_r = d_r^T Sigma_r^-1 d_r (the value
    `ModelBudget.calibration` carries, from this command at seed 2026)."""
    from ..identify.forward.budget import ModelBudget, model_covariance
    from ..identify.forward.chain import ForwardChain
    from ..identify.forward.model import ALL_FEATURES, feature_vector, wrap_difference
    from ..model.machine import load_machine
    from ..verification.independent import clean_corpus, steady_truth

    t0 = time.perf_counter()
    machine = load_machine(machine_path)
    specs = clean_corpus(n, np.random.default_rng(seed), machine=machine_path)
    chains: dict = {}
    rows = []
    for i, spec in enumerate(specs, start=1):
        key = (spec.speed_hz, tuple(spec.nodes), tuple(map(tuple, spec.probe_angles_deg)))
        if key not in chains:
            chains[key] = ForwardChain(machine, spec.speed_hz, spec.nodes, probe_angles_deg=spec.probe_angles_deg)
        chain = chains[key]
        xy = steady_truth(spec)["steady_xy_m"]
        f_true = feature_vector(xy[:, 0], xy[:, 1], ALL_FEATURES)
        theta = np.array([spec.q1_mlmin, spec.q2_mlmin]) / MLMIN_PER_M3S
        sigma = np.sqrt(np.diag(model_covariance(chain, theta, ALL_FEATURES)))
        d = wrap_difference(f_true - chain.features(theta, ALL_FEATURES), ALL_FEATURES)
        z = d / sigma
        cov1 = model_covariance(chain, theta, ALL_FEATURES, ModelBudget(calibration=1.0))
        chi2 = float(d @ np.linalg.lstsq(cov1, d, rcond=1e-12)[0])
        # the static journal position at each bearing centre (SPEC §6), from the rest position (0, -c): the
        # source's film equilibrium on its finer films against the model's, in units of the budget's film term
        truth = steady_truth(spec)
        s_true = np.asarray(truth["journal_positions_m"]) + np.array([[0.0, c] for c in truth["clearance_m"]])
        skey = ("static", spec.speed_hz)
        if skey not in chains:
            chains[skey] = ForwardChain(machine, spec.speed_hz, tuple(chain.rotor.bearing_nodes))
        s_model = chains[skey].output(theta).static
        s_term = ModelBudget().static_position * np.array([[s.bearing.clearance] * 2 for s in chain.sources])
        rows.append({"speed_hz": spec.speed_hz, "q_mlmin": [spec.q1_mlmin, spec.q2_mlmin], "z": z.tolist(),
                     "chi2_as_stated": chi2, "static_difference_um": (1e6 * (s_true - s_model)).ravel().tolist(),
                     "static_z": ((s_true - s_model) / s_term).ravel().tolist()})
        progress(i, len(specs), f"{spec.speed_hz:g} Hz")
    z = np.array([r["z"] for r in rows])
    out = {"points": len(rows), "features": list(ALL_FEATURES),
           "rms_ratio_observed_over_predicted": dict(zip(ALL_FEATURES, np.sqrt(np.mean(z**2, axis=0)).tolist())),
           "median_abs_ratio": dict(zip(ALL_FEATURES, np.median(np.abs(z), axis=0).tolist())),
           "calibration_ml": float(np.sqrt(sum(r["chi2_as_stated"] for r in rows) / (len(rows) * len(ALL_FEATURES)))),
           "calibration_in_use": ModelBudget().calibration, "seed": seed,
           "by_band": {}, "seconds": time.perf_counter() - t0, "rows": rows}
    sd = np.abs(np.array([r["static_difference_um"] for r in rows]))
    sz = np.array([r["static_z"] for r in rows])
    out["static"] = {  # per component sx1, sy1, sx2, sy2: the film term alone (the rest reading's is apart)
        "term_um": [1e6 * ModelBudget().static_position * s.bearing.clearance for s in chain.sources],
        "abs_difference_um_median": np.median(sd, axis=0).tolist(), "abs_difference_um_max": sd.max(axis=0).tolist(),
        "rms_ratio_observed_over_term": np.sqrt(np.mean(sz**2, axis=0)).tolist()}
    for label, lo, hi in _bands(machine):
        zb = np.array([r["z"] for r in rows if lo <= r["speed_hz"] < hi])
        if zb.size:
            out["by_band"][label] = dict(zip(ALL_FEATURES, np.sqrt(np.mean(zb**2, axis=0)).tolist()))
    return out
