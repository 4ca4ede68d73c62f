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
    out = np.empty((4,) + m.shape)
    no_squeeze = np.zeros(m.shape)
    for k, (centre, east) in enumerate(((np.sin(m.alpha), np.sin(m.alpha_east)),  # eX: dh/deX = sin(alpha) (Eq. 1)
                                        (-np.cos(m.alpha), -np.cos(m.alpha_east)))):  # eY: dh/deY = -cos(alpha)
        dH = np.broadcast_to(centre / c, m.shape)
        dH_e = np.broadcast_to(east / c, m.shape)
        out[k] = residual(coefficient_derivatives(m, pr.H, pr.H_e, dH, dH_e, no_squeeze), sol.P, sol.theta)
    # a velocity changes only the squeeze term of C1 (d(sq)/d(hdot) = 2 d_alpha / (Omega c)), so dR = d(sq) theta
    sq_unit = 2.0 * m.d_alpha / (om * c)
    out[2] = sq_unit * np.sin(m.alpha) * sol.theta  # vX: d(dh/dt)/dvX = sin(alpha)
    out[3] = -sq_unit * np.cos(m.alpha) * sol.theta  # vY
    return out


def force_jacobian(sol: FilmSolution) -> np.ndarray:
    """dF/ds (2 x 4): columns d/deX, d/deY, d/dvX, d/dvY, rows Fx, Fy; pattern held fixed."""
    if sol.linear is None:
        raise ValueError("this film solution carries no factorization; solve it with the active-set method")
    dP = sol.linear.tangent(balance_derivatives(sol))
    w = force_weights(sol.problem)
    return np.einsum("fij,kij->fk", w, dP)


def supply_derivative(sol: FilmSolution) -> np.ndarray:
    """dF/dQ (2,): the film force's change with the supply flow (N per m^3/s) at fixed journal position and
    velocity, pattern held. The supply enters the balances only as the groove volumes' source, linear in Q
    (operator: outflow - inflow - source), so dR/dQ = -source / Q and one more back-substitution gives it."""
    if sol.linear is None:
        raise ValueError("this film solution carries no factorization; solve it with the active-set method")
    pr = sol.problem
    src = pr.coef.S
    if not np.any(src):
        return np.zeros(2)
    # the source is Q * (groove area share) / (mirror * flux_ref) (`build_problem`), summing to
    # Q / (mirror * flux_ref): per unit of Q it is the source over that sum times mirror * flux_ref
    per_q = src / (np.sum(src) * pr.flux_ref * pr.mesh.mirror_factor)
    dP = sol.linear.tangent(-per_q[None])
    w = force_weights(pr)
    return np.einsum("fij,kij->fk", w, dP)[:, 0]


def fixed_pattern_coefficients(sol: FilmSolution) -> DynamicCoefficients:
    """K and C from the fixed-pattern linearization of a converged active-set solution."""
    dF = force_jacobian(sol)
    return DynamicCoefficients(K=-dF[:, :2], C=-dF[:, 2:], method="fixed-pattern")


def finite_difference_coefficients(bearing, omega: float, position, feed, *, step: float | None = None,
                                   velocity_step: float | None = None, warm: FilmSolution | None = None
                                   ) -> DynamicCoefficients:
    """K and C by central differences of fully re-solved films (the cavitation pattern may move).

    Default steps: 1e-3 c in position and 1e-3 c Omega in velocity -- small enough that the
    truncation error is O(1e-6) where the pattern is stable, so the result checks the fixed-pattern
    derivative; near Q_T the cavitation boundary moves within such a step and the result depends
    on it (see tests/film/test_coefficients.py).
    """
    from .feed import setup_problem
    from .solver import solve

    c = bearing.clearance
    step = 1e-3 * c if step is None else step
    velocity_step = 1e-3 * c * omega if velocity_step is None else velocity_step
    pos = np.asarray(position, dtype=float)
    dF = np.empty((2, 4))
    for k in range(4):
        d = np.zeros(4)
        d[k] = step if k < 2 else velocity_step
        forces = []
        for sign in (1.0, -1.0):
            prob = setup_problem(bearing, omega, pos + sign * d[:2], feed, velocity=sign * d[2:])
            forces.append(solve(prob, warm=warm).raise_if_failed().force)
        dF[:, k] = (forces[0] - forces[1]) / (2.0 * d[k])
    return DynamicCoefficients(K=-dF[:, :2], C=-dF[:, 2:], method=f"central-fd(step={step:.3g} m)")

