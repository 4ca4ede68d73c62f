"""Sub-cell dynamic coefficients: the tangent of the film with its fronts placed inside the cells.

Why. The discrete p-theta film (Eq. 3-6) is piecewise linear in the journal position and the
supply: each cell is either full (p > 0, theta = 1) or cavitated (p = 0, theta < 1). The
fixed-pattern tangent (linearize.py) is the derivative of one piece, so it jumps whenever one
cell changes state: along a 1 ml/min supply sweep on the paper's 100 x 100 mesh K and C show a
staircase (rupture columns, reformation fronts, the lateral edges of the film fed by the groove,
groove cells near Q_T; its size: BENCHMARKS "Smoothness in the supply flow", the diagnosis:
docs/notes/film-smoothness.md).

The front inside a pair of cells. Every face between a full cell i and a cavitated cell n is
crossed by a rupture or reformation front. Where the front lies between the two cells is read
from two fluxes that vanish at the two ends of the pair's life:

    phi = a P_i / (a P_i + C1_n (1 - theta_n))     (a: the face's Poiseuille conductance)

a P_i is the pressure-driven flow from i into n, C1_n (1 - theta_n) the Couette flow that n lacks
to be full. phi = 0 exactly when i is about to cavitate (P_i = 0) and phi = 1 exactly when n is
about to fill (theta_n = 1); in between it moves almost linearly with the supply (measured along
the rupture and reformation fronts of the paper's bearing). It is the front's position in the pair.

The tangent. A cell the front is crossing is partly full: its linearized Eq. 6 becomes the Robin
relation  d theta = kappa dP  (kappa = 0: full, d theta = 0; kappa -> infinity: cavitated, dP = 0)
with kappa = (a / C1) (1 - phi) / phi. For the last full cell of a rupture this is exactly the
Shortley-Weller (ghost-fluid) condition dp = 0 at the front, a fraction phi of the cell spacing
downstream: the extra Poiseuille outflow a (1/phi - 1) dP leaves as d theta into the cavitated
neighbour, so every balance (Eq. 3-4) still holds and the tangent conserves mass. Carried by the
full cell i, the relation takes the pair from "i cavitated" (phi = 0) to "i full" (phi = 1); carried
by the cavitated cell n, from "n cavitated" to "n full". Either is continuous in every parameter
-- at each change of state the relation is the same on both sides (a full cell's kappas add, a
cavitated cell's 1/kappas add, so a pair that appears or disappears contributes nothing) -- but
each is half a cell off-centre, an O(h) bias of opposite sign (measured: docs/notes/film-smoothness.md).
Their mean places the front's effect where the front is: the coefficients are then smooth in the
supply (the residual staircase: BENCHMARKS "Smoothness in the supply flow") and closer to the
200 x 200 values than the fixed-pattern tangent is (docs/notes/film-smoothness.md). It costs two sparse
LU factorizations of the size of the active-set solver's.

The film itself is the exact one (the equilibrium does not move); only its tangent changes, by a
one-cell boundary layer, so it tends to the same mesh limit as the fixed-pattern tangent.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from .linearize import DynamicCoefficients, balance_derivatives
from .operator import FilmProblem, force_weights
from .smoothed import _ReducedSystem
from .solver import FilmSolution

_HUGE = 1e300


def _neighbour(idx: np.ndarray, direction: str) -> np.ndarray:
    """Flat index of each cell's neighbour in `direction` (E, W periodic; N, S: -1 past the edge)."""
    none = np.full((1, idx.shape[1]), -1)
    if direction == "E":
        return np.roll(idx, -1, axis=1)
    if direction == "W":
        return np.roll(idx, 1, axis=1)
    if direction == "N":  # towards z = L (or the symmetry plane of a half mesh)
        return np.vstack([idx[1:], none])
    return np.vstack([none, idx[:-1]])


