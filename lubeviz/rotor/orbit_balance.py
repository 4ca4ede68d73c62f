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
HARMONICS, POINTS = 5, 24  # the journals' 1X correction close to that with 6 and 36, unlike with 3 and 16
# (docs/notes/large-orbits.md, session 8); the time integration's is farther (ModelBudget.orbit_truncation)
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


@dataclass(frozen=True, eq=False)
class _HarmonicBasis:
    """The linear rotor at each harmonic h Omega (h = 0 .. H), seen from the journals and the output nodes, and the
    N phase points of one revolution the films are sampled at."""

    omega: float
    B: np.ndarray  # (H+1, 2nb, 2nb): receptance at the journals (response there to unit forces there)
    A: np.ndarray  # (H+1, 2nb): the linear orbit at the journals (the unbalance's response, h = 1 only)
    Bo: tuple  # (H+1) x (2 n_nodes, 2nb): response at the nodes to unit forces at the journals
    Ao: tuple  # (H+1) x (2 n_nodes,): the linear orbit at the nodes
    full_b: tuple  # (H+1) x (n_dof, 2nb): every degree of freedom's response to unit forces at the journals
    full_a: tuple  # (H+1) x (n_dof,): every degree of freedom's linear orbit
    E: np.ndarray  # (H+1, N): e^{i h Omega t_n}
    hw: np.ndarray  # (H+1,): i h Omega, the time derivative of each harmonic

    @property
    def harmonics(self) -> int:
        return self.E.shape[0] - 1

    @property
    def points(self) -> int:
        return self.E.shape[1]

    @property
    def n_journals(self) -> int:
        return self.A.shape[1] // 2

    def samples(self, qb):
        """Journal displacement and velocity (2nb, N) over the revolution from their harmonics qb (H+1, 2nb)."""
        return np.real(qb.T @ self.E), np.real((qb * self.hw[:, None]).T @ self.E)

    def harmonics_of(self, r):
        """The one-sided harmonics (..., 2nb, H+1) of samples r (..., 2nb, N): 0X real, the others doubled."""
        R = (r @ self.E.conj().T) / self.points
        R[..., 1:] *= 2.0
        R[..., 0] = R[..., 0].real
        return R

    def pack(self, qb):
        """The real unknowns of harmonics qb (H+1, 2nb): every real part, the imaginary parts of h >= 1 (0X is real)."""
        return np.concatenate([qb.real.ravel(), qb[1:].imag.ravel()])

    def unpack(self, z):
        m = (self.harmonics + 1) * 2 * self.n_journals
        re = z[:m].reshape(self.harmonics + 1, 2 * self.n_journals)
        im = np.zeros_like(re)
        im[1:] = z[m:].reshape(self.harmonics, 2 * self.n_journals)
        return re + 1j * im

    def residual_change(self, dq, dv, dqb):
        """The residual force's change r (..., 2nb, N) for orbit changes dqb (..., H+1, 2nb), with the films'
        tangents along the orbit (dq, dv)."""
        nb, N = self.n_journals, self.points
        lead = dqb.shape[:-2]
        q_t = np.real(np.einsum("...hm,hn->...mn", dqb, self.E)).reshape(lead + (nb, 2, N))
        v_t = np.real(np.einsum("...hm,hn->...mn", dqb * self.hw[:, None], self.E)).reshape(lead + (nb, 2, N))
        dr = np.einsum("bnij,...bjn->...bin", dq, q_t) + np.einsum("bnij,...bjn->...bin", dv, v_t)
        return dr.reshape(lead + (2 * nb, N))

    def map_jacobian(self, dq, dv):
        """dG/dz (n_z, n_z): G is linear in R, R in r, and r's tangent is the films' (dq, dv)."""
        nz = (2 * self.harmonics + 1) * 2 * self.n_journals
        dqb = np.array([self.unpack(u) for u in np.eye(nz)])  # (nz, H+1, 2nb): each unknown's unit orbit
        dR = self.harmonics_of(self.residual_change(dq, dv, dqb).astype(complex))  # (nz, 2nb, H+1)
        cols = np.einsum("hij,zjh->zhi", self.B, dR)
        return np.array([self.pack(c) for c in cols]).T


