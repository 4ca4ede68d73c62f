"""Time integration of Eq. 8 for arbitrary forces (SPEC §4).

Two schemes, both for M q'' + (C + Omega G) q' + K q = f(t) with constant matrices:

* ``"exact"`` (default): the exact discretization of the linear part. In first-order form
  z' = A z + B f, A = [[0, I], [-M^-1 K, -M^-1 (C + Omega G)]], B = [0; M^-1], the state matrix is
  diagonalized once, A = V diag(lambda) V^-1, and each modal coordinate eta = V^-1 z obeys
  eta' = lambda eta + g(t), g = V^-1 B f. With f linear between samples (first-order hold) the step
      eta_{n+1} = e^{lambda h} eta_n + g_n (e^{lambda h} - 1)/lambda
                  + (g_{n+1} - g_n) (e^{lambda h} - 1 - lambda h)/(lambda^2 h)
  is exact; the only error is the hold on f (for a sine sampled 133 times per period, as the paper's
  75 Hz at 1e-4 s, about (Omega h)^2/24 = 1e-4 relative in amplitude). The recursion is a numba
  kernel over (modes x samples); 15 s at 1e-4 s take a fraction of a second.
* ``"newmark"``: Newmark's average-acceleration rule (trapezoidal, unconditionally stable, no
  numerical damping), the classic structural-dynamics scheme, kept as an independent cross-check.

Forces are given as samples at the listed DOFs only (an unbalance acts on two DOFs), so the cost
does not grow with the rotor size beyond the one-off eigen-decomposition.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numba
import numpy as np
import scipy.linalg

from ..errors import InputError
from .assembly import Rotor, bearing_matrices, probe_housings
from .elements import DOF_PER_NODE, X, Y, node_dofs
from .modal import state_matrix
from .response import Unbalance, unbalance_force


@numba.njit(cache=True, nogil=True)
def _modal_recursion(decay, w0, w1, g, eta0, keep_from, out):
    """eta_{n+1} = decay eta_n + w0 g_n + w1 (g_{n+1} - g_n); stores eta for n >= keep_from in `out`."""
    n_modes, n_steps = g.shape
    for m in range(n_modes):
        e = eta0[m]
        d, a, b = decay[m], w0[m], w1[m]
        if keep_from == 0:
            out[m, 0] = e
        for n in range(n_steps - 1):
            e = d * e + a * g[m, n] + b * (g[m, n + 1] - g[m, n])
            if n + 1 >= keep_from:
                out[m, n + 1 - keep_from] = e
    return out


@dataclass(frozen=True)
class LinearSystem:
    """Eq. 8 with fixed bearing coefficients at one speed, ready for time stepping.

    M, C (shaft + bearings + Omega G), K (shaft + bearings): (n, n); eigenvalues/V/V_inv: the
    diagonalized first-order form; `condition` the condition number of V (a check, not a tuning knob).
    """

    omega: float
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    eigenvalues: np.ndarray
    V: np.ndarray
    V_inv: np.ndarray
    condition: float

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def stable(self) -> bool:
        return bool(self.eigenvalues.real.max() < 0.0)


def linear_system(rotor: Rotor, omega: float, bearings) -> LinearSystem:
    """Assemble Eq. 8 at speed `omega` (rad/s) with bearings (one (K, C) per bearing) and diagonalize it."""
    if not (np.isfinite(omega) and omega >= 0.0):
        raise InputError(f"shaft speed {omega!r} rad/s; expected a non-negative number")
    K, C = bearing_matrices(rotor, bearings)
    if K.ndim != 2:
        raise InputError("time integration takes one 2x2 K and C per bearing (coefficients at one speed)")
    Ct = C + omega * rotor.G
    lam, V = scipy.linalg.eig(state_matrix(rotor.M, Ct, K))
    V_inv = np.linalg.inv(V)
    cond = float(np.linalg.norm(V, 2) * np.linalg.norm(V_inv, 2))
    return LinearSystem(omega=float(omega), M=rotor.M, C=Ct, K=K, eigenvalues=lam, V=V, V_inv=V_inv,
                        condition=cond)


@dataclass(frozen=True)
class TimeResponse:
    """Samples of selected DOFs: t (s), displacement (n_out, n_t) in m, velocity likewise (m/s)."""

    t: np.ndarray
    dofs: np.ndarray
    displacement: np.ndarray
    velocity: np.ndarray
    method: str
    seconds: float = 0.0

    def node_xy(self, node: int) -> tuple[np.ndarray, np.ndarray]:
        """x(t), y(t) of a node (paper numbering) if its translations were among the outputs."""
        i = node_dofs(node)
        try:
            rx = int(np.flatnonzero(self.dofs == i[X])[0])
            ry = int(np.flatnonzero(self.dofs == i[Y])[0])
        except IndexError:
            raise InputError(f"node {node} was not among the simulated outputs") from None
        return self.displacement[rx], self.displacement[ry]


def _check_time(dt: float, n_steps: int, keep_from: int) -> None:
    if not (np.isfinite(dt) and dt > 0.0):
        raise InputError(f"time step {dt!r} s; expected a positive number")
    if n_steps < 2:
        raise InputError(f"{n_steps} time samples; expected at least 2")
    if not 0 <= keep_from < n_steps:
        raise InputError(f"keep_from = {keep_from}; expected 0 <= keep_from < {n_steps}")


def _hold_weights(lam: np.ndarray, h: float):
    """Exact first-order-hold weights of eta' = lam eta + g for a step h (series for small |lam h|)."""
    x = lam * h
    decay = np.exp(x)
    small = np.abs(x) < 1e-4
    xs = np.where(small, 1.0, x)
    w0 = np.where(small, h * (1 + x / 2 + x**2 / 6), (decay - 1.0) / np.where(small, 1.0, lam))
    w1 = np.where(small, h * (0.5 + x / 6 + x**2 / 24), (decay - 1.0 - x) / (xs * np.where(small, 1.0, lam)))
    return decay, w0, w1


