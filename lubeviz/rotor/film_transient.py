"""Time integration with the film force taken from the p-theta solver at every step (SPEC §4).

The linearized coefficients (Sec. 2.1) are a small-motion model; the paper's orbits reach ~15 % of
the clearance at the bearings, so this module integrates Eq. 8 with the *nonlinear* film force:

    M q'' + (C_s + Omega G) q' + K_s q = f_unbalance(t) + f_film(e0 + q_b, q_b') - f_film(e0),

q measured from the static equilibrium (where the film carries the weight). It is split as
(linear part with the equilibrium's K0, C0, integrated exactly: `transient`) + (residual force
r = f_film(e0 + q_b, q_b') - f_film(e0) + K0 q_b + C0 q_b'), which is zero to first order, so an
explicit treatment of r is accurate and stable: r enters the first-order hold of each step
extrapolated linearly from the two previous steps (second order in dt). Each step costs one warm
started film solve per bearing.

K0, C0 are those `bearings` carries. r is zero to first order only when they are the exact tangent of
this mesh's discrete film, the fixed-pattern one (`film_bearings(..., coefficients="fixed-pattern")`);
with the sub-cell default (smooth in Q, ~1 % away from it) r keeps a first-order part of that size,
still small for the explicit coupling. Either way the integrated orbit is that of the discrete film.

For small unbalance the result must tend to the linear response with the fixed-pattern K, C (the
film's small-amplitude limit); `tests/rotor` checks that, and the difference at the paper's
unbalance is an effect the linear model lacks.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import ConvergenceError, InputError
from ..film.feed import Feed, setup_problem
from ..film.linearize import force_jacobian
from ..film.solver import solve
from ..progress import ProgressFn, silent
from .assembly import Rotor
from .elements import X, Y, node_dofs
from .film_bearings import FilmBearings
from .response import Unbalance, unbalance_force, unbalance_response
from .transient import _hold_weights, linear_system, node_output_dofs


MAX_RESIDUAL_SHARE = 0.5  # beyond this the explicit residual coupling loses stability
IMPLICIT_ITERATIONS = 12  # Newton iterations of one implicit step before it is refused
IMPLICIT_TOL = 1e-6  # the step's film force equation solved to this fraction of the static load,
IMPLICIT_ACCEPT = 1e-4  # or, after IMPLICIT_ITERATIONS, to this one (a stall at a cavitation pattern switch)


@dataclass(frozen=True)
class FilmTimeResponse:
    """Samples of x, y at `nodes` (displacement (2*len(nodes), n_t), m) and the film forces (N)."""

    t: np.ndarray
    nodes: tuple[int, ...]
    displacement: np.ndarray
    film_force: np.ndarray  # (n_bearings, 2, n_t): total film force on each journal
    residual_force: np.ndarray  # (n_bearings, 2, n_t): film force minus its linearization
    film_solves: int
    sor_fallbacks: int  # steps where the active set cycled and projected SOR solved the film
    seconds: float

    def node_xy(self, node: int) -> tuple[np.ndarray, np.ndarray]:
        k = self.nodes.index(node)
        return self.displacement[2 * k], self.displacement[2 * k + 1]


def film_time_response(rotor: Rotor, bearings: FilmBearings, unbalances: Sequence[Unbalance], *,
                       duration: float, dt: float = 1e-4, nodes: Sequence[int] = (6, 20),
                       start="steady", implicit: bool = False, progress: ProgressFn = silent) -> FilmTimeResponse:
    """Integrate the rotor on its p-theta films for `duration` s from the linear steady state (or rest).

    `bearings`: the equilibria (position, film, K0, C0) of each bearing at this speed and supply.
    start="steady" starts from the linear model's steady orbit (short transients); "rest" from rest; or a
    state vector (q, q') from the static equilibrium (`orbit_balance.OrbitBalance.state`).
    `implicit`: the residual force at the end of each step is solved for (Newton's method with the films'
    own tangents, `film.linearize.force_jacobian`, on the 2 x n_bearings residual unknowns; the explicit
    prediction starts it) instead of extrapolated: the coupling stays stable where the film is far from its
    linearization (large orbits, oil whirl), at 2-3 film solves per bearing and step instead of one.
    """
    t_start = time.perf_counter()
    omega = bearings.omega
    n_t = int(round(duration / dt)) + 1
    if n_t < 3:
        raise InputError(f"duration {duration!r} s at dt {dt!r} s gives fewer than 3 samples")
    coeffs = bearings.coefficients
    system = linear_system(rotor, omega, coeffs)
    n = system.n_dof
    F = unbalance_force(rotor, omega, unbalances)
    if isinstance(start, str) and start == "steady":
        Q = unbalance_response(rotor, omega, unbalances, coeffs).q
        z0 = np.concatenate([Q.real, (1j * omega * Q).real])
    elif isinstance(start, str) and start == "rest":
        z0 = np.zeros(2 * n)
    elif not isinstance(start, str) and np.shape(start) == (2 * n,):
        z0 = np.asarray(start, dtype=float)  # a given state (q, q'), e.g. a periodic orbit's
    else:
        raise InputError(f"start {start!r}; expected 'steady', 'rest' or a state vector of {2 * n} values")

    b_dofs = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes])  # (n_b, 2)
    flat_b = b_dofs.ravel()
    force_dofs = np.union1d(np.flatnonzero(F), flat_b)
    Minv_cols = np.linalg.solve(system.M, np.eye(n)[:, force_dofs])
    G_in = system.V_inv[:, n:] @ Minv_cols  # modal forcing per unit force at force_dofs
    pos_in_force = {d: k for k, d in enumerate(force_dofs)}
    decay, w0, w1 = _hold_weights(system.eigenvalues, dt)
    out_dofs = node_output_dofs(nodes)
    Vq_b, Vv_b = system.V[flat_b], system.V[n + flat_b]
    Vq_out = system.V[out_dofs]

    def forcing(t, resid):
        f = np.zeros(force_dofs.size)
        fu = (F[force_dofs] * np.exp(1j * omega * t)).real
        f += fu
        for k, d in enumerate(flat_b):
            f[pos_in_force[d]] += resid[k]
        return G_in @ f

    eqs = bearings.equilibria
    films = [e.film for e in eqs]
    f0 = [e.film.force.copy() for e in eqs]
    K0 = [e.coefficients.K for e in eqs]
    C0 = [e.coefficients.C for e in eqs]
    n_b = len(eqs)
    film_force = np.empty((n_b, 2, n_t))
    resid_hist = np.empty((n_b, 2, n_t))
    disp = np.empty((out_dofs.size, n_t))
    lin_size = np.zeros((n_b, n_t))  # |K0 q + C0 q'| at each step: the scale of the film's dynamic force
    window = max(1, int(math.ceil(2 * math.pi / (omega * dt))))  # one revolution of steps
    solves = fallbacks = 0

    def residual(eta, k_step, tangents=None):
        """r at the state eta (modal); with `tangents` (an (2 n_b, 4 n_b) array) also dr/d(q_b, v_b) there."""
        nonlocal solves, fallbacks
        qb = (Vq_b @ eta).real.reshape(n_b, 2)
        vb = (Vv_b @ eta).real.reshape(n_b, 2)
        r = np.empty((n_b, 2))
        for j, e in enumerate(eqs):
            pos = e.position + qb[j]
            if np.hypot(*pos) >= 0.995 * e.bearing.clearance:
                raise ConvergenceError(f"journal {j + 1} reached {np.hypot(*pos) / e.bearing.clearance:.3f} of the "
                                       f"clearance at t = {k_step * dt:.4g} s: the orbit hits the bearing")
            problem = setup_problem(e.bearing, omega, pos, Feed.flow(bearings.flows[j]), velocity=vb[j])
            sol = solve(problem, warm=films[j])
            solves += 1
            if not sol.converged:  # the active set can cycle under strong squeeze: projected SOR does not
                sol = solve(problem, method="sor", warm=films[j], relax=1.9, tol=1e-10)
                fallbacks += 1
            if not sol.converged:
                raise ConvergenceError(f"film {j + 1} at t = {k_step * dt:.4g} s: {sol.message}")
            films[j] = sol
            film_force[j, :, k_step] = sol.force
            lin = K0[j] @ qb[j] + C0[j] @ vb[j]
            r[j] = sol.force - f0[j] + lin
            lin_size[j, k_step] = np.hypot(*lin)
            if tangents is not None:  # dr/dq = dF/dq + K0, dr/dv = dF/dv + C0 (SOR carries none: the static ones)
                dF = force_jacobian(sol) if sol.linear is not None else -np.hstack([K0[j], C0[j]])
                tangents[2 * j:2 * j + 2, 2 * j:2 * j + 2] = dF[:, :2] + K0[j]
                tangents[2 * j:2 * j + 2, 2 * n_b + 2 * j:2 * n_b + 2 * j + 2] = dF[:, 2:] + C0[j]
                continue  # the implicit step needs no guard: its Newton iteration says whether it holds
            # against the linear force's size over the last revolution (an instant where it passes near zero
            # is no measure of the motion's amplitude)
            scale = max(lin_size[j, max(0, k_step - window):k_step + 1].max(), 1e-9 * np.hypot(*f0[j]))
            if k_step > 0 and np.hypot(*r[j]) > MAX_RESIDUAL_SHARE * scale:
                raise ConvergenceError(
                    f"bearing {j + 1} at t = {k_step * dt:.4g} s: the film force departs from its linearization by "
                    f"{np.hypot(*r[j]) / scale:.0%} of the linear force's size over the last revolution; the "
                    "explicit coupling is only valid for orbits where the film stays near-linear (reduce the "
                    "unbalance or the time step)")
        return r.ravel()

    eta = system.V_inv @ z0
    r_prev = r_now = residual(eta, 0)
    resid_hist[:, :, 0] = r_now.reshape(n_b, 2)
    disp[:, 0] = (Vq_out @ eta).real
    g_now = forcing(0.0, r_now)
    report_every = max(1, n_t // 100)
    if implicit:  # q_b, v_b at the step's end are affine in its end residual: d/dr of them, once
        P = np.zeros((force_dofs.size, flat_b.size))
        for k, d in enumerate(flat_b):
            P[pos_in_force[d], k] = 1.0
        Gr = w1[:, None] * (G_in @ P)  # d eta_next / d r_next
        A = np.vstack([(Vq_b @ Gr).real, (Vv_b @ Gr).real])  # (4 n_b, 2 n_b): d(q_b, v_b) / d r_next
        tol_r = IMPLICIT_TOL * max(np.hypot(*f) for f in f0)
    for k in range(n_t - 1):
        r_next = 2.0 * r_now - r_prev  # linear extrapolation of the (small) residual force
        g_next = forcing((k + 1) * dt, r_next)
        eta = decay * eta + w0 * g_now + w1 * (g_next - g_now)
        if implicit:  # Newton on E(r) = residual(eta(r)) - r = 0 from the extrapolation, a step that does not
            T = np.zeros((2 * n_b, 4 * n_b))  # lower |E| halved (the film is piecewise smooth: its cavitation
            E = residual(eta, k + 1, T) - r_next  # pattern switches, and a full step can cycle across a switch)
            for it in range(IMPLICIT_ITERATIONS):
                if np.abs(E).max() <= tol_r:
                    break
                step = np.linalg.solve(np.eye(2 * n_b) - T @ A, E)
                lam = 1.0
                for _ in range(5):
                    T_try = np.zeros_like(T)
                    eta_try = eta + lam * (Gr @ step)
                    E_try = residual(eta_try, k + 1, T_try) - (r_next + lam * step)
                    if np.linalg.norm(E_try) < np.linalg.norm(E):
                        break
                    lam *= 0.5
                r_next, eta, E, T = r_next + lam * step, eta_try, E_try, T_try
            else:  # near a pattern switch Newton can stall a little above the target: accept up to IMPLICIT_ACCEPT
                if np.abs(E).max() > tol_r * IMPLICIT_ACCEPT / IMPLICIT_TOL:
                    raise ConvergenceError(f"the implicit step at t = {(k + 1) * dt:.4g} s did not settle in "
                                           f"{IMPLICIT_ITERATIONS} Newton iterations (film force residual "
                                           f"{np.abs(E).max():.2g} N): reduce the time step")
            r_next = r_next + E  # the film's own force at the final state
        r_prev, r_now = r_now, residual(eta, k + 1) if not implicit else r_next
        resid_hist[:, :, k + 1] = r_now.reshape(n_b, 2)
        g_now = forcing((k + 1) * dt, r_now)
        disp[:, k + 1] = (Vq_out @ eta).real
        if (k + 1) % report_every == 0:
            progress(k + 1, n_t - 1, f"t = {(k + 1) * dt:.4f} s")
    return FilmTimeResponse(t=dt * np.arange(n_t), nodes=tuple(nodes), displacement=disp, film_force=film_force,
                            residual_force=resid_hist, film_solves=solves, sor_fallbacks=fallbacks, seconds=time.perf_counter() - t_start)


def amplitude_ratio(t: np.ndarray, signal: np.ndarray, omega: float, reference: complex) -> complex:
    """1X complex amplitude of `signal` over whole revolutions, divided by `reference`."""
    period = 2 * math.pi / omega
    n_rev = math.floor((t[-1] - t[0]) / period + 1e-9)
    sel = t >= t[-1] - n_rev * period
    e = np.exp(-1j * omega * t[sel])
    amp = 2.0 * np.mean(signal[sel] * e)
    return amp / reference
