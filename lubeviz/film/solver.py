"""Steady p-theta solvers: the paper's projected Gauss-Seidel/SOR and a semismooth-Newton active set.

Both converge to the same discrete solution of `operator.residual` = 0 with Eq. 6. The active-set
solver (the default) treats the cavitation pattern -- which cells are full film and which are
cavitated -- as the unknown of an outer loop: for a fixed pattern the balances are *linear* (p
unknown where full, theta unknown where cavitated), solved exactly by one sparse LU; cells that
violate Eq. 6 (full with p < 0, cavitated with theta > 1) switch, and the loop repeats until no cell
switches. That is Newton's method on the piecewise-linear complementarity system, so it ends in a
handful of solves and leaves the mass balance satisfied to round-off; its last factorization is
reused for the dynamic coefficients (the linearization with the pattern held fixed).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ConvergenceError
from . import kernels
from .operator import FilmProblem, edge_leakage, film_force, residual, side_leakage


@dataclass(frozen=True)
class FilmSolution:
    """One converged (or not) steady film.

    Fields are on the solved domain (half the bearing length when the mesh is `half`); use
    `pressure_field()` / `theta_field()` for the whole film. Forces in N, flows in m^3/s.
    """

    problem: FilmProblem = field(repr=False)
    P: np.ndarray = field(repr=False)  # nondimensional pressure, p = P * problem.p_ref
    theta: np.ndarray = field(repr=False)  # oil fraction
    force: np.ndarray  # [Fx, Fy] on the journal
    side_leakage: float
    supply: float  # oil entering: Qs when prescribed, the groove's/feed line's net outflow when held
    mass_residual: float  # |supply - side_leakage| / supply
    iterations: int
    converged: bool
    message: str
    method: str
    seconds: float
    linear: "PatternSystem | None" = field(default=None, repr=False, compare=False)

    @property
    def full(self) -> np.ndarray:
        """Cells with a full film (p > 0 or theta = 1, not cavitated)."""
        return (self.P > 0.0) | (self.theta >= 1.0)

    @property
    def edge_leakage(self) -> tuple[float, float]:
        """Side leakage through the z = 0 and z = L edges (m^3/s); they sum to `side_leakage`."""
        return edge_leakage(self.problem, self.P)

    def pressure_field(self) -> np.ndarray:
        """Pressure (Pa) on the whole film, shape (n_axial, n_circ), rows from z = 0 to z = L."""
        return _whole(self.problem, self.P) * self.problem.p_ref

    def theta_field(self) -> np.ndarray:
        """Oil fraction on the whole film, shape (n_axial, n_circ)."""
        return _whole(self.problem, self.theta)

    def raise_if_failed(self) -> "FilmSolution":
        if not self.converged:
            raise ConvergenceError(self.message)
        return self


def _whole(problem: FilmProblem, a: np.ndarray) -> np.ndarray:
    return np.vstack([a, a[::-1]]) if problem.mesh.half else a


# Reusing a factorization (`PatternSystem(base=...)`). A pattern system's matrix differs from one already
# factorized (the root) only in the columns of the cells whose unknown switched (P <-> theta) when both are
# at the same journal position and velocity (the active-set steps of one solve), and by a small perturbation
# elsewhere when the position moved a little (an equilibrium's Newton step). The new system is then solved with
# the root's LU: the k switched columns by the Sherman-Morrison-Woodbury formula (one back-substitution of k
# columns and a k x k solve), the rest by iterative refinement against the new matrix, until the residual is
# at the level a direct LU leaves (REFINE_RESIDUAL, relative to |A| |x| + |b| in the max norm). A system that
# does not get there within REFINE_STEPS refinements, or whose first refinement contracts the residual by
# less than REFINE_RATE, is factorized afresh (and becomes the root of later ones), so the answer is always
# the new matrix's to round-off; only the work changes. A back-substitution costs a small fraction of a
# factorization and a k-column one grows with k: up to MAX_SWITCHED columns it stays well below a factorization.
# Measured on dimensionless slices (factorizations and time per slice, values equal to 1e-12 of each column's
# max): docs/notes/dimensionless-tables.md (session 16). The harmonic balance (rotor.orbit_balance) reuses within
# a film solve only: reusing across its Newton steps saved time on one thread and none on its two (a
# back-substitution holds the interpreter's lock, a factorization mostly does not; the same notes).
MAX_SWITCHED = 12
REFINE_STEPS = 4
REFINE_RATE = 0.05
REFINE_RESIDUAL = 2e-17


class _Root:
    """A factorized pattern matrix that later systems may reuse: its LU, pattern (free cells) and columns."""

    def __init__(self, matrix: sp.csc_matrix, full_free: np.ndarray, columns: "Columns"):
        self.full_free = full_free
        self.columns = columns
        self.lu = spla.splu(matrix, permc_spec="MMD_AT_PLUS_A")


class PatternSystem:
    """The linear system of the balances for one fixed cavitation pattern, ready to solve.

    Unknown of a free cell: P if it is full, theta if it is cavitated. Held (fixed) cells are
    known (P = 0, theta = 1) and not unknowns. `base` (a system on the same mesh and free cells, e.g. the
    last one of a neighbouring film) offers its factorization for reuse (see the comment above the class).
    """

    def __init__(self, problem: FilmProblem, full: np.ndarray, columns: "Columns",
                 base: "PatternSystem | None" = None):
        self.problem = problem
        self.full = full.copy()
        t = columns
        fullf = full.ravel()
        self.full_free = fullf[t.free_idx]
        indptr, indices, data, row_abs = kernels.pattern_csc(self.full_free, t.p_rows, t.p_vals, t.t_rows, t.t_vals)
        n = t.n_free
        self.matrix = sp.csc_matrix((data, indices, indptr), shape=(n, n))
        # theta = 1 of full and held cells is known: move it to the right-hand side (C1 of a full cell's own
        # balance, -C2 of the balance east of a full or held cell)
        c = problem.coef
        known = fullf | t.fixed_flat
        self.rhs = (c.S.ravel() - c.C1.ravel() * fullf + c.C2.ravel() * known[t.west])[t.free_idx]
        self.columns = t
        self._update = None  # (J, W, inverse capacitance) of the switched columns
        self.reused = False
        root = None if base is None else base._root
        if (root is not None and root.columns.free_idx.size == t.free_idx.size
                and (root.columns.free_idx is t.free_idx or np.array_equal(root.columns.free_idx, t.free_idx))):
            J = np.flatnonzero(self.full_free != root.full_free)
            if J.size <= MAX_SWITCHED:
                self._root = root
                self.reused = True
                if J.size:
                    U = t.dense_columns(J, self.full_free[J]) - root.columns.dense_columns(J, root.full_free[J])
                    W = root.lu.solve(U)
                    cap = np.eye(J.size) + W[J]
                    self._update = (J, W, np.linalg.inv(cap))
                self._anorm = float(row_abs.max())
                return
        self._factorize()

    @property
    def lu(self):
        return self._root.lu

    def _factorize(self) -> None:
        self._root = _Root(self.matrix, self.full_free, self.columns)
        self._update = None
        self.reused = False

    def _apply(self, b: np.ndarray) -> np.ndarray:
        """The root's LU with the switched columns' Woodbury correction: the exact inverse of the matrix
        that equals this one in the switched columns and the root's elsewhere."""
        y = self._root.lu.solve(b)
        if self._update is not None:
            J, W, cap_inv = self._update
            y = y - W @ (cap_inv @ y[J])
        return y

    def _solve(self, b: np.ndarray) -> np.ndarray:
        if not self.reused:
            return self._root.lu.solve(b)
        x = self._apply(b)
        bnorm = np.abs(b).max(axis=0)
        last = None
        for step in range(REFINE_STEPS + 1):
            r = b - self.matrix @ x
            rn = np.abs(r).max(axis=0)
            if np.all(rn <= REFINE_RESIDUAL * (self._anorm * np.abs(x).max(axis=0) + bnorm)):
                return x
            worst = float(np.max(rn / np.maximum(bnorm, 1e-300)))
            if step == REFINE_STEPS or (last is not None and worst > REFINE_RATE * last):
                break
            last = worst
            x = x + self._apply(r)
        self._factorize()  # too far from the root: factorize this matrix
        return self._root.lu.solve(b)

    def solve(self, rhs=None) -> np.ndarray:
        return self._solve(self.rhs if rhs is None else rhs)

    def fields(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(P, theta) on the mesh from the vector of unknowns."""
        t = self.columns
        shape = self.problem.mesh.shape
        P = np.zeros(shape).ravel()
        theta = np.ones(shape).ravel()
        fullf = self.full_free
        P[t.free_idx[fullf]] = x[fullf]
        theta[t.free_idx[~fullf]] = x[~fullf]
        return P.reshape(shape), theta.reshape(shape)

    def tangent(self, dR: np.ndarray) -> np.ndarray:
        """dP for a change dR of the balances at fixed fields (pattern held): J dx = -dR.

        `dR` has shape (k, nz, n_circ) for k parameters; returns dP of the same shape.
        """
        t = self.columns
        k = dR.shape[0]
        b = -dR.reshape(k, -1)[:, t.free_idx].T
        dx = self._solve(np.ascontiguousarray(b))
        fullf = self.full_free
        dP = np.zeros((k, dR[0].size))
        dP[:, t.free_idx[fullf]] = dx[fullf].T
        return dP.reshape(dR.shape)


@dataclass(frozen=True)
class _Structure:
    """Where each free cell's two candidate columns have their entries, for one mesh shape and set of held cells:
    rows in free-cell numbering (sorted, -1 = none) and the index of each entry's coefficient in the stacked
    arrays (aP, -aE, -aW, -aN, -aS) for the pressure column and (C1, -C2) for the oil-fraction column."""

    free_idx: np.ndarray
    fixed_flat: np.ndarray
    west: np.ndarray  # each cell's upstream neighbour (flat index)
    p_rows: np.ndarray  # (n_free, 5)
    p_src: np.ndarray
    t_rows: np.ndarray  # (n_free, 2)
    t_src: np.ndarray


_STRUCTURES: dict = {}


def _structure(shape: tuple[int, int], fixed: np.ndarray) -> _Structure:
    key = (shape, fixed.tobytes())
    s = _STRUCTURES.get(key)
    if s is not None:
        return s
    nz, nc = shape
    N = nz * nc
    k = np.arange(N).reshape(nz, nc)
    east, west = np.roll(k, -1, axis=1), np.roll(k, 1, axis=1)
    none = np.full((1, nc), -1)
    south = np.vstack([none, k[:-1]])  # the cell j - 1 (its balance holds -aN_{j-1} P_j)
    north = np.vstack([k[1:], none])  # the cell j + 1 (its balance holds -aS_{j+1} P_j)
    free = ~fixed.ravel()
    free_idx = np.flatnonzero(free)
    cmap = np.full(N + 1, -1)  # cmap[-1] = -1: "no neighbour" stays none
    cmap[free_idx] = np.arange(free_idx.size)

    def column(cells, planes):
        cells = np.stack([c.ravel()[free_idx] for c in cells], axis=1)
        rows = cmap[cells]  # a held or missing row is no entry
        src = np.where(cells >= 0, np.asarray(planes)[None, :] * N + cells, 0)
        order = np.argsort(np.where(rows < 0, N + 1, rows), axis=1, kind="stable")
        return (np.ascontiguousarray(np.take_along_axis(rows, order, 1)),
                np.ascontiguousarray(np.take_along_axis(src, order, 1)))

    p_rows, p_src = column([k, west, east, south, north], [0, 1, 2, 3, 4])
    t_rows, t_src = column([k, east], [0, 1])
    s = _Structure(free_idx, ~free, west.ravel(), p_rows, p_src, t_rows, t_src)
    for a in dataclasses.astuple(s):  # shared by every problem on this mesh
        a.flags.writeable = False
    if len(_STRUCTURES) > 32:
        _STRUCTURES.clear()
    _STRUCTURES[key] = s
    return s


class Columns:
    """The balance operator of one problem as two candidate columns per free cell (numbered among the free
    cells): a full cell's column holds the coefficients of its pressure, a cavitated cell's those of its oil
    fraction. A pattern's matrix takes one of each cell's two (`kernels.pattern_csc`)."""

    def __init__(self, problem: FilmProblem):
        s = _structure(problem.mesh.shape, problem.fixed)  # (a mesh has >= 8 columns: east and west differ)
        c = problem.coef
        vp = np.concatenate([c.aP.ravel(), -c.aE.ravel(), -c.aW.ravel(), -c.aN.ravel(), -c.aS.ravel()])
        vt = np.concatenate([c.C1.ravel(), -c.C2.ravel()])
        self.p_rows, self.t_rows = s.p_rows, s.t_rows
        self.p_vals, self.t_vals = vp[s.p_src], vt[s.t_src]
        self.free_idx, self.fixed_flat, self.west = s.free_idx, s.fixed_flat, s.west
        self.n_free = int(s.free_idx.size)

    def dense_columns(self, J: np.ndarray, full: np.ndarray) -> np.ndarray:
        """(n_free, len(J)): column J[i] of the pattern with cell J[i] full when full[i], dense."""
        out = np.zeros((self.n_free, J.size))
        for i, (j, f) in enumerate(zip(J, full)):
            rows, vals = (self.p_rows[j], self.p_vals[j]) if f else (self.t_rows[j], self.t_vals[j])
            ok = rows >= 0
            out[rows[ok], i] = vals[ok]
        return out

    def coo(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every entry of both candidate columns: (rows, cols, values, is_pressure) among the free cells."""
        n = self.n_free
        pr, tr = self.p_rows.ravel(), self.t_rows.ravel()
        pc = np.repeat(np.arange(n), self.p_rows.shape[1])
        tc = np.repeat(np.arange(n), self.t_rows.shape[1])
        kp, kt = pr >= 0, tr >= 0
        return (np.concatenate([pr[kp], tr[kt]]), np.concatenate([pc[kp], tc[kt]]),
                np.concatenate([self.p_vals.ravel()[kp], self.t_vals.ravel()[kt]]),
                np.concatenate([np.ones(kp.sum(), bool), np.zeros(kt.sum(), bool)]))


def initial_pattern(problem: FilmProblem) -> np.ndarray:
    """Cold-start guess: full film where the gap converges (where a flooded film builds pressure)."""
    converging = problem.H_e < np.roll(problem.H_e, 1, axis=1)
    return converging & ~problem.fixed


def _finish(problem, P, theta, iterations, converged, message, method, t0, linear=None):
    P = np.maximum(P, 0.0)
    theta = np.minimum(theta, 1.0)
    leak = side_leakage(problem, P)
    if problem.fixed.any():
        R_fixed = residual(problem.coef, P, theta)[problem.fixed]
        supply = float(R_fixed.sum() * problem.flux_ref * problem.mesh.mirror_factor)
    else:
        supply = float(problem.coef.S.sum() * problem.flux_ref * problem.mesh.mirror_factor)
    scale = max(abs(supply), abs(leak), 1e-300)
    return FilmSolution(
        problem=problem, P=P, theta=theta, force=film_force(problem, P), side_leakage=leak,
        supply=supply, mass_residual=abs(supply - leak) / scale, iterations=iterations,
        converged=converged, message=message, method=method,
        seconds=time.perf_counter() - t0, linear=linear,
    )


def solve_active_set(problem: FilmProblem, full0: np.ndarray | None = None, max_iter: int = 60, *,
                     partial: bool = False, base: PatternSystem | None = None) -> FilmSolution:
    """Semismooth-Newton (primal-dual active set) solve of the p-theta system; see module doc.

    `full0` warm-starts the pattern (e.g. from a neighbouring flow or position). A pattern seen
    before (a cycle) is broken by switching only the single most violating cell of each kind.
    `partial`: when the pattern still changes after `max_iter` solves, the result (converged False) keeps
    its last pattern's linear system, so an outer Newton iteration can use its tangent (an inexact solve).
    `base`: a pattern system whose factorization the first system may reuse (a neighbouring film's `linear`);
    each later system may reuse the one before's. Only the work depends on it (see PatternSystem).
    """
    t0 = time.perf_counter()
    trip = Columns(problem)
    full = (initial_pattern(problem) if full0 is None else full0.copy()) & ~problem.fixed
    seen = set()
    tol = 1e-12
    for it in range(1, max_iter + 1):
        system = PatternSystem(problem, full, trip, base=base)
        base = system
        P, theta = system.fields(system.solve())
        p_scale = max(float(P.max()), 1e-30)
        to_cav = full & (P < -tol * p_scale)
        to_full = ~full & ~problem.fixed & (theta > 1.0 + tol)
        if not to_cav.any() and not to_full.any():
            return _finish(problem, P, theta, it, True, "converged", "active-set", t0, system)
        key = hash(full.tobytes())
        if key in seen:  # cycling: move one cell of each kind, the worst first
            new_full = full.copy()
            if to_cav.any():
                worst = np.unravel_index(np.argmin(np.where(to_cav, P, np.inf)), P.shape)
                new_full[worst] = False
            if to_full.any():
                worst = np.unravel_index(np.argmax(np.where(to_full, theta, -np.inf)), P.shape)
                new_full[worst] = True
            full = new_full
        else:
            seen.add(key)
            full = (full & ~to_cav) | to_full
    return _finish(problem, P, theta, max_iter, False,
                   f"active-set solver: cavitation pattern still changing after {max_iter} linear solves",
                   "active-set", t0, system if partial else None)


def solve_sor(problem: FilmProblem, *, relax: float = 1.85, tol: float = 1e-10, max_sweeps: int = 50000,
              P0: np.ndarray | None = None, theta0: np.ndarray | None = None) -> FilmSolution:
    """The paper's projected Gauss-Seidel with over-relaxation `relax` (1 = plain Gauss-Seidel)."""
    t0 = time.perf_counter()
    c = problem.coef
    P = np.zeros(problem.mesh.shape) if P0 is None else np.array(P0, dtype=float)
    theta = np.ones(problem.mesh.shape) if theta0 is None else np.array(theta0, dtype=float)
    P[problem.fixed] = 0.0
    theta[problem.fixed] = 1.0
    sweeps, change = kernels.sor_sweeps(c.C1, c.C2, c.aE, c.aW, c.aN, c.aS, c.S, problem.fixed,
                                        P, theta, relax, max_sweeps, tol)
    ok = change < tol
    msg = "converged" if ok else f"SOR: change {change:.3g} still above {tol:g} after {sweeps} sweeps"
    return _finish(problem, P, theta, int(sweeps), bool(ok), msg, f"sor({relax:g})", t0)


def solve(problem: FilmProblem, *, method: str = "active-set", warm: FilmSolution | None = None,
          pattern: np.ndarray | None = None, **options) -> FilmSolution:
    """Solve with `method` ('active-set' or 'sor'), warm-started from a previous solution.

    `pattern` (active-set only): the full cells to start from, instead of `warm`'s; `warm`'s linear system
    is offered for reuse (`solve_active_set`'s `base`)."""
    if method == "active-set":
        full0 = None
        if pattern is not None and pattern.shape == problem.mesh.shape:
            full0 = pattern
        elif warm is not None and warm.P.shape == problem.mesh.shape:
            full0 = warm.full
        if warm is not None and warm.P.shape == problem.mesh.shape:
            options.setdefault("base", warm.linear)
        return solve_active_set(problem, full0, **options)
    if method == "sor":
        if warm is not None and warm.P.shape == problem.mesh.shape:
            options.setdefault("P0", warm.P)
            options.setdefault("theta0", warm.theta)
        return solve_sor(problem, **options)
    raise ValueError(f"unknown film solver {method!r}; expected 'active-set' or 'sor'")

