"""The periodic orbit on the p-theta films: harmonic balance with the film solved along the orbit.

The linear model (Sec. 2.1) replaces each film by its tangent K0, C0 at the static equilibrium. For
larger orbits the film force is not linear in the journal's motion: the cavitated region breathes with
the orbit, the squeeze term redistributes the supplied oil. The steady response to an unbalance is then
still periodic at the shaft speed, but holds the harmonics 2X, 3X, ... and a static shift (0X) of the
journals. This module finds that periodic orbit by alternating frequency-time harmonic balance:

    D(h Omega) Q_h = F_h + L^T R_h,   h = 0 .. H,

with D the rotor's dynamic stiffness at h Omega (spin Omega) including K0, C0, F the unbalance force
(h = 1), L the bearings' x, y rows, and R_h the harmonics of the residual film force

    r(t) = f_film(e0 + q_b(t), q_b'(t)) - f_film(e0) + K0 q_b(t) + C0 q_b'(t),

sampled at N points of one revolution (the film re-solved at each: a quasi-static p-theta solve with the
journal's squeeze velocity and the bearing's supply flow, as `film_transient` does step by step). r is
zero to first order, so the fixed point Q_b = A + B R(Q_b) (A: the linear orbit at the bearings, B: the
receptance there) starts at the linear orbit and is solved by Newton's method: each film solve also
gives the film's tangent along the orbit (`film.linearize.force_jacobian`, the pattern held, one more
back-substitution), so the Jacobian of the map costs no extra film solve, and a step that does not
reduce the residual is halved. It settles in 4-8 steps where a fixed-point iteration (Anderson-
accelerated) took 40-60 and stalled on the larger orbits, 32 film solves each. While the orbit still moves
by more than INEXACT_ABOVE of its 1X, each film stops after INEXACT_STEPS active-set steps and its last
pattern's force and tangent are used as they are (an inexact Newton method: far from the orbit an exact
film buys nothing); closer in every film is exact, so the answer is the exact films' orbit. From the linear
orbit on 100 x 100 films at the paper's unbalance: 22.5 -> 8.2 s (8.3 -> 4.1 active-set steps per film,
fewer backtracked steps), 25 -> 13 s at 0.6 x, 34 -> 13 s at (673, 467) ml/min; orbits equal to 2e-6. The harmonics at
the probe planes follow from the converged R. As the unbalance shrinks the orbit tends to the linear one
and 2X/1X grows in proportion to the amplitude (`tests/rotor/test_orbit_balance.py`, against the time
integration of `film_transient` as the independent reference).

Sub-synchronous whirl is not periodic at the shaft speed and is outside this method: the linear
stability at the equilibrium (`rotor.stability`) says whether it is to be expected.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..errors import ConvergenceError, InputError
from ..film.feed import Feed, setup_problem
from ..film.linearize import force_jacobian, supply_derivative
from ..film.solver import solve, solve_active_set
from ..progress import ProgressFn, silent
from .assembly import Rotor, bearing_matrices
from .directional import directional_components
from .elements import X, Y, node_dofs
from .film_bearings import FilmBearings
from .response import Unbalance, unbalance_force

CONTACT = 0.95  # eccentricity ratio beyond which the orbit is refused (the journal nearly touches)
HARMONICS, POINTS = 5, 24  # against 6 and 36: the journals' 1X correction within 1.3 % of its size (3 and 16: 9 %)
FILM_THREADS = min(2, os.cpu_count() or 1)  # film solves run side by side (the LU and the kernels release the
# GIL: 1.38 x on this 2-core machine with 2 threads, measured on the 24 films of one revolution)
MAX_STEP = 0.1  # largest move of a journal in one Newton step, relative to its clearance
INEXACT_ABOVE = 1e-2  # while the orbit still changes by more than this (of its 1X), each film solve stops after
INEXACT_STEPS = 2  # this many active-set steps (an inexact Newton method); closer in, every film is exact


@dataclass(frozen=True)
class OrbitBalance:
    """The periodic orbit: complex harmonic amplitudes, x(t) = Re sum_h X_h e^{i h Omega t}."""

    omega: float
    nodes: tuple[int, ...]
    x: np.ndarray  # (H + 1, n_nodes) complex; h = 0 is the static shift (real)
    y: np.ndarray
    bearing_x: np.ndarray  # (H + 1, n_bearings) at the journals
    bearing_y: np.ndarray
    linear_x: np.ndarray  # (n_nodes,) the linear model's 1X at the nodes, for comparison
    linear_y: np.ndarray
    iterations: int
    film_solves: int
    residual: float  # last relative change of the journals' harmonics
    max_eccentricity: float
    seconds: float
    dofs: np.ndarray | None = None  # (H + 1, n_dof) every degree of freedom's harmonics (the initial state)
    # with `flow_slopes`: the derivative of the nonlinear part (x, y minus the linear orbit, every harmonic) at
    # the nodes in each bearing's supply flow, (n_bearings, H + 1, n_nodes) complex, per m^3/s
    flow_slope_x: np.ndarray | None = None
    flow_slope_y: np.ndarray | None = None
    # and its derivative in the logarithm of the unbalance's size (all unbalances scaled alike), (H + 1, n_nodes)
    scale_slope_x: np.ndarray | None = None
    scale_slope_y: np.ndarray | None = None
    films: tuple | None = field(default=None, repr=False, compare=False)  # the last film at each bearing, phase
    bearings: FilmBearings | None = field(default=None, repr=False, compare=False)  # the equilibria it ran on

    @property
    def journal_harmonics(self) -> np.ndarray:
        """(H + 1, 2 n_bearings) complex: x, y of each journal, interleaved (the balance's unknowns)."""
        out = np.empty((self.bearing_x.shape[0], 2 * self.bearing_x.shape[1]), dtype=complex)
        out[:, 0::2], out[:, 1::2] = self.bearing_x, self.bearing_y
        return out

    @property
    def harmonics(self) -> int:
        return self.x.shape[0] - 1

    def harmonic_ratio(self, h: int, node_index: int = 0) -> float:
        """(|Zf| + |Zb|) of harmonic h over the forward 1X |Zf| at a node: the +hX and -hX lines summed,
        each relative to the forward 1X as `signals.lines` reports them."""
        zf1, _ = directional_components(self.x[1, node_index], self.y[1, node_index])
        zf, zb = directional_components(self.x[h, node_index], self.y[h, node_index])
        return float((abs(zf) + abs(zb)) / abs(zf1))

    def state(self, t: float = 0.0) -> np.ndarray:
        """(q, q') of every degree of freedom at time t, measured from the static equilibrium: the state to
        start a time integration on this orbit."""
        h = np.arange(self.harmonics + 1)
        e = np.exp(1j * h * self.omega * t)
        return np.concatenate([np.real(e @ self.dofs), np.real((1j * h * self.omega * e) @ self.dofs)])

    def signals(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """x(t), y(t) at every node: (n_nodes, len(t)) each."""
        e = np.exp(1j * np.outer(np.arange(self.harmonics + 1), self.omega * np.asarray(t, dtype=float)))
        return np.real(self.x.T @ e), np.real(self.y.T @ e)


@functools.lru_cache(maxsize=None)
def _pool(threads: int) -> ThreadPoolExecutor:
    """One lasting pool per thread count: a new pool per balance made new threads, and each new thread a new
    malloc arena, which kept the freed factorizations' memory (3 GB more per large-orbit fit, measured)."""
    return ThreadPoolExecutor(threads, thread_name_prefix="lubeviz-film")


def _mapped_film(src, like):
    """`like` (a film on this mesh) carrying `src`'s fields (a film on another mesh of the same bearing), each
    cell the value of the source cell holding its centre: a warm start, whose cavitation pattern is all the film
    solve takes from it (the answer is the film's own)."""
    ms, mt = src.problem.mesh, like.problem.mesh
    edges = np.cumsum(ms.d_alpha)
    col = np.minimum(np.searchsorted(edges, np.mod(mt.alpha - ms.alpha_offset, 2 * math.pi), side="right"),
                     ms.n_circ - 1)
    row = np.minimum((mt.z / ms.dz).astype(int), ms.nz - 1)
    pick = np.ix_(row, col)
    return dataclasses.replace(like, P=src.P[pick], theta=src.theta[pick], linear=None)


def _dynamic_stiffness(rotor: Rotor, omega: float, frequency: float, K, C) -> np.ndarray:
    """At `frequency` with the shaft spinning at `omega`; K, C: shaft + bearings (`bearing_matrices`)."""
    return K - frequency**2 * rotor.M + 1j * frequency * (C + omega * rotor.G)


def orbit_balance(rotor: Rotor, bearings: FilmBearings, unbalances: Sequence[Unbalance], *,
                  nodes: Sequence[int] = (6, 20), harmonics: int = HARMONICS, points: int = POINTS, tol: float = 1e-5,
                  max_iter: int = 30, start: OrbitBalance | None = None, threads: int | None = None,
                  flow_slopes: Sequence | None = None, progress: ProgressFn = silent) -> OrbitBalance:
    """The periodic orbit of `rotor` on the films of `bearings` under `unbalances` (harmonic balance).

    `harmonics` H (>= 1) and `points` N per revolution (>= 2H + 2, so no harmonic aliases onto another).
    Raises ConvergenceError when the iteration does not settle (an orbit too large for a periodic
    solution near the linear one) or the journal approaches the bearing wall.
    `start`: the orbit at a nearby operating point (same speed; its harmonics padded or cut to H, each point
    warm-started from its nearest phase point: so a coarser balance starts a finer one), from which Newton
    starts (its films warm-start the film solves when they have this mesh): a continuation along the branch
    that grows from the linear orbit. Without it Newton starts at the linear orbit. (Far from it, e.g. from the orbit at flows
    10-20 % away, a fixed-point iteration was seen to land on another periodic solution with the same 1X
    within 3 % and another 0X and 3X: the branch that grows from the linear orbit is the one computed here.)
    `flow_slopes`: per bearing, the derivatives of its equilibrium in its own supply flow, (d position (2,),
    d K0 (2, 2), d C0 (2, 2)) per m^3/s; with them the balance also returns the derivative of its nonlinear part
    in each flow (`flow_slope_x`, `_y`) by implicit differentiation of the converged balance: each exact film
    also gives its force's derivative in the supply at fixed motion (`film.linearize.supply_derivative`, one
    back-substitution), and the balance's own Newton matrix carries it to the orbit. No further balance.
    """
    t0 = time.perf_counter()
    threads = FILM_THREADS if threads is None else max(1, int(threads))
    H, N = int(harmonics), int(points)
    if H < 1 or N < 2 * H + 2:
        raise InputError(f"{H} harmonics need at least {2 * H + 2} points per revolution, got {N}")
    omega = bearings.omega
    eqs = bearings.equilibria
    nb = len(eqs)
    n = rotor.n_dof
    Kt, Ct = bearing_matrices(rotor, bearings.coefficients)
    Lb = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes]).ravel()
    Lo = np.array([node_dofs(rotor.check_node(int(nd), "node"))[[X, Y]] for nd in nodes]).ravel()
    F1 = unbalance_force(rotor, omega, unbalances)
    B, Bo, A, Ao, full_b, full_a = [], [], [], [], [], []
    for h in range(H + 1):
        D = _dynamic_stiffness(rotor, omega, h * omega, Kt, Ct)
        Xb = np.linalg.solve(D, np.eye(n)[:, Lb])  # response to unit forces at the bearings
        B.append(Xb[Lb])
        Bo.append(Xb[Lo])
        full_b.append(Xb)
        if h == 1:
            u = np.linalg.solve(D, F1)
        else:
            u = np.zeros(n, complex)
        A.append(u[Lb])
        Ao.append(u[Lo])
        full_a.append(u)
    A, B = np.array(A), np.array(B)  # (H+1, 2nb), (H+1, 2nb, 2nb)
    phase = 2 * math.pi * np.arange(N) / N  # Omega t_n over one revolution
    E = np.exp(1j * np.outer(np.arange(H + 1), phase))  # (H+1, N)
    hw = 1j * omega * np.arange(H + 1)
    f0 = [e.film.force.copy() for e in eqs]
    K0 = [e.coefficients.K for e in eqs]
    C0 = [e.coefficients.C for e in eqs]
    films = [[e.film] * N for e in eqs]  # warm starts: each phase point from its own last solve
    if start is not None:
        if start.films is None or abs(start.omega - omega) > 1e-9 * omega:
            raise InputError("orbit_balance: the start orbit has another speed or carries no films")
        n_s = len(start.films[0])  # another point count: each point warm-starts from the start's nearest phase
        near = [int(round(k * n_s / N)) % n_s for k in range(N)]
        if all(f[0].P.shape == e.film.P.shape for f, e in zip(start.films, eqs)):
            films = [[f[i] for i in near] for f in start.films]
        else:  # an orbit on another film mesh: its harmonics are the start, its films' patterns the films' starts
            films = [[_mapped_film(sf[i], e.film) for i in near] for sf, e in zip(start.films, eqs)]
    solves = 0

    want_q = flow_slopes is not None

    def one_film(j, k, pos, v, exact=True):
        """The film of bearing j at phase point k (journal at `pos`, velocity `v`), solved (thread-safe: each
        (j, k) has its own warm start), with its force residual and tangent. Not `exact`: at most
        INEXACT_STEPS active-set steps, the last pattern's force and tangent taken as they are."""
        e = eqs[j]
        problem = setup_problem(e.bearing, omega, pos, Feed.flow(bearings.flows[j]), velocity=v)
        warm = films[j][k]
        if not exact and warm.P.shape == problem.mesh.shape:
            sol = solve_active_set(problem, warm.full, max_iter=INEXACT_STEPS, partial=True)
            films[j][k] = dataclasses.replace(sol, linear=None)
            return sol.force, force_jacobian(sol), None
        sol = solve(problem, warm=warm)
        if not sol.converged:  # the active set can cycle under strong squeeze: projected SOR does not
            sol = solve(problem, method="sor", warm=warm, relax=1.9, tol=1e-10)
        if not sol.converged:
            raise ConvergenceError(f"film {j + 1} at phase {360 * k / N:.0f} deg: {sol.message}")
        dF = force_jacobian(sol) if sol.linear is not None else None  # the film's tangent with its pattern held
        dQ = supply_derivative(sol) if (want_q and sol.linear is not None) else None
        # (SOR carries none: there the step uses the static tangent, a quasi-Newton step). The warm start needs
        # the fields only: the factorization (~10 MB at 100 x 100) is not kept, 48 of them per balance were
        films[j][k] = dataclasses.replace(sol, linear=None)
        return sol.force, dF, dQ

    def residual_harmonics(qb, exact=True):
        """R (2nb, H+1) of the orbit qb, and each film's tangent along it: dr/dq, dr/dv (nb, N, 2, 2)."""
        nonlocal solves
        q_t = np.real(qb.T @ E)  # (2nb, N)
        v_t = np.real((qb * hw[:, None]).T @ E)
        r = np.empty((2 * nb, N))
        dq = np.zeros((nb, N, 2, 2))
        dv = np.zeros((nb, N, 2, 2))
        dfq = np.zeros((nb, N, 2))
        jobs, max_eps = [], 0.0
        for j, e in enumerate(eqs):
            for k in range(N):
                pos = e.position + q_t[2 * j:2 * j + 2, k]
                eps = math.hypot(*pos) / e.bearing.clearance
                max_eps = max(max_eps, eps)
                if eps >= CONTACT:
                    raise ConvergenceError(f"bearing {j + 1}: the orbit reaches {eps:.2f} of the clearance; no "
                                           "periodic orbit near the linear one (the journal nearly touches)")
                jobs.append((j, k, pos, v_t[2 * j:2 * j + 2, k], exact))
        results = list(pool.map(lambda job: one_film(*job), jobs)) if pool is not None else \
            [one_film(*job) for job in jobs]
        solves += len(jobs)
        for (j, k, *_), (force, dF, dQ) in zip(jobs, results):
            q, v = q_t[2 * j:2 * j + 2, k], v_t[2 * j:2 * j + 2, k]
            r[2 * j:2 * j + 2, k] = force - f0[j] + K0[j] @ q + C0[j] @ v
            if dF is not None:
                dq[j, k], dv[j, k] = dF[:, :2] + K0[j], dF[:, 2:] + C0[j]
            if dQ is not None:
                dfq[j, k] = dQ
        return harmonics_of(r), dq, dv, max_eps, dfq

    def harmonics_of(r):
        R = (r @ E.conj().T) / N  # (..., 2nb, H+1)
        R[..., 1:] *= 2.0
        R[..., 0] = R[..., 0].real
        return R

    def pack(qb):
        return np.concatenate([qb.real.ravel(), qb[1:].imag.ravel()])

    def unpack(z):
        m = (H + 1) * 2 * nb
        re = z[:m].reshape(H + 1, 2 * nb)
        im = np.zeros_like(re)
        im[1:] = z[m:].reshape(H, 2 * nb)
        return re + 1j * im

    def G(z, exact=True):
        R, dq, dv, eps, dfq = residual_harmonics(unpack(z), exact)
        return pack(A + np.einsum("hij,jh->hi", B, R)), (R, dq, dv, eps, dfq)

    def orbit_r(dq, dv, dqb):
        """The residual force's change r (..., 2nb, N) for orbit changes dqb (..., H+1, 2nb), with the films'
        tangents along the orbit (dq, dv)."""
        lead = dqb.shape[:-2]
        q_t = np.real(np.einsum("...hm,hn->...mn", dqb, E)).reshape(lead + (nb, 2, N))
        v_t = np.real(np.einsum("...hm,hn->...mn", dqb * hw[:, None], E)).reshape(lead + (nb, 2, N))
        dr = np.einsum("bnij,...bjn->...bin", dq, q_t) + np.einsum("bnij,...bjn->...bin", dv, v_t)
        return dr.reshape(lead + (2 * nb, N))

    def G_jacobian(dq, dv):
        """dG/dz (n_z, n_z): G is linear in R, R in r, and r's tangent is the films' (dq, dv)."""
        nz = (2 * H + 1) * 2 * nb
        dqb = np.array([unpack(u) for u in np.eye(nz)])  # (nz, H+1, 2nb): each unknown's unit orbit
        dR = harmonics_of(orbit_r(dq, dv, dqb).astype(complex))  # (nz, 2nb, H+1)
        cols = np.einsum("hij,zjh->zhi", B, dR)
        return np.array([pack(c) for c in cols]).T

    pool = _pool(threads) if threads > 1 else None  # the films of one revolution, side by side
    scale = max(np.abs(A[1]).max(), 1e-12)
    if start is None:
        z = pack(A)
    else:  # another harmonic count: the start's harmonics, those it lacks zero (a refinement of a coarser balance)
        qs = np.zeros((H + 1, 2 * nb), complex)
        m = min(H, start.harmonics) + 1
        qs[:m] = start.journal_harmonics[:m]
        z = pack(qs)
    exact = False  # the first steps move the orbit far: their films inexact (also from a nearby orbit's start)
    g, (R, dq, dv, max_eps, dfq) = G(z, exact)
    f = g - z
    change = float(np.abs(f).max() / scale)
    it = 0
    while True:  # Newton on F(z) = G(z) - z with the films' tangents, halving a step that fails
        if not exact and change < INEXACT_ABOVE:  # close enough: every film exact from here on, this point too
            exact = True
            g, (R, dq, dv, max_eps, dfq) = G(z)
            f = g - z
            change = float(np.abs(f).max() / scale)
        if change < tol:
            break
        it += 1
        if it > max_iter:
            why = (f"it came within {INEXACT_ABOVE:.0e} of an orbit and no closer, where the films' tangents no longer "
                   "lead Newton's method (another harmonic count may settle)" if change < INEXACT_ABOVE else
                   "the orbit is too large for a periodic solution near the linear one")
            raise ConvergenceError(f"harmonic balance with {H} harmonics did not settle in {max_iter} Newton steps "
                                   f"(last change {change:.1e} of the 1X orbit, tolerance {tol:.0e}): {why}")
        step = -np.linalg.solve(G_jacobian(dq, dv) - np.eye(z.size), f)
        reach = np.abs(unpack(step)).sum(axis=0).reshape(nb, 2).max(axis=1)  # bound on each journal's move
        cap = float(np.max(reach / (MAX_STEP * np.array([e.bearing.clearance for e in eqs]))))
        if cap > 1.0:  # far from the orbit the tangent misleads: no step moves a journal by more than this
            step = step / cap
        lam, taken = 1.0, None
        for tries in range(6):  # the full step, or a fraction that lowers |F| (the last one taken regardless);
            trial = z + lam * step  # a step that makes the journal touch or a film fail is halved too
            try:
                g_t, aux = G(trial, exact)
            except ConvergenceError as exc:
                failure = exc
            else:
                f_trial = g_t - trial
                taken = (trial, f_trial, g_t, aux)
                if np.linalg.norm(f_trial) < np.linalg.norm(f):
                    break
            lam *= 0.5
        if taken is None:
            raise failure
        z, f, g, (R, dq, dv, max_eps, dfq) = taken
        change = float(np.abs(f).max() / scale)
        progress(it, max_iter, f"harmonic balance: change {change:.1e}" + ("" if lam == 1.0 else " (step shortened)"))
    slopes = None
    if want_q:  # implicit differentiation at the last point (its films exact, their tangents and dF/dQ at hand)
        qb_at = unpack(z)
        q_t = np.real(qb_at.T @ E)
        v_t = np.real((qb_at * hw[:, None]).T @ E)
        M = G_jacobian(dq, dv) - np.eye(z.size)
        slopes = np.zeros((nb, H + 1, Lo.size), complex)
        for j, (de0, dK, dC) in enumerate(flow_slopes):
            sl = slice(2 * j, 2 * j + 2)
            dr = np.zeros((2 * nb, N))
            dF_pos = dq[j] - K0[j]  # the film's own position tangent along the orbit (N, 2, 2)
            dr[sl] = (dfq[j].T + np.einsum("nik,k->in", dF_pos, np.asarray(de0, float))
                      + np.asarray(dK, float) @ q_t[sl] + np.asarray(dC, float) @ v_t[sl])
            dR_q = harmonics_of(dr)
            dD = []
            dGq = np.zeros((H + 1, 2 * nb), complex)
            for h in range(H + 1):
                d = np.zeros((2 * nb, 2 * nb), complex)
                d[sl, sl] = np.asarray(dK, float) + 1j * h * omega * np.asarray(dC, float)
                dD.append(d)
                dGq[h] = -B[h] @ d @ (A[h] + B[h] @ R[:, h]) + B[h] @ dR_q[:, h]
            dz = -np.linalg.solve(M, pack(dGq))
            dR = dR_q + harmonics_of(orbit_r(dq, dv, unpack(dz)).astype(complex))
            for h in range(H + 1):  # the nonlinear part Bo_h R_h
                slopes[j, h] = -Bo[h] @ dD[h] @ B[h] @ R[:, h] + Bo[h] @ dR[:, h]
        # the unbalance's size enters through A alone (A scales with it): d/d ln(size) at fixed z is A
        dz = -np.linalg.solve(M, pack(A))
        dR = harmonics_of(orbit_r(dq, dv, unpack(dz)).astype(complex))
        scale_slopes = np.array([Bo[h] @ dR[:, h] for h in range(H + 1)])
    z = g  # the map's image at the last point: R belongs to it
    qb = unpack(z)
    out = np.array([Ao[h] + Bo[h] @ R[:, h] for h in range(H + 1)])  # (H+1, 2 n_nodes)
    dofs = np.array([full_a[h] + full_b[h] @ R[:, h] for h in range(H + 1)])
    return OrbitBalance(omega=omega, nodes=tuple(int(v) for v in nodes), x=out[:, 0::2], y=out[:, 1::2],
                        bearing_x=qb[:, 0::2], bearing_y=qb[:, 1::2], linear_x=np.asarray(Ao[1][0::2]),
                        linear_y=np.asarray(Ao[1][1::2]), iterations=it, film_solves=solves, residual=change,
                        max_eccentricity=max_eps, seconds=time.perf_counter() - t0, dofs=dofs,
                        films=tuple(tuple(f) for f in films), bearings=bearings,
                        flow_slope_x=None if slopes is None else slopes[..., 0::2],
                        flow_slope_y=None if slopes is None else slopes[..., 1::2],
                        scale_slope_x=None if slopes is None else scale_slopes[:, 0::2],
                        scale_slope_y=None if slopes is None else scale_slopes[:, 1::2])