def front_pairs(problem: FilmProblem, P: np.ndarray, theta: np.ndarray):
    """Faces between a full cell and a cavitated (free) cell.

    Returns flat arrays (i, n, a, phi): the full cell, the cavitated cell, the face's Poiseuille
    conductance and the front's position phi in [0, 1] (see module doc).
    """
    c = problem.coef
    nz, nc = P.shape
    fixed = problem.fixed.ravel()
    full = ((P > 0.0) | (theta >= 1.0)).ravel() & ~fixed
    cav = ~full & ~fixed
    idx = np.arange(nz * nc).reshape(nz, nc)
    p = np.maximum(P.ravel(), 0.0)
    deficit = problem.coef.C1.ravel() * (1.0 - theta.ravel())  # Couette flow a cavitated cell lacks
    conductance = {"E": c.aE, "W": c.aW, "N": c.aN, "S": c.aS}
    out_i, out_n, out_a, out_phi = [], [], [], []
    full_idx = np.flatnonzero(full)
    for direction in "EWNS":
        n = _neighbour(idx, direction).ravel()[full_idx]
        keep = n >= 0
        i, n = full_idx[keep], n[keep]
        keep = cav[n]
        i, n = i[keep], n[keep]
        a = conductance[direction].ravel()[i]
        flow = a * p[i]
        phi = flow / np.maximum(flow + deficit[n], 1e-300)
        out_i.append(i), out_n.append(n), out_a.append(a), out_phi.append(phi)
    cat = np.concatenate
    return cat(out_i), cat(out_n), cat(out_a), cat(out_phi)


def _robin(problem: FilmProblem, P, theta, pairs, carrier: str):
    """Per-cell (Tp, Tt) of d P = Tp y, d theta = Tt y: fixed pattern plus the fronts' Robin relations.

    carrier "full": the full cell of each pair carries kappa (sum over its pairs); "cavitated": the
    cavitated cell carries it (its 1/kappa summed over its pairs).
    """
    i, n, a, phi = pairs
    C1 = problem.coef.C1.ravel()
    full = ((P > 0.0) | (theta >= 1.0)).ravel() & ~problem.fixed.ravel()
    with np.errstate(divide="ignore", invalid="ignore"):
        if carrier == "full":
            kappa = np.where(full, 0.0, _HUGE)
            add = np.minimum(a / C1[i] * (1.0 - phi) / phi, _HUGE)
            np.add.at(kappa, i, np.where(phi > 0.0, add, _HUGE))
        else:
            inv = np.zeros(P.size)
            add = np.minimum(C1[n] / a * phi / (1.0 - phi), _HUGE)
            np.add.at(inv, n, np.where(phi < 1.0, add, _HUGE))
            kappa = np.where(full, 0.0, np.where(inv > 0.0, 1.0 / np.maximum(inv, 1e-300), _HUGE))
        Tp = np.where(kappa <= 1.0, 1.0, 1.0 / kappa)
        Tt = np.where(kappa <= 1.0, kappa, 1.0)
    return Tp, Tt


def subcell_pressure_tangent(sol: FilmSolution) -> np.ndarray:
    """dP/ds (4, nz, n_circ) for s = (eX, eY, vX, vY): the mean of the two sub-cell tangents (module doc)."""
    problem = sol.problem
    system = _ReducedSystem(problem)
    free = system.free_idx
    pairs = front_pairs(problem, sol.P, sol.theta)
    dR = balance_derivatives(sol)
    k = dR.shape[0]
    rhs = np.ascontiguousarray(-dR.reshape(k, -1)[:, free].T)
    dP = np.zeros((k, sol.P.size))
    for carrier in ("full", "cavitated"):
        Tp, Tt = _robin(problem, sol.P, sol.theta, pairs, carrier)
        lu = spla.splu(system.matrix(Tp[free], Tt[free]), permc_spec="MMD_AT_PLUS_A")
        dP[:, free] += 0.5 * (Tp[free][:, None] * lu.solve(rhs)).T
    return dP.reshape(dR.shape)


def subcell_force_jacobian(sol: FilmSolution) -> np.ndarray:
    """dF/ds (2 x 4) for s = (eX, eY, vX, vY), rows Fx, Fy."""
    return np.einsum("fij,kij->fk", force_weights(sol.problem), subcell_pressure_tangent(sol))


def subcell_coefficients(sol: FilmSolution) -> DynamicCoefficients:
    """K and C (SPEC §1 sign) of a converged film with its fronts placed inside the cells."""
    dF = subcell_force_jacobian(sol)
    return DynamicCoefficients(K=-dF[:, :2], C=-dF[:, 2:], method="subcell")
