"""Dynamic coefficients: the derivative of the discrete film force with the cavitation pattern held.

Around a converged film (p, theta) with pattern F (full cells) the balances R(p, theta; s) = 0 are
linear in the unknowns of that pattern, so for a parameter s (journal position eX, eY or velocity
vX, vY) the tangent follows from one more solve with the factorization the solver already has:

    J dx/ds = -dR/ds (at fixed p, theta),    dF/ds = w . dP/ds

This is the small-step limit of finite differences as long as no cell changes state (SPEC §3), and
it needs no step size. Lund's sign (SPEC §1): f = f0 - K (q - q0) - C qdot, so K = -dF/dq and
C = -dF/dqdot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .operator import coefficient_derivatives, force_weights, residual
from .solver import FilmSolution


@dataclass(frozen=True)
class DynamicCoefficients:
    """Stiffness K (N/m) and damping C (N*s/m), 2x2 each, rows/cols (X, Y), SPEC §1 sign."""

    K: np.ndarray
    C: np.ndarray
    method: str

    def as_dict(self) -> dict:
        return {"K": self.K.tolist(), "C": self.C.tolist(), "method": self.method}


def balance_derivatives(sol: FilmSolution) -> np.ndarray:
    """dR/ds at fixed (P, theta) for s = (eX, eY, vX, vY); shape (4, nz, n_circ)."""
    pr = sol.problem
    m = pr.mesh
    c, om = pr.clearance, pr.omega
    zeros = np.zeros(m.shape)
    sin_c = np.broadcast_to(np.sin(m.alpha), m.shape)
    cos_c = np.broadcast_to(np.cos(m.alpha), m.shape)
    sin_e = np.broadcast_to(np.sin(m.alpha_east), m.shape)
    cos_e = np.broadcast_to(np.cos(m.alpha_east), m.shape)
    sq_unit = 2.0 * m.d_alpha / (om * c)  # d(sq)/d(hdot)
    cases = [
        (sin_c / c, sin_e / c, zeros),  # eX: dh/deX = sin(alpha)   (Eq. 1)
        (-cos_c / c, -cos_e / c, zeros),  # eY: dh/deY = -cos(alpha)
        (zeros, zeros, sq_unit * sin_c),  # vX: d(dh/dt)/dvX = sin(alpha)
        (zeros, zeros, -sq_unit * cos_c),  # vY
    ]
    out = np.empty((4,) + m.shape)
    for k, (dH, dH_e, dsq) in enumerate(cases):
        dcoef = coefficient_derivatives(m, pr.H, pr.H_e, dH, dH_e, dsq)
        out[k] = residual(dcoef, sol.P, sol.theta)
    return out


def force_jacobian(sol: FilmSolution) -> np.ndarray:
    """dF/ds (2 x 4): columns d/deX, d/deY, d/dvX, d/dvY, rows Fx, Fy; pattern held fixed."""
    if sol.linear is None:
        raise ValueError("this film solution carries no factorization; solve it with the active-set method")
    dP = sol.linear.tangent(balance_derivatives(sol))
    w = force_weights(sol.problem)
    return np.einsum("fij,kij->fk", w, dP)


def fixed_pattern_coefficients(sol: FilmSolution) -> DynamicCoefficients:
    """K and C from the fixed-pattern linearization of a converged active-set solution."""
    dF = force_jacobian(sol)
    return DynamicCoefficients(K=-dF[:, :2], C=-dF[:, 2:], method="fixed-pattern")