def _harmonic_basis(rotor: Rotor, bearings: FilmBearings, unbalances, nodes, H: int, N: int) -> _HarmonicBasis:
    """D(h Omega) with the equilibria's K0, C0 solved at each harmonic for unit forces at the journals and, at 1X,
    for the unbalance force."""
    omega = bearings.omega
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
        u = np.linalg.solve(D, F1) if h == 1 else np.zeros(n, complex)
        A.append(u[Lb])
        Ao.append(u[Lo])
        full_a.append(u)
    phase = 2 * math.pi * np.arange(N) / N  # Omega t_n over one revolution
    return _HarmonicBasis(omega=omega, B=np.array(B), A=np.array(A), Bo=tuple(Bo), Ao=tuple(Ao),
                          full_b=tuple(full_b), full_a=tuple(full_a), E=np.exp(1j * np.outer(np.arange(H + 1), phase)),
                          hw=1j * omega * np.arange(H + 1))


def _warm_starts(bearings: FilmBearings, start: OrbitBalance | None, N: int) -> list[list]:
    """The film each phase point of each bearing starts from: the equilibrium's, or the start orbit's nearest phase
    point's (mapped onto this mesh when the start ran on another)."""
    eqs = bearings.equilibria
    if start is None:
        return [[e.film] * N for e in eqs]
    if start.films is None or abs(start.omega - bearings.omega) > 1e-9 * bearings.omega:
        raise InputError("orbit_balance: the start orbit has another speed or carries no films")
    n_s = len(start.films[0])  # another point count: each point warm-starts from the start's nearest phase
    near = [int(round(k * n_s / N)) % n_s for k in range(N)]
    if all(f[0].P.shape == e.film.P.shape for f, e in zip(start.films, eqs)):
        return [[f[i] for i in near] for f in start.films]
    # an orbit on another film mesh: its harmonics are the start, its films' patterns the films' starts
    return [[_mapped_film(sf[i], e.film) for i in near] for sf, e in zip(start.films, eqs)]


def _start_harmonics(basis: _HarmonicBasis, start: OrbitBalance | None) -> np.ndarray:
    """Newton's first point: the linear orbit, or the start's harmonics (another harmonic count: those it lacks
    zero, a refinement of a coarser balance; those beyond H cut)."""
    if start is None:
        return basis.pack(basis.A)
    qs = np.zeros((basis.harmonics + 1, 2 * basis.n_journals), complex)
    m = min(basis.harmonics, start.harmonics) + 1
    qs[:m] = start.journal_harmonics[:m]
    return basis.pack(qs)


