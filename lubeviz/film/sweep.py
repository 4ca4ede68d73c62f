"""Equilibria and coefficients along a list of supply flows (warm-started, in flow order).

Each equilibrium starts where the last ones point: the journal at the parabola through the last three
positions (the secant after two), the first film solve at the cavitation pattern extrapolated along the last
two films (`predicted_pattern`). The starts decide only the work, not the answer. On one dimensionless slice
(141 equilibria, S = 1.91) the first film solve of an equilibrium took 4.7 / 4.2 active-set steps below /
above Q_T from the last film's pattern and the secant start, 4.0 / 3.7 from these; the parabola's start lies
~4e-5 c from the answer (the secant's 1.1e-4 c), not closer, since the position is rough at that level as
cells switch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from ..model.bearing import Bearing
from ..progress import ProgressFn, silent
from .equilibrium import DEFAULT_COEFFICIENTS, Equilibrium, find_equilibrium
from .feed import Feed
from ..units import MLMIN_PER_M3S

PREDICT_MAX_ECCENTRICITY = 0.9  # a predicted position beyond this (of the clearance) is not used; the equilibrium
# then starts from the last position and the last film's pattern


def predicted_position(done, q: float) -> np.ndarray:
    """The journal position at flow `q` extrapolated through the last two or three equilibria `done`
    ((flow, Equilibrium) in increasing flow): the secant, or the parabola when there are three."""
    qs = np.array([f for f, _ in done])
    pos = np.array([e.position for _, e in done])
    if qs.size == 3 and qs[0] < qs[1]:
        w = np.array([np.prod([(q - qs[j]) / (qs[i] - qs[j]) for j in range(3) if j != i]) for i in range(3)])
        return w @ pos
    return pos[-1] + (pos[-1] - pos[-2]) * (q - qs[-1]) / (qs[-1] - qs[-2])


def predicted_pattern(before, prev, t: float) -> np.ndarray | None:
    """Full cells of the film one step `t` (in units of the last step) past `prev` along a sweep.

    Each cell's complementarity variable d = P - (1 - theta) (> 0 full, < 0 cavitated; one of the two
    terms is zero) is extrapolated along the secant through the last two films, so the fronts move on
    as they were moving; the first film solve of the next equilibrium starts from that pattern.
    """
    if before.P.shape != prev.P.shape:
        return None
    d_before = before.P - (1.0 - before.theta)
    d_prev = prev.P - (1.0 - prev.theta)
    return (d_prev + (d_prev - d_before) * t) > 0.0


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
                 smoothing: float | None = None, tol: float = 1e-9, start: Equilibrium | None = None) -> SupplySweep:
    """Equilibria at every flow in `flows` (m^3/s), each warm-started from its neighbour.

    `coefficients` ("subcell", the default, "fixed-pattern" or "smoothed"), `smoothing` and `tol` (the
    force balance, relative to the load): see find_equilibrium. `start`: an equilibrium of the same bearing,
    speed and load near the first flow (e.g. the flooded one for a sweep from Q_T up), whose position and
    film start the first equilibrium (else the short-bearing guess).

    Raises ConvergenceError naming the flow if one equilibrium fails. `keep`, if a list, receives
    the Equilibrium objects (for views that need the fields).
    """
    flows = np.asarray(flows, dtype=float)
    order = np.argsort(flows)
    out: list[Equilibrium | None] = [None] * flows.size
    done: list[tuple[float, Equilibrium]] = []  # (flow, equilibrium) so far, in flow order
    first = start
    for n, k in enumerate(order):
        prev = done[-1][1] if done else first
        start, pattern = None if prev is None else prev.position, None
        if len(done) >= 2 and done[-1][0] > done[-2][0]:
            guess = predicted_position(done[-3:], flows[k])
            if np.hypot(*guess) < PREDICT_MAX_ECCENTRICITY * bearing.clearance:
                start = guess
                t = (flows[k] - done[-1][0]) / (done[-1][0] - done[-2][0])
                pattern = predicted_pattern(done[-2][1].film, prev.film, t)
        eq = find_equilibrium(bearing, omega, load, Feed.flow(flows[k]), start=start,
                              warm=None if prev is None else prev.film, pattern=pattern, tol=tol,
                              coefficients=coefficients, smoothing=smoothing)
        if not eq.converged:
            raise ConvergenceError(f"equilibrium at supply {flows[k] * MLMIN_PER_M3S:.4g} ml/min: {eq.message}")
        out[k] = eq
        done.append((float(flows[k]), eq))
        progress(n + 1, flows.size, f"{flows[k] * MLMIN_PER_M3S:.0f} ml/min")
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
