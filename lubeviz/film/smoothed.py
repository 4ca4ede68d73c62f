"""Smoothed complementarity: a p-theta film whose cells change state gradually, and its exact tangent.

Why. The discrete p-theta system (Eq. 3-6) is piecewise linear: each cell is either full (p > 0,
theta = 1) or cavitated (p = 0, theta < 1), and the fixed-pattern tangent (linearize.py) jumps
whenever one cell changes state. Along a supply sweep on the paper's 100 x 100 mesh that happens
several times per ml/min (rupture-side columns, the reformation front of the strip fed by the groove,
groove cells near Q_T), and K, C show a staircase (BENCHMARKS "Smoothness in the supply flow";
docs/notes/film-smoothness.md).

What. Eq. 6 (p >= 0, theta <= 1, p (1 - theta) = 0) is replaced by the Fischer-Burmeister equation

    phi_mu(a, b) = a + b - sqrt(a^2 + b^2 + 2 mu) = 0,    a = P, b = 1 - theta,

whose root set is exactly the hyperbola  P (1 - theta) = mu  with P > 0, theta < 1 (square both sides
of a + b = sqrt(...)). So mu (`smoothing`, in units of p_ref = 6 mu_oil U R / c^2) is the only
parameter: a full cell at pressure P keeps theta = 1 - mu / P, a cavitated cell with oil fraction
theta keeps P = mu / (1 - theta). The balances (Eq. 3-4) are kept exactly, so a smoothed film
conserves mass to round-off like the exact one. mu -> 0 gives back Eq. 6 and the active-set solution,
and the tangent below gives back the fixed-pattern tangent (tests/film/test_smoothed.py).

How. Newton on (balances, phi_mu) = 0, started from the exact active-set film projected onto the
hyperbola. The linearized phi_mu of each cell gives one of its two unknowns in terms of the other
(P where phi_b >= phi_a, "full-like"; theta elsewhere), so every Newton step is one sparse LU of the
same size and five-point structure as the active-set solver's. At the solution the same factorization
gives the implicit-function derivative of the smoothed film with respect to the journal position and
velocity: dP/ds = -J^-1 dR/ds, the dynamic coefficients of the smoothed film. They are smooth in every
parameter because the film is.

The default mu = 1e-7 means p (1 - theta) = mu p_ref ~ 4 Pa for the paper's bearing (p_ref ~ 37 MPa):
a full cell at 1 kPa keeps 1 - theta ~ 4e-3, one at 1 MPa ~ 4e-6, so only the cells next to a
rupture or reformation boundary and in the groove are touched. It moves the paper bearing's
coefficients by less than the 100 -> 200 mesh difference; a larger mu smooths more but changes the
model itself (a tenfold mu moves K at Q_T by more than that difference, on 100 x 100 and 200 x 200
alike). The smoothed coefficients are superseded by the sub-cell ones (docs/notes/film-smoothness.md).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ConvergenceError
from .linearize import DynamicCoefficients, balance_derivatives
from .operator import FilmProblem, film_force, force_weights, residual, side_leakage
from .solver import Columns, FilmSolution

DEFAULT_SMOOTHING = 1e-7  # mu: P (1 - theta) = mu in every free cell (P in units of p_ref); chosen on the
# uniform 100 x 100 mesh: it acts per cell, so on the refined groove columns (mesh.refined_split) it smooths more


NEGLIGIBLE = 1e-200  # a scale this small multiplies an entry by nothing a double can add to its row's others


class _ReducedSystem:
    """Sparse structure of the balances restricted to free cells, reused by every Newton step.

    The balance is A_P dP + A_theta dtheta = -R. With dP = Tp y + tp and dtheta = Tt y + tt per cell
    (y the cell's primary unknown) the reduced matrix is A_P diag(Tp) + A_theta diag(Tt): the same
    nonzeros as A_P (A_theta only touches the diagonal and the west neighbour), refilled per step.
    """

    def __init__(self, problem: FilmProblem):
        t = Columns(problem)
        self.rows, self.cols, self.vals, self.is_p = t.coo()
        n = t.n_free
        key = self.cols * n + self.rows  # CSC order: by column, then row
        uniq, self.slot = np.unique(key, return_inverse=True)
        self.indices = (uniq % n).astype(np.int32)
        self.indptr = np.searchsorted(uniq // n, np.arange(n + 1)).astype(np.int32)
        self.slot_col = (uniq // n).astype(np.int64)  # the column of each stored entry
        self.n = n
        self.free_idx = t.free_idx

    def matrix(self, Tp: np.ndarray, Tt: np.ndarray) -> sp.csc_matrix:
        """The reduced matrix; an entry whose scale is below `NEGLIGIBLE` (a cell that is simply full,
        Tt = 0, or simply cavitated, Tp = 1e-300 in subcell.py) is left out of the sparsity pattern: kept,
        it would only add fill (a sub-cell tangent's two LUs took 15 ms each instead of 5 ms)."""
        scale = np.where(self.is_p, Tp[self.cols], Tt[self.cols])
        scale = np.where(np.abs(scale) < NEGLIGIBLE, 0.0, scale)
        data = np.bincount(self.slot, weights=self.vals * scale, minlength=self.indices.size)
        keep = np.bincount(self.slot, weights=(scale != 0.0).astype(float), minlength=self.indices.size) > 0
        if keep.all():
            return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))
        indptr = np.concatenate([[0], np.cumsum(np.bincount(self.slot_col[keep], minlength=self.n))])
        return sp.csc_matrix((data[keep], self.indices[keep], indptr.astype(np.int32)), shape=(self.n, self.n))

    def apply(self, vp: np.ndarray, vt: np.ndarray) -> np.ndarray:
        """A_P vp + A_theta vt on the free cells."""
        x = np.where(self.is_p, vp[self.cols], vt[self.cols])
        return np.bincount(self.rows, weights=self.vals * x, minlength=self.n)