@dataclass
class _OrbitFilms:
    """The film of each bearing at each phase point of the revolution: each point's warm start is its own last solve
    (so the solves are thread-safe), and the count of solves."""

    bearings: FilmBearings
    films: list[list]  # [bearing][phase point]
    want_supply: bool  # also each film's force derivative in its supply flow (for `flow_slopes`)
    pool: ThreadPoolExecutor | None  # the films of one revolution, side by side
    solves: int = 0
    f0: list = field(init=False)  # each equilibrium's film force, K0, C0: the linearization r is measured from
    K0: list = field(init=False)
    C0: list = field(init=False)

    def __post_init__(self):
        eqs = self.bearings.equilibria
        self.f0 = [e.film.force.copy() for e in eqs]
        self.K0 = [e.coefficients.K for e in eqs]
        self.C0 = [e.coefficients.C for e in eqs]

    def solve_one(self, j, k, pos, v, exact=True):
        """The film of bearing j at phase point k (journal at `pos`, velocity `v`), solved, with its force and its
        tangent (and supply derivative). Not `exact`: at most INEXACT_STEPS active-set steps, the last pattern's
        force and tangent taken as they are."""
        e = self.bearings.equilibria[j]
        problem = setup_problem(e.bearing, self.bearings.omega, pos, Feed.flow(self.bearings.flows[j]), velocity=v)
        warm = self.films[j][k]
        if not exact and warm.P.shape == problem.mesh.shape:
            sol = solve_active_set(problem, warm.full, max_iter=INEXACT_STEPS, partial=True)
            self.films[j][k] = dataclasses.replace(sol, linear=None)
            return sol.force, force_jacobian(sol), None
        sol = solve(problem, warm=warm)
        if not sol.converged:  # the active set can cycle under strong squeeze: projected SOR does not
            sol = solve(problem, method="sor", warm=warm, relax=1.9, tol=1e-10)
        if not sol.converged:
            raise ConvergenceError(f"film {j + 1} at phase {360 * k / len(self.films[j]):.0f} deg: {sol.message}")
        dF = force_jacobian(sol) if sol.linear is not None else None  # the film's tangent with its pattern held
        dQ = supply_derivative(sol) if (self.want_supply and sol.linear is not None) else None
        # (SOR carries none: there the step uses the static tangent, a quasi-Newton step). The warm start needs
        # the fields only: the factorization (~10 MB at 100 x 100) is not kept, 48 of them per balance were
        self.films[j][k] = dataclasses.replace(sol, linear=None)
        return sol.force, dF, dQ

    def jobs(self, q_t, v_t, exact):
        """One film solve per bearing and phase point, the journal's position and velocity there, and the largest
        eccentricity ratio on the orbit; an orbit that nearly touches the bearing is refused before any solve."""
        jobs, max_eps = [], 0.0
        for j, e in enumerate(self.bearings.equilibria):
            for k in range(q_t.shape[1]):
                pos = e.position + q_t[2 * j:2 * j + 2, k]
                eps = math.hypot(*pos) / e.bearing.clearance
                max_eps = max(max_eps, eps)
                if eps >= CONTACT:
                    raise ConvergenceError(f"bearing {j + 1}: the orbit reaches {eps:.2f} of the clearance; no "
                                           "periodic orbit near the linear one (the journal nearly touches)")
                jobs.append((j, k, pos, v_t[2 * j:2 * j + 2, k], exact))
        return jobs, max_eps

    def residual(self, basis: _HarmonicBasis, qb, exact=True):
        """R (2nb, H+1) of the orbit qb, each film's tangent along it: dr/dq, dr/dv (nb, N, 2, 2), the largest
        eccentricity ratio and each film's supply derivative (nb, N, 2)."""
        q_t, v_t = basis.samples(qb)  # (2nb, N)
        nb, N = basis.n_journals, basis.points
        r = np.empty((2 * nb, N))
        dq = np.zeros((nb, N, 2, 2))
        dv = np.zeros((nb, N, 2, 2))
        dfq = np.zeros((nb, N, 2))
        jobs, max_eps = self.jobs(q_t, v_t, exact)
        results = list(self.pool.map(lambda job: self.solve_one(*job), jobs)) if self.pool is not None else \
            [self.solve_one(*job) for job in jobs]
        self.solves += len(jobs)
        f0, K0, C0 = self.f0, self.K0, self.C0
        for (j, k, *_), (force, dF, dQ) in zip(jobs, results):
            q, v = q_t[2 * j:2 * j + 2, k], v_t[2 * j:2 * j + 2, k]
            # r = f_film(e0 + q_b, q_b') - f_film(e0) + K0 q_b + C0 q_b': zero to first order
            r[2 * j:2 * j + 2, k] = force - f0[j] + K0[j] @ q + C0[j] @ v
            if dF is not None:
                dq[j, k], dv[j, k] = dF[:, :2] + K0[j], dF[:, 2:] + C0[j]
            if dQ is not None:
                dfq[j, k] = dQ
        return basis.harmonics_of(r), dq, dv, max_eps, dfq


