"""Newmark average-acceleration integration of M q'' + C q' + K q = Re(F e^{i Omega t}) from rest.

The trapezoidal rule (Newmark beta = 1/4, gamma = 1/2): unconditionally stable, no numerical damping,
a period error of (omega h)^2/12 (1.9e-4 at 75 Hz and h = 1e-4 s). Because the scheme keeps
M a_k + C v_k + K q_k = f_k at every step, the acceleration can be eliminated:

    Keff q_{k+1} = f_{k+1} + f_k + (4/h^2 M + 2/h C - K) q_k + 4/h M v_k,    Keff = K + 2/h C + 4/h^2 M,
    v_{k+1} = 2/h (q_{k+1} - q_k) - v_k,

i.e. two dense matrix-vector products per step with P = Keff^-1 (4/h^2 M + 2/h C - K) and
Q = Keff^-1 4/h M. The harmonic force is evaluated inside the loop from its complex amplitude, so a
force on every DOF (a bow) costs nothing extra and no (n_dof x n_steps) force array is stored.
Written here on purpose rather than taken from `lubeviz.rotor.transient` (the identification's own
helpers), so that the test records share no integrator code with the model.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _kernel(P, Q, hr, hi, omega, dt, n_steps, keep_from, out_idx, out):
    n = P.shape[0]
    q = np.zeros(n)
    v = np.zeros(n)
    for k in range(n_steps - 1):
        wt = omega * k * dt
        c, s = np.cos(wt), np.sin(wt)
        q_new = np.dot(P, q) + np.dot(Q, v) + c * hr - s * hi
        v = (2.0 / dt) * (q_new - q) - v
        q = q_new
        j = k + 1 - keep_from
        if j >= 0:
            for r in range(out_idx.size):
                out[r, j] = q[out_idx[r]]
    return out


def integrate_harmonic(M, C, K, F, omega: float, dt: float, n_steps: int, keep_from: int,
                       out_dofs) -> np.ndarray:
    """Displacements of `out_dofs` at samples keep_from..n_steps-1 (sample k at t = k dt), from rest.

    M, C (including Omega G), K: (n, n) real; F: complex (n,) force amplitude, f(t) = Re(F e^{i Omega t}).
    """
    c1, c2 = 4.0 / dt**2, 2.0 / dt
    Keff = K + c2 * C + c1 * M
    P = np.linalg.solve(Keff, c1 * M + c2 * C - K)
    Q = np.linalg.solve(Keff, (4.0 / dt) * M)
    # f_{k+1} + f_k = Re(F (e^{i Omega dt} + 1) e^{i Omega t_k})
    h = np.linalg.solve(Keff, F) * (1.0 + np.exp(1j * omega * dt))
    out_dofs = np.asarray(out_dofs, dtype=np.int64)
    out = np.zeros((out_dofs.size, n_steps - keep_from))
    return _kernel(np.ascontiguousarray(P), np.ascontiguousarray(Q), np.ascontiguousarray(h.real),
                   np.ascontiguousarray(h.imag), float(omega), float(dt), int(n_steps), int(keep_from),
                   out_dofs, out)


def amplification(eigenvalues, dt: float) -> np.ndarray:
    """|z| of each mode under the trapezoidal rule, z = (1 + lambda h/2)/(1 - lambda h/2)."""
    x = 0.5 * np.asarray(eigenvalues) * dt
    return np.abs((1.0 + x) / (1.0 - x))
