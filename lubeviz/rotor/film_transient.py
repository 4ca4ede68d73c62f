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
with the sub-cell default (smooth in Q, off the fixed-pattern tangent by about the old staircase:
docs/notes/film-smoothness.md) r keeps a first-order part of that size, still small for the explicit
coupling. Either way the integrated orbit is that of the discrete film.

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


def _initial_state(rotor: Rotor, omega: float, unbalances, coefficients, start, n: int) -> np.ndarray:
    """The state (q, q') from the static equilibrium that `start` names: the linear steady orbit, rest, or given."""
    if isinstance(start, str) and start == "steady":
        Q = unbalance_response(rotor, omega, unbalances, coefficients).q
        return np.concatenate([Q.real, (1j * omega * Q).real])
    if isinstance(start, str) and start == "rest":
        return np.zeros(2 * n)
    if not isinstance(start, str) and np.shape(start) == (2 * n,):
        return np.asarray(start, dtype=float)  # a given state (q, q'), e.g. a periodic orbit's
    raise InputError(f"start {start!r}; expected 'steady', 'rest' or a state vector of {2 * n} values")


@dataclass(frozen=True, eq=False)
class _ModalStep:
    """The linear part (shaft, K0, C0) in modal coordinates, integrated exactly over a step with a first-order hold
    of its forcing: the unbalance and the residual film forces at the journals."""

    omega: float
    unbalance: np.ndarray  # (n_dof,) complex unbalance force amplitude
    force_dofs: np.ndarray  # the dofs any force acts on
    journal_slots: tuple[int, ...]  # where each journal's x, y sits in force_dofs
    G_in: np.ndarray  # modal forcing per unit force at force_dofs
    decay: np.ndarray
    w0: np.ndarray
    w1: np.ndarray
    Vq_b: np.ndarray  # modes -> journal displacement, velocity, output displacement
    Vv_b: np.ndarray
    Vq_out: np.ndarray

    def forcing(self, t, resid):
        """Modal forcing at time t with residual film forces `resid` (2 n_b,) on the journals."""
        f = np.zeros(self.force_dofs.size)
        fu = (self.unbalance[self.force_dofs] * np.exp(1j * self.omega * t)).real
        f += fu
        for k, slot in enumerate(self.journal_slots):
            f[slot] += resid[k]
        return self.G_in @ f

    def end_residual_gain(self) -> tuple[np.ndarray, np.ndarray]:
        """q_b, v_b at the step's end are affine in its end residual: d eta_next / d r_next and d(q_b, v_b) / d r_next
        (4 n_b, 2 n_b)."""
        P = np.zeros((self.force_dofs.size, len(self.journal_slots)))
        for k, slot in enumerate(self.journal_slots):
            P[slot, k] = 1.0
        Gr = self.w1[:, None] * (self.G_in @ P)
        return Gr, np.vstack([(self.Vq_b @ Gr).real, (self.Vv_b @ Gr).real])


def _modal_step(rotor: Rotor, system, F: np.ndarray, omega: float, dt: float, nodes) -> _ModalStep:
    """The step's exact hold weights for `system` (`transient.linear_system`) and the forced and observed dofs."""
    n = system.n_dof
    flat_b = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes]).ravel()  # (2 n_b,)
    force_dofs = np.union1d(np.flatnonzero(F), flat_b)
    Minv_cols = np.linalg.solve(system.M, np.eye(n)[:, force_dofs])
    pos_in_force = {d: k for k, d in enumerate(force_dofs)}
    decay, w0, w1 = _hold_weights(system.eigenvalues, dt)
    return _ModalStep(omega=omega, unbalance=F, force_dofs=force_dofs,
                      journal_slots=tuple(pos_in_force[d] for d in flat_b), G_in=system.V_inv[:, n:] @ Minv_cols,
                      decay=decay, w0=w0, w1=w1, Vq_b=system.V[flat_b], Vv_b=system.V[n + flat_b],
                      Vq_out=system.V[node_output_dofs(nodes)])