@dataclass(frozen=True, eq=False)
class _MapPoint:
    """The balance's map G at the journals' harmonics z (packed): its image g = pack(A + B R(z)), F = g - z, and
    what the films along the orbit gave on the way."""

    z: np.ndarray
    g: np.ndarray
    f: np.ndarray
    R: np.ndarray  # (2nb, H+1) the residual force's harmonics
    dq: np.ndarray  # (nb, N, 2, 2) dr/dq along the orbit
    dv: np.ndarray  # (nb, N, 2, 2) dr/dq'
    max_eps: float
    dfq: np.ndarray  # (nb, N, 2) each film's force derivative in its supply (zero unless asked for)


def _balance_map(basis: _HarmonicBasis, films: _OrbitFilms, z, exact=True) -> _MapPoint:
    """Q_b = A + B R(Q_b) at each harmonic, evaluated at z."""
    R, dq, dv, max_eps, dfq = films.residual(basis, basis.unpack(z), exact)
    g = basis.pack(basis.A + np.einsum("hij,jh->hi", basis.B, R))
    return _MapPoint(z=z, g=g, f=g - z, R=R, dq=dq, dv=dv, max_eps=max_eps, dfq=dfq)


def _newton_step(basis: _HarmonicBasis, films: _OrbitFilms, point: _MapPoint, exact: bool) -> tuple[_MapPoint, float]:
    """One Newton step on F(z) = G(z) - z with the films' tangents, capped and halved until |F| falls; the new
    point and the step's fraction taken (below 1: shortened)."""
    step = -np.linalg.solve(basis.map_jacobian(point.dq, point.dv) - np.eye(point.z.size), point.f)
    reach = np.abs(basis.unpack(step)).sum(axis=0).reshape(basis.n_journals, 2).max(axis=1)  # bound on each move
    cap = float(np.max(reach / (MAX_STEP * np.array([e.bearing.clearance for e in films.bearings.equilibria]))))
    if cap > 1.0:  # far from the orbit the tangent misleads: no step moves a journal by more than this
        step = step / cap
    lam, taken = 1.0, None
    for _ in range(6):  # the full step, or a fraction that lowers |F| (the last one taken regardless);
        trial = point.z + lam * step  # a step that makes the journal touch or a film fail is halved too
        try:
            candidate = _balance_map(basis, films, trial, exact)
        except ConvergenceError as exc:
            failure = exc
        else:
            taken = candidate
            if np.linalg.norm(candidate.f) < np.linalg.norm(point.f):
                break
        lam *= 0.5
    if taken is None:
        raise failure
    return taken, lam


class HarmonicsNotSettled(ConvergenceError):
    """The balance came near an orbit and no closer: the films' tangents stopped leading Newton's method at this
    harmonic count (on the fan's 100 x 60 films, 16 harmonics stall at 1e-2 where 8 settle), not an orbit too
    large for a periodic solution."""


def _not_settled(H: int, max_iter: int, change: float, tol: float) -> ConvergenceError:
    near = change < INEXACT_ABOVE
    why = (f"it came within {INEXACT_ABOVE:.0e} of an orbit and no closer, where the films' tangents no longer "
           "lead Newton's method (another harmonic count may settle)" if near else
           "the orbit is too large for a periodic solution near the linear one")
    return (HarmonicsNotSettled if near else ConvergenceError)(
        f"harmonic balance with {H} harmonics did not settle in {max_iter} Newton steps (last change {change:.1e} "
        f"of the 1X orbit, tolerance {tol:.0e}): {why}")


def _settled_orbit(basis: _HarmonicBasis, films: _OrbitFilms, z, tol: float, max_iter: int,
                   progress: ProgressFn) -> tuple[_MapPoint, int, float]:
    """Newton from z until F changes the orbit by less than `tol` of its 1X: the last point, the steps taken and
    that last change."""
    scale = max(np.abs(basis.A[1]).max(), 1e-12)
    exact = False  # the first steps move the orbit far: their films inexact (also from a nearby orbit's start)
    point = _balance_map(basis, films, z, exact)
    change = float(np.abs(point.f).max() / scale)
    it = 0
    while True:
        if not exact and change < INEXACT_ABOVE:  # close enough: every film exact from here on, this point too
            exact = True
            point = _balance_map(basis, films, point.z)
            change = float(np.abs(point.f).max() / scale)
        if change < tol:
            return point, it, change
        it += 1
        if it > max_iter:
            raise _not_settled(basis.harmonics, max_iter, change, tol)
        point, lam = _newton_step(basis, films, point, exact)
        change = float(np.abs(point.f).max() / scale)
        progress(it, max_iter, f"harmonic balance: change {change:.1e}" + ("" if lam == 1.0 else " (step shortened)"))


