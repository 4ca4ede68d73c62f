"""Timings of a machine of N fluid-film bearings (issue 37): its first identification on an empty cache, the fit of
its N flows on warm tables, and the diagnosis of a few of its records.

`lubeviz bench flows --machine PATH` (add `--extra-bearing` for N + 1: the file's first constant-coefficient
support replaced by a sleeve bearing like its first one, e.g. the fan with four sleeve bearings). Records are made
by the identification's own chain at fractions of each bearing's Q_T (timings, not rates: the rates come from the
independent source, `lubeviz bench coverage --machine`).
"""

from __future__ import annotations

import os
import re
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..model.files import load_machine
from ..progress import ProgressFn, silent

FRACTIONS = (0.8, 1.2, 1.0, 0.9, 1.3, 0.7)  # each bearing's flow in the records, x its Q_T
EFFECTS = ("", "probe_rotation:plane=1,angle_deg=5", "probe_gain:channel=y2,gain=1.1", "clearance:bearing=1,clearance_um=95",
           "viscosity:factor=0.8")


def with_extra_bearing(path) -> Path:
    """A copy of the model file `path` (in a temporary folder) whose first [[supports]] is a sleeve bearing like its
    first [[bearings]] (radius from the shaft there): N + 1 fluid-film bearings."""
    text = Path(path).read_text(encoding="utf-8")
    support = re.search(r"\[\[supports\]\]\n(?:(?!\n\[).)*", text, flags=re.S)
    bearing = re.search(r"\[\[bearings\]\]\n(?:(?!\n\[).)*", text, flags=re.S)
    if support is None or bearing is None:
        raise InputError(f"{path}: --extra-bearing needs a [[supports]] and a [[bearings]] table to copy")
    node = int(re.search(r"^node = (\d+)", support.group(0), flags=re.M).group(1))
    machine = load_machine(path)
    radius = machine.elements[min(node - 1, len(machine.elements) - 1)].diameter * 500.0
    block = re.sub(r"^name = .*$", 'name = "sleeve (in place of the support)"', bearing.group(0), flags=re.M)
    block = re.sub(r"^node = \d+", f"node = {node}", block, flags=re.M)
    block = re.sub(r"^radius_mm = .*$", f"radius_mm = {radius:g}", block, flags=re.M)
    out = Path(tempfile.mkdtemp(prefix="lubeviz-extra-")) / f"{Path(path).stem}_extra_bearing.toml"
    out.write_text(text.replace(support.group(0), block), encoding="utf-8")
    return out


def bench_flows(machine_path, *, repeat: int = 3, extra_bearing: bool = False, cold: bool = True,
                progress: ProgressFn = silent) -> dict:
    from ..diagnose.pipeline import run_diagnosis
    from ..effects import parse_effect
    from ..identify.batch import identify_record
    from ..identify.fit.least_squares import fit, forget_searches
    from ..identify.forward.chain import ForwardChain, simulate
    from ..identify.forward.measured import measure

    path = with_extra_bearing(machine_path) if extra_bearing else Path(machine_path)
    machine = load_machine(path)
    planes = machine.measurement_planes
    nodes, angles = [p.node for p in planes], [p.probe_angles_deg for p in planes]
    out: dict = {"machine": machine.name, "n_flows": len(machine.bearings), "n_planes": len(planes)}

    def record(chain, effect: str, seed: int):
        theta = chain.start()
        theta[:chain.n_flows] = [FRACTIONS[k % len(FRACTIONS)] * q for k, q in enumerate(chain.q_threshold)]
        if effect:
            chain = chain.with_effects((parse_effect(effect).hold(),))
        return simulate(chain, theta, snr_db=12.0, rng=np.random.default_rng(seed))

    if cold:  # the first identification of a machine never seen: tables built into an empty cache
        before = os.environ.get("LUBEVIZ_CACHE_DIR")
        with tempfile.TemporaryDirectory(prefix="lubeviz-cold-") as tmp:
            os.environ["LUBEVIZ_CACHE_DIR"] = tmp
            try:
                calls = []
                t0 = time.perf_counter()
                chain = ForwardChain(machine, machine.operating_speed, nodes, probe_angles_deg=angles,
                                     progress=lambda *a: calls.append(a))
                rec = record(chain, "", 1)
                identify_record(rec, machine, progress=lambda *a: calls.append(a))
                out["first_identification_empty_cache_s"] = time.perf_counter() - t0
                out["first_identification_progress_calls"] = len(calls)
            finally:
                if before is None:
                    os.environ.pop("LUBEVIZ_CACHE_DIR", None)
                else:
                    os.environ["LUBEVIZ_CACHE_DIR"] = before
    progress(0, 3, "tables (user cache)")
    chain = ForwardChain(machine, machine.operating_speed, nodes, probe_angles_deg=angles)
    meas = measure(record(chain, "", 2))
    times = []
    for _ in range(repeat):
        forget_searches()  # each fit searches as a first one does
        t0 = time.perf_counter()
        res = fit(chain, meas)
        times.append(time.perf_counter() - t0)
    out["fit_s"] = statistics.median(times)
    out["fit_evaluations"] = res.evaluations
    truth = [FRACTIONS[k % len(FRACTIONS)] * q for k, q in enumerate(chain.q_threshold)]
    out["fit_largest_error_pct"] = float(np.max(np.abs(res.flow_values() / np.array(truth) - 1)) * 100)
    progress(1, 3, "diagnoses")
    diag = {}
    for k, spec in enumerate(EFFECTS):
        rec = record(chain, spec, 10 + k)
        t0 = time.perf_counter()
        run = run_diagnosis([rec], machine)
        diag[spec or "clean"] = {"seconds": time.perf_counter() - t0, "outcome": run.diagnosis.outcome,
                                 "added": None if run.diagnosis.added is None else run.diagnosis.added.label}
    seconds = [d["seconds"] for d in diag.values()]
    out["diagnose"] = diag
    out["diagnose_median_s"] = statistics.median(seconds)
    out["diagnose_max_s"] = max(seconds)
    progress(3, 3, "done")
    return out