class _JournalFilms:
    """The film at each journal along the integration (each step warm-started from the last), the film forces it
    gave and the counts of solves and SOR fallbacks."""

    def __init__(self, bearings: FilmBearings, dt: float, n_t: int):
        eqs = bearings.equilibria
        self.bearings, self.dt = bearings, dt
        self.films = [e.film for e in eqs]
        self.f0 = [e.film.force.copy() for e in eqs]
        self.K0 = [e.coefficients.K for e in eqs]
        self.C0 = [e.coefficients.C for e in eqs]
        self.film_force = np.empty((len(eqs), 2, n_t))
        self.lin_size = np.zeros((len(eqs), n_t))  # |K0 q + C0 q'| at each step: the scale of the film's dynamic force
        self.window = max(1, int(math.ceil(2 * math.pi / (bearings.omega * dt))))  # one revolution of steps
        self.solves = self.fallbacks = 0

    def solve(self, j: int, pos, velocity, k_step: int):
        """The film of journal j at `pos` moving at `velocity`, warm-started from its last."""
        e = self.bearings.equilibria[j]
        if np.hypot(*pos) >= 0.995 * e.bearing.clearance:
            raise ConvergenceError(f"journal {j + 1} reached {np.hypot(*pos) / e.bearing.clearance:.3f} of the "
                                   f"clearance at t = {k_step * self.dt:.4g} s: the orbit hits the bearing")
        problem = setup_problem(e.bearing, self.bearings.omega, pos, Feed.flow(self.bearings.flows[j]),
                                velocity=velocity)
        sol = solve(problem, warm=self.films[j])
        self.solves += 1
        if not sol.converged:  # the active set can cycle under strong squeeze: projected SOR does not
            sol = solve(problem, method="sor", warm=self.films[j], relax=1.9, tol=1e-10)
            self.fallbacks += 1
        if not sol.converged:
            raise ConvergenceError(f"film {j + 1} at t = {k_step * self.dt:.4g} s: {sol.message}")
        self.films[j] = sol
        self.film_force[j, :, k_step] = sol.force
        return sol

    def check_near_linear(self, j: int, k_step: int, r_j) -> None:
        """The explicit coupling holds while r stays small against the linear force's size over the last revolution
        (an instant where it passes near zero is no measure of the motion's amplitude)."""
        scale = max(self.lin_size[j, max(0, k_step - self.window):k_step + 1].max(), 1e-9 * np.hypot(*self.f0[j]))
        if k_step > 0 and np.hypot(*r_j) > MAX_RESIDUAL_SHARE * scale:
            raise ConvergenceError(
                f"bearing {j + 1} at t = {k_step * self.dt:.4g} s: the film force departs from its linearization by "
                f"{np.hypot(*r_j) / scale:.0%} of the linear force's size over the last revolution; the "
                "explicit coupling is only valid for orbits where the film stays near-linear (reduce the "
                "unbalance or the time step)")

    def residual(self, modal: _ModalStep, eta, k_step: int, implicit: bool = False):
        """r = f_film(e0 + q_b, q_b') - f_film(e0) + K0 q_b + C0 q_b' at the state eta (modal). `implicit`: no
        near-linear guard (the implicit step's Newton iteration says whether it holds)."""
        n_b = len(self.films)
        qb = (modal.Vq_b @ eta).real.reshape(n_b, 2)
        vb = (modal.Vv_b @ eta).real.reshape(n_b, 2)
        r = np.empty((n_b, 2))
        for j, (K0, C0) in enumerate(zip(self.K0, self.C0)):
            sol = self.solve(j, self.bearings.equilibria[j].position + qb[j], vb[j], k_step)
            lin = K0 @ qb[j] + C0 @ vb[j]
            r[j] = sol.force - self.f0[j] + lin
            self.lin_size[j, k_step] = np.hypot(*lin)
            if not implicit:
                self.check_near_linear(j, k_step, r[j])
        return r.ravel()

    def tangents(self) -> np.ndarray:
        """dr/d(q_b, v_b) ((2 n_b, 4 n_b)) at the films last solved: dr/dq = dF/dq + K0, dr/dv = dF/dv + C0 (SOR
        carries none: the static ones). Asked for only where a Newton step needs it (a converged state's is not)."""
        n_b = len(self.films)
        T = np.zeros((2 * n_b, 4 * n_b))
        for j, (sol, K0, C0) in enumerate(zip(self.films, self.K0, self.C0)):
            dF = force_jacobian(sol) if sol.linear is not None else -np.hstack([K0, C0])
            T[2 * j:2 * j + 2, 2 * j:2 * j + 2] = dF[:, :2] + K0
            T[2 * j:2 * j + 2, 2 * n_b + 2 * j:2 * n_b + 2 * j + 2] = dF[:, 2:] + C0
        return T