def _flow_slope(basis: _HarmonicBasis, point: _MapPoint, M, q_t, v_t, K0, j: int, de0, dK, dC) -> np.ndarray:
    """d/dQ_j of the nonlinear part at the nodes (H+1, 2 n_nodes): the residual's change at fixed orbit (the film's
    supply derivative, its equilibrium's move, dK0, dC0), carried to the orbit by the Newton matrix M, plus the
    receptance's own change through dK0, dC0."""
    H, nb, N = basis.harmonics, basis.n_journals, basis.points
    B, Bo, A, R = basis.B, basis.Bo, basis.A, point.R
    sl = slice(2 * j, 2 * j + 2)
    dr = np.zeros((2 * nb, N))
    dF_pos = point.dq[j] - K0  # the film's own position tangent along the orbit (N, 2, 2)
    dr[sl] = (point.dfq[j].T + np.einsum("nik,k->in", dF_pos, np.asarray(de0, float))
              + np.asarray(dK, float) @ q_t[sl] + np.asarray(dC, float) @ v_t[sl])
    dR_q = basis.harmonics_of(dr)
    dD = []
    dGq = np.zeros((H + 1, 2 * nb), complex)
    for h in range(H + 1):
        d = np.zeros((2 * nb, 2 * nb), complex)
        d[sl, sl] = np.asarray(dK, float) + 1j * h * basis.omega * np.asarray(dC, float)
        dD.append(d)
        dGq[h] = -B[h] @ d @ (A[h] + B[h] @ R[:, h]) + B[h] @ dR_q[:, h]
    dz = -np.linalg.solve(M, basis.pack(dGq))
    dR = dR_q + basis.harmonics_of(basis.residual_change(point.dq, point.dv, basis.unpack(dz)).astype(complex))
    out = np.zeros((H + 1, Bo[0].shape[0]), complex)
    for h in range(H + 1):  # the nonlinear part Bo_h R_h
        out[h] = -Bo[h] @ dD[h] @ B[h] @ R[:, h] + Bo[h] @ dR[:, h]
    return out


def _slopes(basis: _HarmonicBasis, films: _OrbitFilms, point: _MapPoint, flow_slopes) -> tuple[np.ndarray, np.ndarray]:
    """Implicit differentiation at the last point (its films exact, their tangents and dF/dQ at hand): the nonlinear
    part's derivative in each bearing's supply flow (nb, H+1, 2 n_nodes) and in ln(unbalance size) (H+1, 2 n_nodes)."""
    q_t, v_t = basis.samples(basis.unpack(point.z))
    M = basis.map_jacobian(point.dq, point.dv) - np.eye(point.z.size)
    flow = np.zeros((basis.n_journals, basis.harmonics + 1, basis.Bo[0].shape[0]), complex)
    for j, (de0, dK, dC) in enumerate(flow_slopes):
        flow[j] = _flow_slope(basis, point, M, q_t, v_t, films.K0[j], j, de0, dK, dC)
    # the unbalance's size enters through A alone (A scales with it): d/d ln(size) at fixed z is A
    dz = -np.linalg.solve(M, basis.pack(basis.A))
    dR = basis.harmonics_of(basis.residual_change(point.dq, point.dv, basis.unpack(dz)).astype(complex))
    size = np.array([basis.Bo[h] @ dR[:, h] for h in range(basis.harmonics + 1)])
    return flow, size