def simulate(system: LinearSystem, dt: float, force: np.ndarray, force_dofs: Sequence[int], *,
             output_dofs: Sequence[int], q0=None, v0=None, keep_from: int = 0,
             method: str = "exact") -> TimeResponse:
    """Integrate Eq. 8 from (q0, v0) under forces sampled every `dt` seconds.

    force: (len(force_dofs), n_samples) in N at the global DOFs `force_dofs` (0-based); the number of
    samples sets the duration. Returns the samples of `output_dofs` from sample `keep_from` on.
    """
    import time

    t_start = time.perf_counter()
    force = np.atleast_2d(np.asarray(force, dtype=float))
    force_dofs = np.asarray(force_dofs, dtype=int)
    output_dofs = np.asarray(output_dofs, dtype=int)
    n = system.n_dof
    if force.shape[0] != force_dofs.size:
        raise InputError(f"force has {force.shape[0]} rows for {force_dofs.size} force DOFs")
    if not np.all(np.isfinite(force)):
        raise InputError("force samples contain NaN or inf")
    for name, d in (("force", force_dofs), ("output", output_dofs)):
        if d.size and (d.min() < 0 or d.max() >= n):
            raise InputError(f"{name} DOF outside 0..{n - 1}: {d.tolist()}")
    n_t = force.shape[1]
    _check_time(dt, n_t, keep_from)
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    v0 = np.zeros(n) if v0 is None else np.asarray(v0, dtype=float)
    if method == "exact":
        disp, vel = _simulate_exact(system, dt, force, force_dofs, output_dofs, q0, v0, keep_from)
    elif method == "newmark":
        disp, vel = _simulate_newmark(system, dt, force, force_dofs, output_dofs, q0, v0, keep_from)
    else:
        raise InputError(f"integration method {method!r}; expected 'exact' or 'newmark'")
    t = dt * np.arange(keep_from, n_t)
    return TimeResponse(t=t, dofs=output_dofs, displacement=disp, velocity=vel, method=method,
                        seconds=time.perf_counter() - t_start)


def _simulate_exact(system, dt, force, force_dofs, output_dofs, q0, v0, keep_from):
    n = system.n_dof
    # B f = [0; M^-1 f]: only the columns of M^-1 at the forced DOFs are needed.
    Minv_cols = np.linalg.solve(system.M, np.eye(n)[:, force_dofs])
    g = (system.V_inv[:, n:] @ Minv_cols) @ force  # (2n, n_t) modal forcing
    eta0 = system.V_inv @ np.concatenate([q0, v0])
    decay, w0, w1 = _hold_weights(system.eigenvalues, dt)
    eta = np.empty((2 * n, force.shape[1] - keep_from), dtype=complex)
    _modal_recursion(decay, w0, w1, np.ascontiguousarray(g, dtype=complex), eta0.astype(complex), keep_from, eta)
    disp = (system.V[output_dofs] @ eta).real
    vel = (system.V[n + output_dofs] @ eta).real
    return disp, vel


