"""Performance figures of BENCHMARKS.md (`lubeviz bench ...`): medians of repeated runs, in seconds."""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from ..film.equilibrium import find_equilibrium, flooded_threshold
from ..film.feed import Feed, setup_problem
from ..film.linearize import fixed_pattern_coefficients
from ..film.solver import solve, solve_sor
from ..film.sweep import sweep_supply
from ..model.machine import load_machine
from ..progress import ProgressFn, silent
from ..units import MLMIN_PER_M3S

PAPER_LOAD = np.array([0.0, -3272.8])


def _median(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def bench_film(machine_file=None, repeat: int = 5, progress: ProgressFn = silent) -> dict:
    """Film-model timings on the machine's bearing 1 at its operating speed (paper: 100 x 100)."""
    machine = load_machine(machine_file)
    b = machine.bearings[0]
    omega = 2.0 * math.pi * machine.operating_speed
    q_t, eq_t = flooded_threshold(b, omega, PAPER_LOAD)
    feed = Feed.flow(0.8 * q_t)
    eq = find_equilibrium(b, omega, PAPER_LOAD, feed, start=eq_t.position)
    problem = setup_problem(b, omega, eq.position, feed)
    results = {"mesh": f"{b.n_circumferential}x{b.n_axial}", "groove_refinement": b.groove_refinement,
               "columns_solved": problem.mesh.n_circ, "bearing": b.name,
               "speed_hz": machine.operating_speed, "q_mlmin": 0.8 * q_t * MLMIN_PER_M3S, "repeat": repeat}
    progress(1, 7, "film solve, cold")
    results["solve_cold_s"], sol = _median(lambda: solve(problem), repeat)
    results["solve_cold_linear_solves"] = sol.iterations
    progress(2, 7, "film solve, warm")
    near = setup_problem(b, omega, eq.position * 1.01, feed)
    results["solve_warm_s"], sol_w = _median(lambda: solve(near, warm=sol), repeat)
    results["solve_warm_linear_solves"] = sol_w.iterations
    progress(3, 7, "SOR baseline")
    solve_sor(problem, max_sweeps=2)  # compile / load the numba cache outside the timing
    relax = tuned_relaxation(problem)
    t_sor, sor = _median(lambda: solve_sor(problem, relax=relax, tol=1e-8), max(1, repeat // 2))
    results.update({"sor_relaxation": relax, "sor_solve_s": t_sor, "sor_sweeps": sor.iterations,
                    "sor_vs_active_set_force_diff": float(np.max(np.abs(sor.force - sol.force)) /
                                                          np.max(np.abs(sol.force)))})
    t_gs, gs = _median(lambda: solve_sor(problem, relax=1.0, tol=1e-8, max_sweeps=20000), 1)
    results.update({"gauss_seidel_solve_s": t_gs, "gauss_seidel_sweeps": gs.iterations,
                    "gauss_seidel_converged": gs.converged})
    progress(4, 7, "equilibrium, cold")
    results["equilibrium_cold_s"], e_cold = _median(
        lambda: find_equilibrium(b, omega, PAPER_LOAD, feed), repeat)
    results["equilibrium_cold_newton_steps"] = e_cold.iterations
    progress(5, 7, "equilibrium, warm")
    neighbour = find_equilibrium(b, omega, PAPER_LOAD, Feed.flow(0.8 * q_t * 1.02), start=eq.position, warm=eq.film)
    results["equilibrium_warm_s"], _ = _median(
        lambda: find_equilibrium(b, omega, PAPER_LOAD, feed, start=neighbour.position, warm=neighbour.film), repeat)
    progress(6, 7, "coefficients")
    results["coefficients_s"], _ = _median(lambda: fixed_pattern_coefficients(eq.film), repeat)
    results["equilibrium_plus_coefficients_warm_s"] = results["equilibrium_warm_s"] + results["coefficients_s"]
    progress(7, 7, "40-flow table")
    flows = np.linspace(0.25, 2.0, 40) * q_t
    results["table_40_flows_s"], _ = _median(lambda: sweep_supply(b, omega, PAPER_LOAD, flows), max(1, repeat // 2))
    return results


def bench_mesh(machine_file=None) -> dict:
    """Mesh study 50x50 -> 100x100 -> 200x200 of bearing 1 (see film.mesh_study)."""
    from ..film.mesh_study import mesh_study

    machine = load_machine(machine_file)
    feeds = {"starved 400": Feed.flow(400 / MLMIN_PER_M3S), "546": Feed.flow(546 / MLMIN_PER_M3S),
             "over 700": Feed.flow(700 / MLMIN_PER_M3S), "flooded": Feed.flooded()}
    return {"rows": mesh_study(machine.bearings[0], 2.0 * math.pi * machine.operating_speed, PAPER_LOAD, feeds)}


def bench_smoothness(machine_file=None, secant_amplitude: float | None = None,
                     progress: ProgressFn = silent) -> dict:
    """Roughness of equilibrium, K and C over 273..819 ml/min in 1 ml/min steps (see film.roughness).

    Reports the fixed-pattern tangent (the old figure, key "fixed-pattern"), the smoothed-
    complementarity tangent (key "smoothed", film.smoothed) and the sub-cell tangent (key "subcell",
    film.subcell, the default of find_equilibrium / sweep_supply) at the same equilibria, each also
    with the fits split at Q_T and outside the Q_T band (see film.roughness); with `secant_amplitude`
    (m) also the secant coefficients (key "secant").
    """
    from ..film.roughness import supply_roughness

    machine = load_machine(machine_file)
    return supply_roughness(machine.bearings[0], 2.0 * math.pi * machine.operating_speed, PAPER_LOAD,
                            273 / MLMIN_PER_M3S, 819 / MLMIN_PER_M3S, 1 / MLMIN_PER_M3S, progress=progress,
                            secant_amplitude=secant_amplitude)


def tuned_relaxation(problem, candidates=(1.5, 1.7, 1.8, 1.85, 1.9, 1.95, 1.97)) -> float:
    """The over-relaxation factor with the fewest SOR sweeps on `problem` (coarse search)."""
    best = None
    for w in candidates:
        s = solve_sor(problem, relax=w, tol=1e-8, max_sweeps=20000)
        if s.converged and (best is None or s.iterations < best[1]):
            best = (w, s.iterations)
    return best[0] if best else 1.0