def orbit_balance(rotor: Rotor, bearings: FilmBearings, unbalances: Sequence[Unbalance], *,
                  nodes: Sequence[int] | None = None, harmonics: int = HARMONICS, points: int = POINTS, tol: float = 1e-5,
                  max_iter: int = 30, start: OrbitBalance | None = None, threads: int | None = None,
                  flow_slopes: Sequence | None = None, progress: ProgressFn = silent) -> OrbitBalance:
    """The periodic orbit of `rotor` on the films of `bearings` under `unbalances` (harmonic balance).

    `harmonics` H (>= 1) and `points` N per revolution (>= 2H + 2, so no harmonic aliases onto another).
    Raises ConvergenceError when the iteration does not settle (an orbit too large for a periodic
    solution near the linear one) or the journal approaches the bearing wall.
    `start`: the orbit at a nearby operating point (same speed; its harmonics padded or cut to H, each point
    warm-started from its nearest phase point: so a coarser balance starts a finer one), from which Newton
    starts (its films warm-start the film solves when they have this mesh): a continuation along the branch
    that grows from the linear orbit. Without it Newton starts at the linear orbit. (Far from it, e.g. from the
    orbit at flows 10-20 % away, a fixed-point iteration was seen to land on another periodic solution with
    nearly the same 1X and another 0X and 3X: the branch that grows from the linear orbit is the one computed
    here.)
    `flow_slopes`: per bearing, the derivatives of its equilibrium in its own supply flow, (d position (2,),
    d K0 (2, 2), d C0 (2, 2)) per m^3/s; with them the balance also returns the derivative of its nonlinear part
    in each flow (`flow_slope_x`, `_y`) by implicit differentiation of the converged balance: each exact film
    also gives its force's derivative in the supply at fixed motion (`film.linearize.supply_derivative`, one
    back-substitution), and the balance's own Newton matrix carries it to the orbit. No further balance.
    """
    rotor.require_films_on_ground("the orbit's harmonic balance on the p-theta films")
    t0 = time.perf_counter()
    threads = FILM_THREADS if threads is None else max(1, int(threads))
    H, N = int(harmonics), int(points)
    if H < 1 or N < 2 * H + 2:
        raise InputError(f"{H} harmonics need at least {2 * H + 2} points per revolution, got {N}")
    nodes = tuple(rotor.bearing_nodes) if nodes is None else tuple(nodes)  # default: at the bearings
    basis = _harmonic_basis(rotor, bearings, unbalances, nodes, H, N)
    films = _OrbitFilms(bearings, _warm_starts(bearings, start, N), want_supply=flow_slopes is not None,
                        pool=_pool(threads) if threads > 1 else None)
    point, it, change = _settled_orbit(basis, films, _start_harmonics(basis, start), tol, max_iter, progress)
    flow, size = (None, None) if flow_slopes is None else _slopes(basis, films, point, flow_slopes)
    qb = basis.unpack(point.g)  # the map's image at the last point: R belongs to it
    R = point.R
    out = np.array([basis.Ao[h] + basis.Bo[h] @ R[:, h] for h in range(H + 1)])  # (H+1, 2 n_nodes)
    dofs = np.array([basis.full_a[h] + basis.full_b[h] @ R[:, h] for h in range(H + 1)])
    return OrbitBalance(omega=bearings.omega, nodes=tuple(int(v) for v in nodes), x=out[:, 0::2], y=out[:, 1::2],
                        bearing_x=qb[:, 0::2], bearing_y=qb[:, 1::2], linear_x=np.asarray(basis.Ao[1][0::2]),
                        linear_y=np.asarray(basis.Ao[1][1::2]), iterations=it, film_solves=films.solves,
                        residual=change, max_eccentricity=point.max_eps, seconds=time.perf_counter() - t0, dofs=dofs,
                        films=tuple(tuple(f) for f in films.films), bearings=bearings,
                        flow_slope_x=None if flow is None else flow[..., 0::2],
                        flow_slope_y=None if flow is None else flow[..., 1::2],
                        scale_slope_x=None if size is None else size[:, 0::2],
                        scale_slope_y=None if size is None else size[:, 1::2])
