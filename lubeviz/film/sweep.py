"""Equilibria and coefficients along a list of supply flows (warm-started, in flow order)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from ..model.bearing import Bearing
from ..progress import ProgressFn, silent
from .equilibrium import DEFAULT_COEFFICIENTS, Equilibrium, find_equilibrium
from .feed import Feed

PREDICT_MAX_ECCENTRICITY = 0.9  # a secant guess beyond this (of the clearance) is not used; the equilibrium then
# starts from the last position, as before the secant (one slice: -16 % time, values equal to 6e-9)


@dataclass(frozen=True)
class SupplySweep:
    """Equilibrium and coefficients at each supply flow q (m^3/s), arrays indexed like `q`."""

    q: np.ndarray
    position: np.ndarray  # (n, 2)
    eccentricity_ratio: np.ndarray
    K: np.ndarray  # (n, 2, 2)
    C: np.ndarray  # (n, 2, 2)
    side_leakage: np.ndarray
    max_pressure: np.ndarray
    iterations: np.ndarray
    seconds: float


def sweep_supply(bearing: Bearing, omega: float, load, flows, *, progress: ProgressFn = silent,
                 keep: list | None = None, coefficients: str = DEFAULT_COEFFICIENTS,
                 smoothing: float | None = None) -> SupplySweep:
    """Equilibria at every flow in `flows` (m^3/s), each warm-started from its neighbour.

    `coefficients` ("subcell", the default, "fixed-pattern" or "smoothed") and `smoothing`: see
    find_equilibrium.

    Raises ConvergenceError naming the flow if one equilibrium fails. `keep`, if a list, receives
    the Equilibrium objects (for views that need the fields).
    """
    flows = np.asarray(flows, dtype=float)
    order = np.argsort(flows)
    out: list[Equilibrium | None] = [None] * flows.size
    prev = before = None
    q_prev = q_before = None
    for n, k in enumerate(order):
        start = None if prev is None else prev.position
        if before is not None and q_prev > q_before:  # the secant through the last two positions
            guess = prev.position + (prev.position - before.position) * (flows[k] - q_prev) / (q_prev - q_before)
            if np.hypot(*guess) < PREDICT_MAX_ECCENTRICITY * bearing.clearance:
                start = guess
        eq = find_equilibrium(bearing, omega, load, Feed.flow(flows[k]), start=start,
                              warm=None if prev is None else prev.film,
                              coefficients=coefficients, smoothing=smoothing)
        if not eq.converged:
            raise ConvergenceError(f"equilibrium at supply {flows[k] * 6e7:.4g} ml/min: {eq.message}")
        out[k], before, prev = eq, prev, eq
        q_before, q_prev = q_prev, flows[k]
        progress(n + 1, flows.size, f"{flows[k] * 6e7:.0f} ml/min")
    if keep is not None:
        keep.extend(out)
    return SupplySweep(
        q=flows,
        position=np.array([e.position for e in out]),
        eccentricity_ratio=np.array([e.eccentricity_ratio for e in out]),
        K=np.array([e.coefficients.K for e in out]),
        C=np.array([e.coefficients.C for e in out]),
        side_leakage=np.array([e.film.side_leakage for e in out]),
        max_pressure=np.array([e.film.P.max() * e.film.problem.p_ref for e in out]),
        iterations=np.array([e.iterations for e in out]),
        seconds=float(sum(e.seconds for e in out)),
    )
