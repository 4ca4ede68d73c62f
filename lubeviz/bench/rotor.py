"""Rotor performance figures of BENCHMARKS.md (`lubeviz bench rotor`): medians of repeated runs, seconds.

The paper's rotor at its operating speed on fixed bearing coefficients (the film's at Q_T, 75 Hz, below),
so the figures time the rotor alone. When ROSS is importable the same operations run in ROSS on the same
rotor (`lubeviz.rotor.ross_model`) in the same process, and each `ross_*` figure comes with its ratio
ROSS / lubeviz.
"""

from __future__ import annotations

import itertools
import math
import statistics
import time

import numpy as np

from ..model.machine import load_machine
from ..progress import ProgressFn, silent
from ..rotor import (
    machine_unbalance,
    modal_analysis,
    rotor_from_machine,
    unbalance_response,
)
from ..rotor.stability import Supply, machine_stability
from ..units import MLMIN_PER_M3S

# Bearing 1 of the paper's machine at 75 Hz, 546 ml/min (~Q_T), 100x100 mesh (BENCHMARKS "Mesh study"):
# K in N/m, C in N s/m, SPEC §1 sign. Representative values; the timings do not depend on them.
PAPER_K = np.array([[204.2e6, 124.6e6], [-104.2e6, 56.3e6]])
PAPER_C = np.array([[509e3, -724e3], [-113e3, 543e3]])
RESPONSE_NODES = (5, 6, 20, 21)


