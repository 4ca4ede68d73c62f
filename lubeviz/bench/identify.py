"""`lubeviz bench identify`: tables cold and warm, one identification, the whole 128-case reproduction,
and (`--accuracy`) the tables' error in fb and φ against direct solves."""

from __future__ import annotations

import statistics
import tempfile
import time

import numpy as np

from ..model.machine import load_machine
from ..progress import ProgressFn, silent
from ..identify.tables.cache import machine_tables
from ..identify.forward.model import ALL_FEATURES, ForwardModel
from ..identify.forward.measured import measure
from ..identify.fit.least_squares import forget_searches
from ..identify.paper.newton import identify
from ..identify.fit.settings import IdentificationSettings
from ..units import MLMIN_PER_M3S


def bench_identify(machine_path=None, *, repeat: int = 5, reproduce_all: bool = False, accuracy: bool = False,
                   progress: ProgressFn = silent) -> dict:
    from ..signals.synthesize import synthesize_record
    from ..identify.paper.reproduce import reproduce

    machine = load_machine(machine_path)
    out: dict = {"machine": machine.source}
    with tempfile.TemporaryDirectory(prefix="lubeviz-bench-") as tmp:
        t0 = time.perf_counter()
        tables = machine_tables(machine, directory=tmp, progress=progress)
        out["tables_cold_s"] = time.perf_counter() - t0
        warm = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            machine_tables(machine, directory=tmp)
            warm.append(time.perf_counter() - t0)
        out["tables_warm_s"] = statistics.median(warm)
        out["table_points"] = int(tables[0].q.size)
        t0 = time.perf_counter()
        model = ForwardModel(machine, tables, tuple(machine.center_nodes))
        out["forward_model_setup_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        for _ in range(1000):
            model.features(450 / MLMIN_PER_M3S, 600 / MLMIN_PER_M3S, ALL_FEATURES)
        out["one_model_evaluation_s"] = (time.perf_counter() - t0) / 1000
        g = np.linspace(0.25, 2.0, 100)
        t0 = time.perf_counter()
        model.features(g[:, None] * model.q_threshold[0], g[None, :] * model.q_threshold[1], ALL_FEATURES)
        out["map_100x100_s"] = time.perf_counter() - t0
        rec = synthesize_record(machine, (448.5 / MLMIN_PER_M3S, 604.5 / MLMIN_PER_M3S), rng=np.random.default_rng(0))
        for mode in ("paper", "best"):
            times = []
            for _ in range(repeat):
                forget_searches()  # each identification searches as a first one does
                t0 = time.perf_counter()
                identify(model, measure(rec, ALL_FEATURES), IdentificationSettings(mode=mode))
                times.append(time.perf_counter() - t0)
            out[f"identification_{mode}_s"] = statistics.median(times)
        out["fit"] = bench_fit(machine, tables, rec, repeat=repeat)
        if accuracy:
            out["interpolation_error"] = table_accuracy(machine, tables)
        if reproduce_all:
            for loc in ("center", "outside"):
                t0 = time.perf_counter()
                r = reproduce(machine, loc, tables=tables, progress=progress)
                out[f"reproduce_{loc}"] = {mode: {k: v for k, v in summ.items() if k != "cases"}
                                           for mode, (_, summ) in r["results"].items()}
                out[f"reproduce_{loc}_s"] = time.perf_counter() - t0
            out["reproduce_all_with_cold_tables_s"] = (out["tables_cold_s"] + out["reproduce_center_s"]
                                                       + out["reproduce_outside_s"])
    return out


def table_accuracy(machine, tables) -> dict:
    """Each table's fb/φ error against direct solves at every midpoint and reference flow, below,
    across and above the groove-filling band, next to issue 4's target (a tenth of the noise floor)."""
    from ..identify.tables.accuracy import GROOVE_BAND_MLMIN, NOISE_FB_REL, NOISE_PHI_DEG, interpolation_error

    out: dict = {"target_fb_pct": 10.0 * NOISE_FB_REL, "target_phi_deg": 0.1 * NOISE_PHI_DEG,
                 "band_mlmin_from_q_threshold": list(GROOVE_BAND_MLMIN)}
    for t in tables:
        t0 = time.perf_counter()
        e = interpolation_error(machine, t)
        out[f"bearing_{t.bearing + 1}"] = {"nodes": list(e.nodes), "flows": int(e.flows.size),
                                           **e.regions(t.q_threshold), "seconds": time.perf_counter() - t0}
    return out


def bench_fit(machine, tables, record, *, repeat: int = 5) -> dict:
    """The fit on named parameters (`fit.fit`): the global search with intervals, the local part alone,
    one evaluation of the chain with an effect, an identification with one free effect parameter, and the
    first identification at a speed not seen before (tables of the geometry already built)."""
    from ..effects import parse_effect
    from ..identify.batch import identify_record
    from ..identify.forward.chain import ForwardChain
    from ..identify.fit.least_squares import _lm, _parts, _Problem, _scales, fit

    def median(fn):
        times = []
        for _ in range(repeat):
            forget_searches()
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return statistics.median(times)

    chain = ForwardChain(machine, machine.operating_speed, tuple(machine.center_nodes), tables=tables)
    meas = measure(record, ALL_FEATURES)
    out = {"global_search_and_intervals_s": median(lambda: fit(chain, meas)),
           "global_search_no_intervals_s": median(lambda: fit(chain, meas, intervals=False))}
    parts, noise = _parts([chain], [meas], None)
    res = fit(chain, meas, intervals=False)
    prob = _Problem(parts, _Problem(parts, np.eye(len(noise)), [0, 1]).model_cov(res.values, None, noise), [0, 1])
    lo, hi = chain.bounds()
    out["local_refinement_s"] = median(lambda: _lm(prob, res.values * 1.02, lo, hi, _scales(chain)))
    rot = chain.with_effects((parse_effect("probe_rotation:plane=1"),))
    theta = np.array([*res.values[:2], 2.0])
    t0 = time.perf_counter()
    for _ in range(1000):
        rot.features(theta, ALL_FEATURES)
    out["one_evaluation_with_an_effect_s"] = (time.perf_counter() - t0) / 1000
    out["fit_with_one_free_effect_parameter_s"] = median(lambda: fit(rot, meas))
    from ..identify.forward.chain import simulate

    speed = machine.operating_speed * 1.0731  # a speed no table view exists for yet (the slices do)
    rec2 = simulate(ForwardChain(machine, speed, tuple(machine.center_nodes)), res.values[:2],
                    rng=np.random.default_rng(1))
    t0 = time.perf_counter()
    identify_record(rec2, machine)
    out["first_identification_at_a_new_speed_s"] = time.perf_counter() - t0
    return out