@numba.njit(cache=True, nogil=True)
def _newmark_kernel(Keff_inv, M, C, K, force_full, q, v, a, dt, keep_from, out_idx, disp, vel):
    n_t = force_full.shape[1]
    n = q.size
    c1 = 4.0 / dt**2
    c2 = 4.0 / dt
    rhs = np.empty(n)
    for k in range(n_t - 1):
        # average acceleration: q_{k+1} from Keff q_{k+1} = f_{k+1} + M(c1 q + c2 v + a) + C(2/dt q + v)
        tm = c1 * q + c2 * v + a
        tc = (2.0 / dt) * q + v
        rhs[:] = force_full[:, k + 1] + M @ tm + C @ tc
        q_new = Keff_inv @ rhs
        v_new = (2.0 / dt) * (q_new - q) - v
        a_new = c1 * (q_new - q) - c2 * v - a
        q, v, a = q_new, v_new, a_new
        if k + 1 >= keep_from:
            j = k + 1 - keep_from
            for r in range(out_idx.size):
                disp[r, j] = q[out_idx[r]]
                vel[r, j] = v[out_idx[r]]
    return disp, vel


def _simulate_newmark(system, dt, force, force_dofs, output_dofs, q0, v0, keep_from):
    n = system.n_dof
    M, C, K = system.M, system.C, system.K
    f_full = np.zeros((n, force.shape[1]))
    f_full[force_dofs] = force
    a0 = np.linalg.solve(M, f_full[:, 0] - C @ v0 - K @ q0)
    Keff_inv = np.linalg.inv(K + (2.0 / dt) * C + (4.0 / dt**2) * M)
    n_keep = force.shape[1] - keep_from
    disp = np.empty((output_dofs.size, n_keep))
    vel = np.empty((output_dofs.size, n_keep))
    if keep_from == 0:
        disp[:, 0], vel[:, 0] = q0[output_dofs], v0[output_dofs]
    _newmark_kernel(Keff_inv, M, C, K, f_full, q0.copy(), v0.copy(), a0, dt, keep_from, output_dofs, disp, vel)
    return disp, vel


def node_output_dofs(nodes: Sequence[int]) -> np.ndarray:
    """Global DOF indices (x, y) of each node, in order: [x1, y1, x2, y2, ...]."""
    return np.array([node_dofs(n)[k] for n in nodes for k in (X, Y)], dtype=int)


def unbalance_time_response(rotor: Rotor, omega: float, unbalances: Sequence[Unbalance], bearings, *,
                            duration: float = 15.0, dt: float = 1e-4, keep_last: float | None = 5.0,
                            nodes: Sequence[int] | None = None, method: str = "exact",
                            system: LinearSystem | None = None, probes: bool = False) -> TimeResponse:
    """The paper's reference response: start at rest, integrate `duration` s, keep the last `keep_last` s, at
    `nodes` (default: the bearings' nodes). `probes`: each node as its probes read it, relative to the pedestal they
    ride on (`assembly.probe_housings`; the same as the shaft's motion without pedestals).

    The unbalance force of Eq. 9 (a force turning with the shaft) is sampled every `dt`.
    """
    if not (np.isfinite(duration) and duration > 0):
        raise InputError(f"duration {duration!r} s; expected a positive number")
    nodes = tuple(rotor.bearing_nodes) if nodes is None else tuple(nodes)  # default: at the bearings
    n_t = int(round(duration / dt)) + 1
    keep_from = 0 if keep_last is None else max(0, n_t - int(round(keep_last / dt)))
    system = linear_system(rotor, omega, bearings) if system is None else system
    F = unbalance_force(rotor, omega, unbalances)
    force_dofs = np.flatnonzero(F)
    t = dt * np.arange(n_t)
    force = (F[force_dofs, None] * np.exp(1j * omega * t)[None, :]).real
    for n in nodes:
        rotor.check_node(n, "output node")
    out = node_output_dofs(nodes)
    housings = probe_housings(rotor, nodes) if probes else [None] * len(nodes)
    if all(h is None for h in housings):
        return simulate(system, dt, force, force_dofs, output_dofs=out, keep_from=keep_from, method=method)
    ref = np.concatenate([h if h is not None else np.full(2, -1) for h in housings])
    extra = np.unique(ref[ref >= 0])
    tr = simulate(system, dt, force, force_dofs, output_dofs=np.concatenate([out, extra]), keep_from=keep_from,
                  method=method)
    d, v = tr.displacement[:out.size].copy(), tr.velocity[:out.size].copy()
    for i, r in enumerate(ref):
        if r >= 0:
            j = out.size + int(np.searchsorted(extra, r))
            d[i] -= tr.displacement[j]
            v[i] -= tr.velocity[j]
    return TimeResponse(t=tr.t, dofs=out, displacement=d, velocity=v, method=tr.method, seconds=tr.seconds)


__all__ = ["DOF_PER_NODE", "LinearSystem", "TimeResponse", "linear_system", "node_output_dofs", "simulate",
           "unbalance_time_response"]
