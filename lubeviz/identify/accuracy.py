"""How well a coefficient table stands in for direct film solves, measured where it matters: fb and φ.

The identification compares simulated and measured fb and φ (SPEC §5), so a table is good enough
when the fb and φ it gives differ from those of direct equilibrium solves by much less than the
noise of a measured fb and φ. `interpolation_error` measures that difference at flows between the
table's nodes (where interpolation is worst) and at the paper's reference flows, at the bearing
centres and outside the bearings, with the other bearing held at a fixed flow.

The noise floor (`NOISE_FB_REL`, `NOISE_PHI_DEG`): the standard deviation of fb (relative) and φ over
seeds of a 5 s record at 12 dB SNR (the paper's protocol), measured with `noise_floor`.

What the difference contains: (1) the interpolation error of the spline, which falls like h^4 with
the node spacing h, and (2) the film's own roughness in Q: on a finite-volume mesh the cavitation
boundary moves cell by cell, so K(Q) and C(Q) of direct solves are a fine staircase about a smooth
curve. A direct solve at a midpoint sits on that staircase; the spline through the nodes cannot,
however dense. So the difference levels off at the roughness as points grow.

Measured (bearing 1, 100 x 100 mesh, 75 Hz, nodes 6, 20, 5, 21):
- roughness: direct solves on 295 flows vs a least-squares spline through them: fb 0.4 % rms below
  Q_T and 0.8 % above (max 3.5 %), phi 0.09 / 0.24 deg rms (max 0.9 deg): of the order of the noise.
- table vs direct solves at all midpoints and reference flows, current grid and single spline:
  71 points max 4.3 % / 1.05 deg, median 0.08 % / 0.022 deg; 101 points max 3.2 % / 0.9 deg.
- interpolation proper (table of a smooth surrogate vs the surrogate): a single spline through the
  kink of K(Q), C(Q) at Q_T (the groove starts to pressurize) never gets below ~0.75 % in fb; with a
  node at Q_T and separate splines on either side the max error is 0.097 % / 0.016 deg at 21
  points, 0.022 % / 0.0024 deg at 41, 0.0067 % / 0.0007 deg at 51, 0.0008 % at 71.
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

