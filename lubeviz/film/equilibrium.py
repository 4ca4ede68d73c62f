"""Static equilibrium of the journal under a given load (paper Sec. 2.1, before Eq. 7).

Newton on the journal position: find e with F_film(e) + W = 0 for the external load W on the
journal (e.g. its share of the rotor weight, (0, -W)). The Jacobian dF/de = -K is the fixed-pattern
stiffness, which every active-set film solve delivers at the cost of one back-substitution, so the
iteration converges quadratically once the cavitation pattern settles; each step warm-starts the
film solve from the previous pattern. Steps are limited so the journal stays inside the clearance.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..model.bearing import Bearing
from .feed import Feed, setup_problem
from .linearize import DynamicCoefficients, fixed_pattern_coefficients, force_jacobian
from .smoothed import DEFAULT_SMOOTHING, smoothed_coefficients
from .solver import FilmSolution, solve
from .subcell import subcell_coefficients

MAX_ECCENTRICITY = 0.995


@dataclass(frozen=True)
class Equilibrium:
    """A journal in static equilibrium, its film and its dynamic coefficients (see find_equilibrium)."""

    bearing: Bearing
    omega: float
    load: np.ndarray  # external load on the journal [Wx, Wy] (N); the film carries -load
    feed: Feed
    position: np.ndarray  # [eX, eY] (m)
    film: FilmSolution
    coefficients: DynamicCoefficients
    iterations: int
    converged: bool
    message: str
    seconds: float

    @property
    def eccentricity_ratio(self) -> float:
        return float(np.hypot(*self.position) / self.bearing.clearance)

    @property
    def attitude_angle(self) -> float:
        """Angle (rad) from the load line to the line of centres, in the direction of rotation."""
        load_dir = math.atan2(self.load[1], self.load[0])
        centre_dir = math.atan2(self.position[1], self.position[0])
        return (centre_dir - load_dir) % (2.0 * math.pi)


def initial_position(bearing: Bearing, omega: float, load: np.ndarray) -> np.ndarray:
    """A starting guess from the short-bearing (Ocvirk) solution for the load's Sommerfeld number.

    Only a guess: the Newton iteration corrects it. Ocvirk: W = mu U L^3 / (4 c^2) *
    eps / (1 - eps^2)^2 * sqrt(pi^2 (1 - eps^2) + 16 eps^2), attitude tan(phi) = pi sqrt(1 - eps^2) / (4 eps).
    """
    w = float(np.hypot(*load))
    U = omega * bearing.radius
    scale = bearing.viscosity * U * bearing.length**3 / (4.0 * bearing.clearance**2)
    lo, hi = 1e-4, 0.95
    for _ in range(60):
        eps = 0.5 * (lo + hi)
        f = scale * eps / (1 - eps**2) ** 2 * math.sqrt(math.pi**2 * (1 - eps**2) + 16 * eps**2)
        lo, hi = (eps, hi) if f < w else (lo, eps)
    eps = min(max(0.5 * (lo + hi), 0.05), 0.9)
    phi = math.atan2(math.pi * math.sqrt(1 - eps**2), 4 * eps)
    load_dir = math.atan2(load[1], load[0]) if w > 0 else -0.5 * math.pi
    ang = load_dir + phi  # displaced from the load line in the direction of rotation
    e = eps * bearing.clearance
    return np.array([e * math.cos(ang), e * math.sin(ang)])


COEFFICIENT_METHODS = ("subcell", "fixed-pattern", "smoothed")
DEFAULT_COEFFICIENTS = "subcell"


def find_equilibrium(bearing: Bearing, omega: float, load, feed: Feed, *,
                     start=None, warm: FilmSolution | None = None, pattern: np.ndarray | None = None,
                     tol: float = 1e-9, max_iter: int = 40, coefficients: str = DEFAULT_COEFFICIENTS,
                     smoothing: float | None = None) -> Equilibrium:
    """Journal position where the film force balances `load` (N, external, on the journal).

    `start` (position) and `warm` (a film solution, for its cavitation pattern) speed up sweeps;
    `pattern` (full cells, the mesh's shape), if given, is the first film solve's starting pattern
    instead of `warm`'s (a sweep's prediction, film.sweep); the later solves start from the last film.
    `coefficients` chooses how K and C are computed at the equilibrium:
    - "subcell" (default): tangent of the exact film with each rupture/reformation front placed
      inside its pair of cells (subcell.py); continuous in the supply and position (its residual
      staircase: BENCHMARKS "Smoothness in the supply flow") and closer to the 200 x 200 values than
      the fixed-pattern tangent (docs/notes/film-smoothness.md); ~30 ms.
    - "fixed-pattern": derivative of the exact discrete film with the cavitation pattern held
      (linearize.py); the exact small-amplitude limit of this mesh's film, ~1 ms, but it jumps
      whenever one cell changes state (a staircase in the supply: BENCHMARKS "Smoothness in the supply
      flow").
    - "smoothed": derivative of the film with Eq. 6 smoothed to P (1 - theta) = `smoothing`
      (smoothed.py; default smoothing.DEFAULT_SMOOTHING); ~50 ms.
    The equilibrium position itself is always that of the exact film.
    Does not raise on non-convergence: the result says so (`converged`, `message`).
    """
    if coefficients not in COEFFICIENT_METHODS:
        raise InputError(f"coefficient method {coefficients!r}; expected one of {COEFFICIENT_METHODS}")
    t0 = time.perf_counter()
    load = np.asarray(load, dtype=float)
    if load.shape != (2,) or not np.all(np.isfinite(load)):
        raise InputError(f"load {load!r} must be two finite numbers [Wx, Wy] in N")
    w = float(np.hypot(*load))
    if w <= 0.0:
        raise InputError("load is zero; expected a positive bearing load")
    c = bearing.clearance
    e = initial_position(bearing, omega, load) if start is None else np.array(start, dtype=float)
    target = -load

    def film_at(pos, warm_sol, full0=None):
        sol = solve(setup_problem(bearing, omega, pos, feed), warm=warm_sol, pattern=full0)
        return sol, sol.force - target

    sol, g = film_at(e, warm, pattern)
    message = ""
    it = 0
    converged = False
    for it in range(1, max_iter + 1):
        if not sol.converged:
            message = f"film solve failed at eccentricity {np.hypot(*e) / c:.4g}: {sol.message}"
            break
        if np.hypot(*g) <= tol * w:
            converged = True
            break
        J = force_jacobian(sol)[:, :2]  # dF/de = -K
        try:
            step = -np.linalg.solve(J, g)
        except np.linalg.LinAlgError:  # the film does not answer a move of the journal here (e.g. in a groove)
            message = f"the film's stiffness is singular at eccentricity {np.hypot(*e) / c:.4g}: no Newton step"
            break
        # Backtrack: stay inside the clearance and do not let the force error grow.
        lam = 1.0
        for _ in range(30):
            trial = e + lam * step
            if np.hypot(*trial) < MAX_ECCENTRICITY * c:
                sol_t, g_t = film_at(trial, sol)
                if sol_t.converged and np.hypot(*g_t) < (1.0 - 1e-4 * lam) * np.hypot(*g) + 1e-14 * w:
                    break
            lam *= 0.5
        else:
            message = "equilibrium search could not reduce the force error (backtracking failed)"
            break
        e, sol, g = trial, sol_t, g_t
    else:
        it = max_iter
    if converged:
        message = f"converged in {it - 1} Newton steps"
    elif not message:
        message = f"equilibrium force error {np.hypot(*g) / w:.3g} (relative) after {max_iter} Newton steps"
    if sol.linear is not None and coefficients == "smoothed" and sol.converged:
        coef = smoothed_coefficients(sol, DEFAULT_SMOOTHING if smoothing is None else smoothing)
    elif sol.linear is not None and coefficients == "subcell":
        coef = subcell_coefficients(sol)
    elif sol.linear is not None:
        coef = fixed_pattern_coefficients(sol)
    else:
        nan = np.full((2, 2), np.nan)
        coef = DynamicCoefficients(K=nan, C=nan, method="unavailable")
    return Equilibrium(bearing=bearing, omega=omega, load=load, feed=feed, position=e, film=sol,
                       coefficients=coef, iterations=it - 1 if converged else it, converged=converged,
                       message=message, seconds=time.perf_counter() - t0)


def flooded_threshold(bearing: Bearing, omega: float, load, *, start=None) -> tuple[float, Equilibrium]:
    """Q_T: side leakage of the flooded film at its equilibrium under `load` (SPEC §2). (m^3/s, eq.)"""
    eq = find_equilibrium(bearing, omega, load, Feed.flooded(), start=start)
    return eq.film.side_leakage, eq