def _implicit_step(films: _JournalFilms, modal: _ModalStep, eta, r_next, k_step: int, Gr, A, tol_r):
    """The residual force at the step's end solved for: Newton on E(r) = residual(eta(r)) - r = 0 from the
    extrapolation, a step that does not lower |E| halved (the film is piecewise smooth: its cavitation pattern
    switches, and a full step can cycle across a switch). The end residual and state."""
    E = films.residual(modal, eta, k_step, implicit=True) - r_next
    for _ in range(IMPLICIT_ITERATIONS):
        if np.abs(E).max() <= tol_r:
            break
        step = np.linalg.solve(np.eye(E.size) - films.tangents() @ A, E)
        lam = 1.0
        for _ in range(5):
            eta_try = eta + lam * (Gr @ step)
            E_try = films.residual(modal, eta_try, k_step, implicit=True) - (r_next + lam * step)
            if np.linalg.norm(E_try) < np.linalg.norm(E):
                break
            lam *= 0.5
        r_next, eta, E = r_next + lam * step, eta_try, E_try
    else:  # near a pattern switch Newton can stall a little above the target: accept up to IMPLICIT_ACCEPT
        if np.abs(E).max() > tol_r * IMPLICIT_ACCEPT / IMPLICIT_TOL:
            raise ConvergenceError(f"the implicit step at t = {k_step * films.dt:.4g} s did not settle in "
                                   f"{IMPLICIT_ITERATIONS} Newton iterations (film force residual "
                                   f"{np.abs(E).max():.2g} N): reduce the time step")
    return r_next + E, eta  # the film's own force at the final state


def film_time_response(rotor: Rotor, bearings: FilmBearings, unbalances: Sequence[Unbalance], *,
                       duration: float, dt: float = 1e-4, nodes: Sequence[int] | None = None,
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
    rotor.require_films_on_ground("the time integration on the p-theta films")
    t_start = time.perf_counter()
    nodes = tuple(rotor.bearing_nodes) if nodes is None else tuple(nodes)  # default: at the bearings
    omega = bearings.omega
    n_t = int(round(duration / dt)) + 1
    if n_t < 3:
        raise InputError(f"duration {duration!r} s at dt {dt!r} s gives fewer than 3 samples")
    system = linear_system(rotor, omega, bearings.coefficients)
    F = unbalance_force(rotor, omega, unbalances)
    z0 = _initial_state(rotor, omega, unbalances, bearings.coefficients, start, system.n_dof)
    modal = _modal_step(rotor, system, F, omega, dt, nodes)
    films = _JournalFilms(bearings, dt, n_t)
    n_b = len(films.films)
    resid_hist = np.empty((n_b, 2, n_t))
    disp = np.empty((modal.Vq_out.shape[0], n_t))

    eta = system.V_inv @ z0
    r_prev = r_now = films.residual(modal, eta, 0)
    resid_hist[:, :, 0] = r_now.reshape(n_b, 2)
    disp[:, 0] = (modal.Vq_out @ eta).real
    g_now = modal.forcing(0.0, r_now)
    report_every = max(1, n_t // 100)
    if implicit:
        Gr, A = modal.end_residual_gain()
        tol_r = IMPLICIT_TOL * max(np.hypot(*f) for f in films.f0)
    for k in range(n_t - 1):
        r_next = 2.0 * r_now - r_prev  # linear extrapolation of the (small) residual force
        g_next = modal.forcing((k + 1) * dt, r_next)
        eta = modal.decay * eta + modal.w0 * g_now + modal.w1 * (g_next - g_now)
        if implicit:
            r_next, eta = _implicit_step(films, modal, eta, r_next, k + 1, Gr, A, tol_r)
        r_prev, r_now = r_now, films.residual(modal, eta, k + 1) if not implicit else r_next
        resid_hist[:, :, k + 1] = r_now.reshape(n_b, 2)
        g_now = modal.forcing((k + 1) * dt, r_now)
        disp[:, k + 1] = (modal.Vq_out @ eta).real
        if (k + 1) % report_every == 0:
            progress(k + 1, n_t - 1, f"t = {(k + 1) * dt:.4f} s")
    return FilmTimeResponse(t=dt * np.arange(n_t), nodes=tuple(nodes), displacement=disp, film_force=films.film_force,
                            residual_force=resid_hist, film_solves=films.solves, sor_fallbacks=films.fallbacks,
                            seconds=time.perf_counter() - t_start)


def amplitude_ratio(t: np.ndarray, signal: np.ndarray, omega: float, reference: complex) -> complex:
    """1X complex amplitude of `signal` over whole revolutions, divided by `reference`."""
    period = 2 * math.pi / omega
    n_rev = math.floor((t[-1] - t[0]) / period + 1e-9)
    sel = t >= t[-1] - n_rev * period
    e = np.exp(-1j * omega * t[sel])
    amp = 2.0 * np.mean(signal[sel] * e)
    return amp / reference