def _fb(a, b, mu):
    """phi_mu and its partial derivatives (both in (0, 2) for mu > 0)."""
    r = np.sqrt(a * a + b * b + 2.0 * mu)
    return a + b - r, 1.0 - a / r, 1.0 - b / r


def _elimination(phi, fa, fb):
    """Per cell: dP = Tp y + tp, dtheta = Tt y + tt from phi_a dP - phi_b dtheta = -phi (b = 1 - theta)."""
    p_primary = fb >= fa
    with np.errstate(divide="ignore", invalid="ignore"):
        Tp = np.where(p_primary, 1.0, fb / fa)
        tp = np.where(p_primary, 0.0, -phi / fa)
        Tt = np.where(p_primary, fa / fb, 1.0)
        tt = np.where(p_primary, phi / fb, 0.0)
    return Tp, tp, Tt, tt


@dataclass(frozen=True)
class SmoothedFilm:
    """The film with Eq. 6 smoothed to P (1 - theta) = `smoothing`; fields like FilmSolution's."""

    problem: FilmProblem = field(repr=False)
    P: np.ndarray = field(repr=False)
    theta: np.ndarray = field(repr=False)
    force: np.ndarray
    side_leakage: float
    smoothing: float
    iterations: int
    converged: bool
    message: str
    seconds: float
    _lu: object = field(default=None, repr=False, compare=False)
    _Tp: np.ndarray = field(default=None, repr=False, compare=False)
    _system: _ReducedSystem = field(default=None, repr=False, compare=False)

    def tangent(self, dR: np.ndarray) -> np.ndarray:
        """dP for a change dR (k, nz, n_circ) of the balances at fixed fields: implicit-function theorem."""
        s = self._system
        k = dR.shape[0]
        y = self._lu.solve(np.ascontiguousarray(-dR.reshape(k, -1)[:, s.free_idx].T))
        dP = np.zeros((k, dR[0].size))
        dP[:, s.free_idx] = (self._Tp[:, None] * y).T
        return dP.reshape(dR.shape)


