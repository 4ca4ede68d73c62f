"""How well a coefficient table stands in for direct film solves, measured where it matters: fb and φ.

The identification compares simulated and measured fb and φ (SPEC §5), so a table is good enough
when the fb and φ it gives differ from those of direct equilibrium solves by much less than the
noise of a measured fb and φ. `interpolation_error` measures that difference at flows between the
table's nodes (where interpolation is worst) and at the paper's reference flows, at the bearing
centres and outside the bearings, with the other bearing held at a fixed flow.

The noise floor (`NOISE_FB_REL`, `NOISE_PHI_DEG`): the standard deviation of fb (relative) and φ over
seeds of a 5 s record at 12 dB SNR (the paper's protocol), measured with `noise_floor`.

What the difference contains: (1) the interpolation error of the spline, which falls like h^4 with
the node spacing h where the coefficients are smooth; (2) the fast change of slope of K(Q), C(Q) as the
groove pressurizes just above Q_T (on the uniform mesh, kinks at mesh-dependent flows; smooth with the
groove's columns refined), which a spline only follows with short steps (tables.DENSE_BAND); (3) the film's own roughness
in Q: the sub-cell tangent's residual staircase (BENCHMARKS "Smoothness in the supply flow") is in the direct
solves, and a smooth table cannot follow it, however dense. So away from the band the difference levels off at (3).

The target is a tenth of the noise floor (`NOISE_FB_REL`, `NOISE_PHI_DEG`) in fb and in phi. Measured with
`lubeviz bench identify --accuracy` (100 x 100 mesh, 75 Hz, nodes 6, 20, 5, 21, all midpoints between nodes and
the reference flows) below, across and above the band GROOVE_BAND_MLMIN: BENCHMARKS "Coefficient tables: accuracy
against direct solves" (with the uniform mesh's and the former 71-flow grid's figures for comparison); guarded by
tests/identify/test_tables.py. The choice of the grid (its points and its step in the band):
docs/notes/dimensionless-tables.md ("Ratio grid") and supply.py; why the band was hard and the earlier grids:
docs/notes/identification-history.md.

Over the operating range (`range_accuracy`, `lubeviz bench table`): the tables are views of the
dimensionless (S, Q/Q_T) table (dimensionless.py), so their error has a third part, (4) the cubic in
ln S between slices (and the film's roughness in S). Measured at 200 random points (speed 5-150 Hz,
viscosity x0.5-2, clearance x0.8-1.5, both bearings, bearing 1 at 25-200 % of its Q_T; nodes 6, 20, 5,
21, the per-point worst node): see BENCHMARKS.md, "Dimensionless tables" (the ln S step behind (4):
docs/notes/dimensionless-tables.md). The fixed target (a tenth of
the 75 Hz noise floor) is strict away from 75 Hz: where the backward component |Zb| nearly vanishes
fb = |Zf| / |Zb| is ill-conditioned, and its noise grows in proportion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...errors import InputError
from ...film.equilibrium import flooded_threshold
from ...film.sweep import sweep_supply
from ...rotor.assembly import rotor_from_machine
from ...rotor.response import machine_unbalance, unbalance_response
from ...rotor.statics import bearing_static_loads
from .supply import CoefficientTable
from ...units import MLMIN_PER_M3S

# The paper's reference flows (SPEC §5), ml/min.
REFERENCE_FLOWS_MLMIN = (409.5, 448.5, 487.5, 526.5, 565.5, 604.5, 643.5, 682.5)

# The band around Q_T where the groove pressurizes (ml/min from Q_T), as in BENCHMARKS "Smoothness".
GROOVE_BAND_MLMIN = (-5.0, 25.0)
_STATS = {"median": np.median, "p90": lambda a: np.percentile(a, 90), "max": np.max}

# Noise of the features at 12 dB SNR over 5 s at 75 Hz, the paper's machine: one standard deviation
# over 50 seeds (`noise_floor`) with both bearings at Q_T, bearing centres (nodes 6, 20). It varies
# with the flows and the node, smallest outside a starved bearing: `noise_floor` at the corners
# (409.5/682.5 ml/min) of the paper's protocol measures it there.
NOISE_FB_REL = 3.3e-3
NOISE_PHI_DEG = 0.079


@dataclass(frozen=True)
class InterpolationError:
    """fb and φ on the table vs on direct solves at `flows` (m^3/s), per flow (rows) and node (columns)."""

    bearing: int
    flows: np.ndarray
    nodes: tuple[int, ...]
    fb_table: np.ndarray
    fb_direct: np.ndarray
    phi_table: np.ndarray  # rad
    phi_direct: np.ndarray  # rad
    coefficient_error: np.ndarray  # per flow: max over the 8 entries of |table - direct| / max|K| (or |C|)

    @property
    def fb_rel(self) -> np.ndarray:
        return np.abs(self.fb_table / self.fb_direct - 1.0)

    @property
    def phi_deg(self) -> np.ndarray:
        """|Δφ| in degrees, with φ taken modulo 180° (the orbit's major axis has no sign)."""
        d = np.degrees(self.phi_table - self.phi_direct)
        return np.abs((d + 90.0) % 180.0 - 90.0)

    @property
    def max_fb_rel(self) -> float:
        return float(self.fb_rel.max())

    @property
    def median_fb_rel(self) -> float:
        return float(np.median(self.fb_rel))

    @property
    def max_phi_deg(self) -> float:
        return float(self.phi_deg.max())

    @property
    def median_phi_deg(self) -> float:
        return float(np.median(self.phi_deg))

    def regions(self, q_threshold: float, band_mlmin=GROOVE_BAND_MLMIN) -> dict:
        """Median, 90th percentile and max of the fb (%) and phi (deg) errors below, across and above
        the band Q_T + band_mlmin (ml/min) where the groove pressurizes, up to BASE_TOP x Q_T (the identification's
        box), and "far" beyond it (reached when an effect lowers Q_T: thicker oil); None for an empty region."""
        from .supply import BASE_TOP

        dq = (self.flows - q_threshold) * MLMIN_PER_M3S
        far = self.flows > BASE_TOP * q_threshold * (1 + 1e-12)  # (below BASE_BOTTOM: in "below", and as accurate)
        lo, hi = band_mlmin
        out = {}
        for name, sel in (("below", dq < lo), ("band", (dq >= lo) & (dq <= hi)), ("above", (dq > hi) & ~far),
                          ("far", far)):
            if not sel.any():
                out[name] = None
                continue
            fb, phi = 100.0 * self.fb_rel[sel], self.phi_deg[sel]
            out[name] = {"flows": int(sel.sum()),
                         **{f"fb_pct_{k}": float(f(fb)) for k, f in _STATS.items()},
                         **{f"phi_deg_{k}": float(f(phi)) for k, f in _STATS.items()}}
        return out

    def summary(self) -> dict:
        """Max and median errors, and the max as a fraction of the noise floor."""
        return {"max_fb_rel": self.max_fb_rel, "median_fb_rel": self.median_fb_rel,
                "max_phi_deg": self.max_phi_deg, "median_phi_deg": self.median_phi_deg,
                "max_fb_over_noise": self.max_fb_rel / NOISE_FB_REL,
                "max_phi_over_noise": self.max_phi_deg / NOISE_PHI_DEG,
                "max_coefficient_error": float(self.coefficient_error.max())}


def midpoint_flows(table: CoefficientTable) -> np.ndarray:
    """Flows halfway between consecutive table nodes (m^3/s): where a spline is least accurate."""
    return 0.5 * (table.q[1:] + table.q[:-1])


def default_flows(table: CoefficientTable) -> np.ndarray:
    """Midpoints plus the paper's reference flows that lie inside the table (m^3/s), ascending."""
    ref = np.array(REFERENCE_FLOWS_MLMIN) / MLMIN_PER_M3S
    ref = ref[(ref >= table.q_min) & (ref <= table.q_max)]
    return np.unique(np.concatenate([midpoint_flows(table), ref]))


def _relative_coefficient_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    scale = np.abs(b).reshape(b.shape[0], -1).max(axis=1)
    return np.abs(a - b).reshape(a.shape[0], -1).max(axis=1) / scale


def interpolation_error(machine, table: CoefficientTable, flows: Sequence[float] | None = None, *,
                        other_flow: float | None = None, nodes: Sequence[int] | None = None,
                        rotor=None) -> InterpolationError:
    """fb and φ with `table`'s bearing on interpolated vs directly solved coefficients.

    `flows` (m^3/s): default `default_flows(table)`. The other bearing sits at `other_flow` (default
    its own Q_T), solved directly once. `nodes`: default the centre and outside nodes (6, 20, 5, 21).
    """
    k = table.bearing
    if len(machine.bearings) != 2 or not 0 <= k < 2:
        raise InputError(f"interpolation_error needs a two-bearing machine; table of bearing {k + 1}")
    flows = default_flows(table) if flows is None else np.sort(np.asarray(flows, dtype=float))
    if flows.ndim != 1 or flows.size == 0:
        raise InputError(f"flows {flows!r}: expected a non-empty 1-D array of flows (m^3/s)")
    nodes = tuple(machine.center_nodes) + tuple(machine.outside_nodes) if nodes is None else tuple(nodes)
    rotor = rotor_from_machine(machine) if rotor is None else rotor
    omega = table.omega
    loads = bearing_static_loads(machine)
    other = 1 - k
    if other_flow is None:
        other_flow, _ = flooded_threshold(machine.bearings[other], omega, loads[other])
    other_kc = sweep_supply(machine.bearings[other], omega, loads[other], [other_flow])
    other_pair = (other_kc.K[0], other_kc.C[0])
    direct = sweep_supply(machine.bearings[k], omega, loads[k], flows)
    K_tab, C_tab = table.coefficients(flows)
    unb = machine_unbalance(machine)

    def features(K, C):
        fb, phi = [], []
        for i in range(flows.size):
            pairs = [None, None]
            pairs[k], pairs[other] = (K[i], C[i]), other_pair
            r = unbalance_response(rotor, omega, unb, pairs, nodes=nodes)
            fb.append(r.fb)
            phi.append(r.phi)
        return np.array(fb), np.array(phi)

    fb_t, phi_t = features(K_tab, C_tab)
    fb_d, phi_d = features(direct.K, direct.C)
    coef = np.maximum(_relative_coefficient_error(K_tab, direct.K), _relative_coefficient_error(C_tab, direct.C))
    return InterpolationError(bearing=k, flows=flows, nodes=nodes, fb_table=fb_t, fb_direct=fb_d,
                              phi_table=phi_t, phi_direct=phi_d, coefficient_error=coef)


@dataclass(frozen=True)
class NoiseFloor:
    """Standard deviation over seeds of fb (relative) and φ (degrees) per node, at `flows` (m^3/s)."""

    flows: tuple[float, float]
    nodes: tuple[int, ...]
    fb_rel_std: np.ndarray
    phi_deg_std: np.ndarray
    seeds: int


def noise_floor(machine, flows: Sequence[float], *, seeds: int = 50, nodes: Sequence[int] | None = None,
                snr_db: float = 12.0, duration_s: float = 5.0) -> NoiseFloor:
    """Scatter of the measured features over `seeds` noisy steady-state records (the paper's protocol)."""
    from ...rotor.film_bearings import film_bearings
    from ...signals.features import record_features
    from ...signals.synthesize import synthesize_record

    if seeds < 2:
        raise InputError(f"seeds = {seeds}; need at least 2 to estimate a standard deviation")
    nodes = tuple(machine.center_nodes) if nodes is None else tuple(nodes)
    fb = film_bearings(machine, flows)
    rotor = rotor_from_machine(machine)
    vec = []
    for seed in range(seeds):
        rec = synthesize_record(machine, flows, nodes=nodes, snr_db=snr_db, rng=np.random.default_rng(seed),
                                duration_s=duration_s, method="steady", bearings=fb, rotor=rotor)
        vec.append(record_features(rec).vector())
    vec = np.array(vec)
    n = len(nodes)
    fb_vals, phi_vals = vec[:, :n], vec[:, n:]
    phi_deg = np.degrees(phi_vals)
    return NoiseFloor(flows=tuple(float(q) for q in flows), nodes=nodes,
                      fb_rel_std=fb_vals.std(axis=0, ddof=1) / np.abs(fb_vals.mean(axis=0)),
                      phi_deg_std=phi_deg.std(axis=0, ddof=1), seeds=seeds)



# --- over the operating range: the dimensionless tables (S, r) against direct solves ----------------

# The range the dimensionless tables must cover (issue 15): speed, viscosity and clearance factors.
RANGE_SPEED_HZ = (5.0, 150.0)
RANGE_VISCOSITY_FACTOR = (0.5, 2.0)
RANGE_CLEARANCE_FACTOR = (0.8, 1.5)


@dataclass(frozen=True)
class RangeAccuracy:
    """fb and φ of `machine` at random operating points with bearing 1's K, C from its dimensionless-table
    view vs from a direct equilibrium; per point (rows) and node (columns). The other bearing sits at its
    flooded equilibrium, solved directly, the same in both."""

    speed_hz: np.ndarray
    viscosity_factor: np.ndarray
    clearance_factor: np.ndarray
    ratio: np.ndarray  # Q / Q_T of bearing 1 (Q_T of its view)
    sommerfeld: np.ndarray
    nodes: tuple[int, ...]
    fb_rel: np.ndarray  # |fb_table / fb_direct - 1|
    phi_deg: np.ndarray  # |Δφ| (deg, modulo 180)
    coefficient_error: np.ndarray  # per point: max |table - direct| / max|direct| over K and C
    q_threshold_error: np.ndarray  # |Q_T view / Q_T direct - 1|
    fb_direct: np.ndarray  # fb on the direct solves (per point and node): large where |Zb| -> 0

    def worst(self, n: int = 5) -> list[dict]:
        """The n points with the largest fb error: where they are and how sensitive fb is there."""
        fb = 100.0 * self.fb_rel.max(axis=1)
        out = []
        for i in np.argsort(fb)[::-1][:n]:
            j = int(np.argmax(self.fb_rel[i]))
            out.append({"speed_hz": float(self.speed_hz[i]), "viscosity_factor": float(self.viscosity_factor[i]),
                        "clearance_factor": float(self.clearance_factor[i]), "q_over_q_threshold": float(self.ratio[i]),
                        "sommerfeld": float(self.sommerfeld[i]), "fb_pct": float(fb[i]),
                        "phi_deg": float(self.phi_deg[i].max()), "node": int(self.nodes[j]),
                        "fb": float(self.fb_direct[i, j]), "coefficient_rel": float(self.coefficient_error[i])})
        return out

    def summary(self) -> dict:
        """Median, 90th percentile and max of the per-point worst node, with the targets."""
        fb = 100.0 * self.fb_rel.max(axis=1)
        phi = self.phi_deg.max(axis=1)
        out = {"points": int(self.ratio.size), "nodes": list(self.nodes),
               "sommerfeld_range": [float(self.sommerfeld.min()), float(self.sommerfeld.max())],
               "target_fb_pct": 10.0 * NOISE_FB_REL, "target_phi_deg": 0.1 * NOISE_PHI_DEG}
        for name, a in (("fb_pct", fb), ("phi_deg", phi), ("coefficient_rel", self.coefficient_error),
                        ("q_threshold_rel", self.q_threshold_error)):
            out.update({f"{name}_{k}": float(f(a)) for k, f in _STATS.items()})
        out["fraction_within_target"] = float(np.mean((fb < 10.0 * NOISE_FB_REL) & (phi < 0.1 * NOISE_PHI_DEG)))
        return out

    def by_sommerfeld(self, edges=(0.0, 0.1, 0.3, 1.0, 3.0, np.inf)) -> list[dict]:
        """The same statistics per band of S (where the ln S interpolation is hardest: low S)."""
        out = []
        fb = 100.0 * self.fb_rel.max(axis=1)
        phi = self.phi_deg.max(axis=1)
        for lo, hi in zip(edges[:-1], edges[1:]):
            sel = (self.sommerfeld >= lo) & (self.sommerfeld < hi)
            if sel.any():
                out.append({"s_from": float(lo), "s_to": float(hi), "points": int(sel.sum()),
                            **{f"fb_pct_{k}": float(f(fb[sel])) for k, f in _STATS.items()},
                            **{f"phi_deg_{k}": float(f(phi[sel])) for k, f in _STATS.items()}})
        return out


def range_accuracy(machine, points: int = 200, *, rng: np.random.Generator, nodes: Sequence[int] | None = None,
                   directory=None, progress=None) -> RangeAccuracy:
    """Draw `points` operating points (speed log-uniform in RANGE_SPEED_HZ, viscosity and clearance
    factors log-uniform in their ranges, applied to both bearings, bearing 1's supply uniform in 25-200 %
    of its Q_T) and compare fb, φ with bearing 1 on its table view vs on a direct equilibrium.

    The views come from `cache.bearing_view` (slices built if missing, in `directory`)."""
    from ...film.equilibrium import find_equilibrium
    from ...film.feed import Feed
    from ...progress import silent
    from .cache import bearing_view
    from .dimensionless import sommerfeld_number

    progress = silent if progress is None else progress
    if len(machine.bearings) != 2:
        raise InputError("range_accuracy needs a two-bearing machine")
    nodes = tuple(machine.center_nodes) + tuple(machine.outside_nodes) if nodes is None else tuple(nodes)
    rotor = rotor_from_machine(machine)
    loads = bearing_static_loads(machine)
    unb = machine_unbalance(machine)

    def log_uniform(lo, hi):
        return np.exp(rng.uniform(np.log(lo), np.log(hi), points))

    speed, fm, fc = log_uniform(*RANGE_SPEED_HZ), log_uniform(*RANGE_VISCOSITY_FACTOR), log_uniform(*RANGE_CLEARANCE_FACTOR)
    ratio = rng.uniform(0.25, 2.0, points)
    fb_rel, phi_deg, coef, qt_err, s_all, fb_d = [], [], [], [], [], []
    for i in range(points):
        omega = 2.0 * np.pi * speed[i]
        b1, b2 = (b.copy(viscosity=fm[i] * b.viscosity, clearance=fc[i] * b.clearance) for b in machine.bearings)
        view = bearing_view(b1, loads[0], omega, directory=directory)
        s_all.append(sommerfeld_number(b1, loads[0], omega))
        q = ratio[i] * view.q_threshold
        K_t, C_t = view.coefficients(q)
        eq = find_equilibrium(b1, omega, loads[0], Feed.flow(q), start=view.journal_position(q))
        flooded = find_equilibrium(b1, omega, loads[0], Feed.flooded(), start=view.journal_position(view.q_threshold))
        other = find_equilibrium(b2, omega, loads[1], Feed.flooded(), start=view.journal_position(view.q_threshold))
        if not (eq.converged and flooded.converged and other.converged):
            raise InputError(f"direct equilibrium failed at {speed[i]:.4g} Hz, viscosity x{fm[i]:.3g}, "
                             f"clearance x{fc[i]:.3g}, Q/Q_T {ratio[i]:.3g}: {eq.message}")
        K_d, C_d = eq.coefficients.K, eq.coefficients.C
        pair_o = (other.coefficients.K, other.coefficients.C)
        r_t = unbalance_response(rotor, omega, unb, [(K_t, C_t), pair_o], nodes=nodes)
        r_d = unbalance_response(rotor, omega, unb, [(K_d, C_d), pair_o], nodes=nodes)
        fb_rel.append(np.abs(np.asarray(r_t.fb) / np.asarray(r_d.fb) - 1.0))
        fb_d.append(np.asarray(r_d.fb, dtype=float))
        d = np.degrees(np.asarray(r_t.phi) - np.asarray(r_d.phi))
        phi_deg.append(np.abs((d + 90.0) % 180.0 - 90.0))
        coef.append(max(np.abs(K_t - K_d).max() / np.abs(K_d).max(), np.abs(C_t - C_d).max() / np.abs(C_d).max()))
        qt_err.append(abs(view.q_threshold / flooded.film.side_leakage - 1.0))
        progress(i + 1, points, f"{speed[i]:.0f} Hz, S = {s_all[-1]:.3g}")
    return RangeAccuracy(speed_hz=speed, viscosity_factor=fm, clearance_factor=fc, ratio=ratio,
                         sommerfeld=np.array(s_all), nodes=nodes, fb_rel=np.array(fb_rel), phi_deg=np.array(phi_deg),
                         coefficient_error=np.array(coef), q_threshold_error=np.array(qt_err), fb_direct=np.array(fb_d))


def bench_table(machine_path=None, *, points: int = 200, seed: int = 0, identify_record=None,
                progress=None) -> dict:
    """`lubeviz bench table`: the full-range cold build of the dimensionless table (seconds, MB, slices),
    its accuracy over the range (`range_accuracy`) and a cold first identification (a fresh cache)."""
    import os
    import subprocess
    import sys
    import tempfile
    import time
    from pathlib import Path

    from ...model.machine import load_machine
    from ...progress import silent
    from .cache import full_build
    from .dimensionless import ratio_grid

    progress = silent if progress is None else progress
    machine = load_machine(machine_path)
    out: dict = {"machine": machine.source}
    with tempfile.TemporaryDirectory(prefix="lubeviz-bench-table-") as tmp:
        table, seconds = full_build(machine.bearings[0], directory=tmp, progress=progress)
        files = list((Path(tmp) / "slices").glob("*.npz"))
        out.update({"full_build_cold_s": seconds, "slices": len(files),
                    "disk_mb": sum(f.stat().st_size for f in files) / 1e6,
                    "sommerfeld_range": list(table.s_range), "ratio_points": table.points,
                    "ratio_nodes": int(ratio_grid(table.span, table.points).size),
                    "ratio_span": [float(v) for v in table.span]})
        t0 = time.perf_counter()
        acc = range_accuracy(machine, points, rng=np.random.default_rng(seed), directory=tmp, progress=progress)
        out["accuracy"] = {**acc.summary(), "by_sommerfeld": acc.by_sommerfeld(), "worst": acc.worst(),
                           "seconds": time.perf_counter() - t0}
    if identify_record is not None:
        with tempfile.TemporaryDirectory(prefix="lubeviz-bench-cold-") as tmp:
            env = {**os.environ, "LUBEVIZ_CACHE_DIR": tmp}
            cmd = [sys.executable, "-m", "lubeviz.cli.main", "identify", str(identify_record), "--json"]
            if machine_path is not None:
                cmd += ["--machine", str(machine_path)]
            t0 = time.perf_counter()
            subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            out["cold_first_identification_s"] = time.perf_counter() - t0
    return out
