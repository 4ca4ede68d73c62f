"""Numba kernels of the film solvers: plain arrays in, plain arrays out (no validation here)."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def sor_sweeps(C1, C2, aE, aW, aN, aS, S, fixed, P, theta, relax, max_sweeps, tol):
    """Projected Gauss-Seidel / SOR on the p-theta cell balances (the paper's solver, Eq. 3-6).

    Each free cell is solved for given neighbours: full film (theta = 1) if that gives p >= 0,
    otherwise p = 0 and theta from the balance (which is then < 1) -- Eq. 6 cell by cell. The
    pressure is over-relaxed; theta is transported upwind and left unrelaxed. Cells are swept in
    the direction of rotation so theta travels a whole row in one sweep.

    P and theta (nz, n_circ) are updated in place. Returns (sweeps, last_change) where the change
    is max|dP| / max(P) + max|dtheta| of the last sweep.
    """
    nz, nc = P.shape
    change = 0.0
    sweeps = 0
    for sweep in range(max_sweeps):
        dp_max = 0.0
        dth_max = 0.0
        p_max = 1e-300
        for j in range(nz):
            for i in range(nc):
                if fixed[j, i]:
                    continue
                iw = i - 1 if i > 0 else nc - 1
                ie = i + 1 if i < nc - 1 else 0
                rhs = C2[j, i] * theta[j, iw] + aE[j, i] * P[j, ie] + aW[j, i] * P[j, iw] + S[j, i]
                if j < nz - 1:
                    rhs += aN[j, i] * P[j + 1, i]
                if j > 0:
                    rhs += aS[j, i] * P[j - 1, i]
                aP = aE[j, i] + aW[j, i] + aN[j, i] + aS[j, i]
                p_full = (rhs - C1[j, i]) / aP  # pressure if the cell is full (theta = 1)
                p_old = P[j, i]
                th_old = theta[j, i]
                if p_full >= 0.0:
                    p_new = p_old + relax * (p_full - p_old)
                    if p_new < 0.0:
                        p_new = 0.0
                    th_new = 1.0
                else:
                    p_new = 0.0
                    th_new = rhs / C1[j, i]  # < 1 because p_full < 0
                    if th_new < 0.0:
                        th_new = 0.0
                P[j, i] = p_new
                theta[j, i] = th_new
                d = abs(p_new - p_old)
                if d > dp_max:
                    dp_max = d
                d = abs(th_new - th_old)
                if d > dth_max:
                    dth_max = d
                if p_new > p_max:
                    p_max = p_new
        sweeps = sweep + 1
        change = dp_max / p_max + dth_max
        if change < tol:
            break
    return sweeps, change


@numba.njit(cache=True, nogil=True)
def mass_residual(C1, C2, aE, aW, aN, aS, S, P, theta):
    """Cell mass balances R (same formula as operator.residual), for kernels' own convergence checks."""
    nz, nc = P.shape
    R = np.empty_like(P)
    for j in range(nz):
        for i in range(nc):
            iw = i - 1 if i > 0 else nc - 1
            ie = i + 1 if i < nc - 1 else 0
            aP = aE[j, i] + aW[j, i] + aN[j, i] + aS[j, i]
            r = C1[j, i] * theta[j, i] - C2[j, i] * theta[j, iw] + aP * P[j, i]
            r -= aE[j, i] * P[j, ie] + aW[j, i] * P[j, iw]
            if j < nz - 1:
                r -= aN[j, i] * P[j + 1, i]
            if j > 0:
                r -= aS[j, i] * P[j - 1, i]
            R[j, i] = r - S[j, i]
    return R


@numba.njit(cache=True, nogil=True)
def pattern_csc(full, p_rows, p_vals, t_rows, t_vals):
    """CSC arrays of a pattern system: column c is cell c's pressure column (p_rows/p_vals, (n, 5), rows sorted,
    -1 = none) when full[c], its oil-fraction column (t_rows/t_vals, (n, 2)) otherwise. Also each row's sum of
    |entries| (for the infinity norm). Returns (indptr, indices, data, row_abs)."""
    n = full.size
    indptr = np.empty(n + 1, np.int32)
    indptr[0] = 0
    for c in range(n):
        rows = p_rows[c] if full[c] else t_rows[c]
        m = 0
        for s in range(rows.size):
            m += rows[s] >= 0
        indptr[c + 1] = indptr[c] + m
    indices = np.empty(indptr[n], np.int32)
    data = np.empty(indptr[n])
    row_abs = np.zeros(n)
    for c in range(n):
        rows, vals = (p_rows[c], p_vals[c]) if full[c] else (t_rows[c], t_vals[c])
        k = indptr[c]
        for s in range(rows.size):
            r = rows[s]
            if r >= 0:
                indices[k] = r
                data[k] = vals[s]
                row_abs[r] += abs(vals[s])
                k += 1
    return indptr, indices, data, row_abs