def _median_per_call(fn, repeat: int, number: int = 1) -> tuple[float, object]:
    """Median over `repeat` runs of the mean time of `number` back-to-back calls."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            out = fn()
        times.append((time.perf_counter() - t0) / number)
    return statistics.median(times), out


def bench_rotor(machine_file=None, repeat: int = 5, include_ross: bool = True,
                progress: ProgressFn = silent) -> dict:
    """Rotor timings (s): assembly, one steady unbalance response, one modal analysis; ROSS alongside.

    Keys: `assembly_s`, `unbalance_response_s` (one speed, nodes 5, 6, 20, 21, rotor assembled),
    `modal_analysis_s` (all modes, dense), and with ROSS `ross_version`, `ross_assembly_s`,
    `ross_unbalance_response_s`, `ross_modal_analysis_s` and `*_ratio` = ROSS / lubeviz; `ross` is
    null with `ross_unavailable` (the reason) when ROSS cannot be imported.
    """
    machine = load_machine(machine_file)
    omega = 2.0 * math.pi * machine.operating_speed
    bearings = [(PAPER_K, PAPER_C)] * len(machine.bearings)
    unbalance = machine_unbalance(machine)
    total = 6 if include_ross else 3
    out: dict = {"speed_hz": machine.operating_speed, "repeat": repeat, "n_dof": None,
                 "response_nodes": list(RESPONSE_NODES)}

    progress(1, total, "rotor assembly")
    out["assembly_s"], rotor = _median_per_call(lambda: rotor_from_machine(machine), repeat, 20)
    out["n_dof"] = rotor.n_dof
    progress(2, total, "unbalance response")
    out["unbalance_response_s"], _ = _median_per_call(
        lambda: unbalance_response(rotor, omega, unbalance, bearings, nodes=RESPONSE_NODES), repeat, 200)
    progress(3, total, "modal analysis")
    out["modal_analysis_s"], modal = _median_per_call(lambda: modal_analysis(rotor, omega, bearings), repeat, 3)
    out["modes_below_300_hz"] = int(np.sum(modal.damped_frequencies_hz < 300.0))
    # the paper's record: 15 s from rest at dt = 1e-4 s, last 5 s kept, nodes 6 and 20
    from ..rotor.transient import linear_system, unbalance_time_response

    out["time_system_setup_s"], system = _median_per_call(lambda: linear_system(rotor, omega, bearings), repeat)
    out["time_simulation_15s_exact_s"], _ = _median_per_call(
        lambda: unbalance_time_response(rotor, omega, unbalance, bearings, system=system), repeat)
    out["time_simulation_15s_newmark_s"], _ = _median_per_call(
        lambda: unbalance_time_response(rotor, omega, unbalance, bearings, system=system, method="newmark"),
        max(1, repeat // 2))
    if not include_ross:
        return out

    from ..rotor.ross_model import (
        RossUnavailable,
        import_ross,
        ross_lateral_eigenvalues,
        ross_rotor,
        ross_unbalance_response,
    )

    try:
        rs = import_ross()
    except RossUnavailable as exc:
        out.update(ross=None, ross_unavailable=str(exc))
        return out
    out["ross"] = True
    out["ross_version"] = getattr(rs, "__version__", "?")
    progress(4, total, "ROSS assembly")
    out["ross_assembly_s"], rrotor = _median_per_call(lambda: ross_rotor(machine, bearings), repeat)
    out["ross_n_dof"] = int(rrotor.ndof)
    # ROSS caches run_modal and the frequency response per speed (methodtools.lru_cache): shift the speed by
    # a relative 1e-12 per call so each call computes, as ours does.
    fresh = itertools.count(1)
    progress(5, total, "ROSS unbalance response")
    u = unbalance[0]
    out["ross_unbalance_response_s"], _ = _median_per_call(
        lambda: ross_unbalance_response(rrotor, omega * (1 + 1e-12 * next(fresh)), u, RESPONSE_NODES), repeat, 20)
    progress(6, total, "ROSS modal analysis")
    out["ross_modal_analysis_s"], _ = _median_per_call(
        lambda: ross_lateral_eigenvalues(rrotor, omega * (1 + 1e-12 * next(fresh))), repeat)
    for key in ("assembly", "unbalance_response", "modal_analysis"):
        out[f"{key}_ratio"] = out[f"ross_{key}_s"] / out[f"{key}_s"]
    return out


def bench_stability(machine_file=None, fractions=(0.5, 0.75, 1.0, 1.25, 1.5), fixed_flow_mlmin=546.0,
                    speed_step_hz: float = 5.0, progress: ProgressFn = silent) -> dict:
    """First critical speed and instability threshold per supply (BENCHMARKS "Stability"), one run each.

    Speeds from the machine's speed_min to speed_max in `speed_step_hz` steps; supply q/Q_T(speed) for each
    fraction, and the fixed flow `fixed_flow_mlmin` (the paper's 546 ml/min; None to skip).
    """
    machine = load_machine(machine_file)
    speeds_hz = np.arange(machine.speed_min, machine.speed_max + 1e-9, speed_step_hz)
    op = machine.operating_speed
    supplies = [(f"{f:g} Q_T", Supply.threshold_fraction(f)) for f in fractions]
    if fixed_flow_mlmin is not None:
        supplies.append((f"{fixed_flow_mlmin:g} ml/min", Supply.flow(fixed_flow_mlmin / MLMIN_PER_M3S)))
    cases = []
    for k, (name, supply) in enumerate(supplies):
        res = machine_stability(machine, 2.0 * math.pi * speeds_hz, supply)
        first = res.modes.critical_speeds[0] if res.modes.critical_speeds else None
        unstable = res.modes.unstable_mode
        fc = None if first is None else first.speed_hz
        th = None if unstable is None else unstable.speed_hz
        cases.append({
            "supply": name,
            "first_critical_hz": fc,
            "damping_ratio_at_first_critical": None if first is None else first.damping_ratio,
            "instability_threshold_hz": th,
            "unstable_mode_frequency_hz": None if unstable is None else unstable.frequency_hz,
            "unstable_mode_whirl": None if unstable is None else unstable.whirl,
            "operating_speed_between": fc is not None and fc < op and (th is None or op < th),
            "seconds": res.seconds,
        })
        progress(k + 1, len(supplies), name)
    return {"speeds_hz": [float(speeds_hz[0]), float(speeds_hz[-1]), speed_step_hz], "operating_speed_hz": op,
            "cases": cases}
