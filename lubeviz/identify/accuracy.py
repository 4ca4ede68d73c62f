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
in Q: the sub-cell tangent's residual staircase (~0.03 % in K, C) is in the direct solves, and a
smooth table cannot follow it, however dense. So away from the band the difference levels off at (3).

Measured (`lubeviz bench identify --accuracy`; bearing 1, 100 x 100 mesh, 75 Hz, nodes 6, 20, 5, 21,
all midpoints between nodes and the reference flows; target = a tenth of the noise floor, 0.033 % in
fb and 0.0079 deg in phi):
- 222 points (111 in the band at 0.05 % Q_T steps), median / 90th percentile / max:
  below Q_T - 5 ml/min  fb 0.0002 / 0.003 / 0.011 %, phi 0.0001 / 0.001 / 0.0033 deg (met);
  Q_T - 5 ... Q_T + 25  fb 0.00002 / 0.001 / 0.052 % (the max in the interval holding the first kink),
                        phi 0.00000 / 0.0001 / 0.0053 deg;
  above Q_T + 25        fb 0.0004 / 0.018 / 0.054 %, phi 0.0001 / 0.0056 / 0.014 deg: the max is the
  direct solves' own roughness (their deviation from a local cubic in Q reaches 0.05 % / 0.014 deg there).
  Bearing 2 alike (max 0.010 / 0.049 / 0.049 %, 0.0028 / 0.0041 / 0.012 deg).
- the former 71-point grid without the dense band: max 0.35 % / 0.036 deg below (at Q_T - 7 ml/min,
  ringing of the first kink), 1.37 % / 0.14 deg at Q_T + 7, 0.21 % / 0.034 deg above.
- on 1014 flows every 1 ml/min (0.1 near Q_T) instead of the midpoints: the same picture (222 points:
  max 0.012 / 0.055 / 0.058 % in fb, 0.0035 / 0.0056 / 0.014 deg in phi).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import InputError
from ..film.equilibrium import flooded_threshold
from ..film.sweep import sweep_supply
from ..rotor.assembly import rotor_from_machine
from ..rotor.response import machine_unbalance, unbalance_response
from ..rotor.statics import bearing_static_loads
from .tables import CoefficientTable

# The paper's reference flows (SPEC §5), ml/min.
REFERENCE_FLOWS_MLMIN = (409.5, 448.5, 487.5, 526.5, 565.5, 604.5, 643.5, 682.5)

# The band around Q_T where the groove pressurizes (ml/min from Q_T), as in BENCHMARKS "Smoothness".
GROOVE_BAND_MLMIN = (-5.0, 25.0)
_STATS = {"median": np.median, "p90": lambda a: np.percentile(a, 90), "max": np.max}

# Noise of the features at 12 dB SNR over 5 s at 75 Hz, the paper's machine: one standard deviation
# over 50 seeds (`noise_floor`) with both bearings at Q_T, bearing centres (nodes 6, 20). It varies
# with the flows and the node: 0.06-0.9 % in fb and 0.02-0.22 deg in phi over the corners
# (409.5/682.5 ml/min) of the paper's protocol, smallest outside a starved bearing.
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
        the band Q_T + band_mlmin (ml/min) where the groove pressurizes; None for an empty region."""
        dq = (self.flows - q_threshold) * 6e7
        lo, hi = band_mlmin
        out = {}
        for name, sel in (("below", dq < lo), ("band", (dq >= lo) & (dq <= hi)), ("above", dq > hi)):
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
    ref = np.array(REFERENCE_FLOWS_MLMIN) / 6e7
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
    from ..rotor.film_bearings import film_bearings
    from ..signals.features import record_features
    from ..signals.synthesize import synthesize_record

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