def solve_smoothed(exact: FilmSolution, smoothing: float = DEFAULT_SMOOTHING, *, tol: float = 1e-12,
                   max_iter: int = 40) -> SmoothedFilm:
    """Newton solve of the smoothed film, started from the exact (active-set) film `exact`."""
    if not (smoothing > 0.0 and np.isfinite(smoothing)):
        raise ValueError(f"smoothing {smoothing!r} must be a positive number (P (1 - theta) = smoothing)")
    t0 = time.perf_counter()
    problem = exact.problem
    sysm = _ReducedSystem(problem)
    free = sysm.free_idx
    shape = problem.mesh.shape
    P = np.zeros(shape).ravel()
    theta = np.ones(shape).ravel()
    # Start on the hyperbola a b = mu, keeping a - b of the exact film.
    d = exact.P.ravel()[free] - (1.0 - exact.theta.ravel()[free])
    root = np.sqrt(d * d + 4.0 * smoothing)
    x_p, x_b = 0.5 * (d + root), 0.5 * (root - d)

    def equations(x_p, x_b):
        P[free], theta[free] = x_p, 1.0 - x_b
        R = residual(problem.coef, P.reshape(shape), theta.reshape(shape)).ravel()[free]
        return (R,) + _fb(x_p, x_b, smoothing)

    R, phi, fa, fb = equations(x_p, x_b)
    converged = False
    it = 0
    lu = Tp = None
    for it in range(1, max_iter + 1):
        if max(np.abs(R).max(), np.abs(phi).max()) < tol:
            converged = True
            break
        Tp, tp, Tt, tt = _elimination(phi, fa, fb)
        lu = spla.splu(sysm.matrix(Tp, Tt), permc_spec="MMD_AT_PLUS_A")
        y = lu.solve(-R - sysm.apply(tp, tt))
        dp, dth = Tp * y + tp, Tt * y + tt
        merit = R @ R + phi @ phi
        lam = 1.0
        for _ in range(30):  # backtracking on the squared residual
            trial = equations(x_p + lam * dp, x_b - lam * dth)
            if trial[0] @ trial[0] + trial[1] @ trial[1] <= (1.0 - 1e-4 * lam) * merit:
                break
            lam *= 0.5
        x_p, x_b = x_p + lam * dp, x_b - lam * dth
        R, phi, fa, fb = trial
    P[free], theta[free] = x_p, 1.0 - x_b
    P, theta = P.reshape(shape), theta.reshape(shape)
    if lu is None or not converged:
        Tp, _, Tt, _ = _elimination(np.zeros_like(phi), fa, fb)
        lu = spla.splu(sysm.matrix(Tp, Tt), permc_spec="MMD_AT_PLUS_A")
    # else: the last Newton matrix is reused for the tangent: it was factorized one (quadratically
    # small, residual < tol) step away from the solution, so it is the Jacobian there to ~tol.
    err = max(np.abs(R).max(), np.abs(phi).max())
    message = (f"converged in {it - 1} Newton steps" if converged else
               f"smoothed film: residual {err:.3g} still above {tol:g} after {max_iter} Newton steps")
    return SmoothedFilm(problem=problem, P=P, theta=theta, force=film_force(problem, P),
                        side_leakage=side_leakage(problem, P), smoothing=smoothing,
                        iterations=it - 1 if converged else it, converged=converged, message=message,
                        seconds=time.perf_counter() - t0, _lu=lu, _Tp=Tp, _system=sysm)


def smoothed_force_jacobian(film: SmoothedFilm) -> np.ndarray:
    """dF/ds (2 x 4) of the smoothed film for s = (eX, eY, vX, vY)."""
    dP = film.tangent(balance_derivatives(film))
    return np.einsum("fij,kij->fk", force_weights(film.problem), dP)


def smoothed_coefficients(exact: FilmSolution, smoothing: float = DEFAULT_SMOOTHING) -> DynamicCoefficients:
    """K and C (SPEC §1 sign) of the smoothed film around the exact film `exact` (see module doc).

    Raises ConvergenceError if the smoothed Newton solve does not converge.
    """
    film = solve_smoothed(exact, smoothing)
    if not film.converged:
        raise ConvergenceError(film.message)
    dF = smoothed_force_jacobian(film)
    return DynamicCoefficients(K=-dF[:, :2], C=-dF[:, 2:], method=f"smoothed(mu={smoothing:g})")
