"""Damped modes of Eq. 8 at one speed, and the Campbell diagram.

State space, z = (q, q'):   z' = A z,   A = [[0, I], [-M^-1 K, -M^-1 (C + Omega G)]].
Each underdamped mode is a conjugate pair lambda = -zeta w_n +/- i w_d; we keep the member with
Im(lambda) > 0, so a mode shape Q gives q(t) = Re(Q e^{lambda t}) and the node orbit
Z = x + i y = e^{sigma t} (Zf e^{i w_d t} + Zb e^{-i w_d t}) with Zf = (Qx + i Qy)/2, Zb = conj(Qx - i Qy)/2.
The mode whirls forward (with the spin, counter-clockwise in X-Y, SPEC §1) when |Zf| > |Zb|.
Overdamped roots are not modes of vibration: they are counted, not listed. That includes the nearly
real pairs (zeta >= `max_damping_ratio`, default 0.99: decay by e^-40 within one period) that the
gyroscopic coupling makes of two real roots. Stiffness-proportional shaft damping (zeta = beta w / 2)
overdamps every shaft mode above 1/(pi beta) Hz (16 kHz for the paper's beta = 2e-5 s); the slower root
of each such pair lands near 8 kHz, so the listed modes stop there.
Stability is judged on all roots (`max_real_part`), not only the listed modes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
import scipy.linalg

from ..errors import InputError
from .assembly import Rotor, bearing_matrices
from .directional import directional_components
from .elements import DOF_PER_NODE, X, Y


def _check_speed(omega: float) -> float:
    if not np.isfinite(omega):
        raise InputError(f"shaft speed {omega!r} rad/s is not a finite number")
    return float(omega)


@dataclass(frozen=True)
class ModalResult:
    """Damped modes at shaft speed `omega` (rad/s), ordered by damped frequency.

    eigenvalues (1/s, Im > 0); natural_frequencies = |lambda| and damped_frequencies = Im(lambda), both
    rad/s; damping_ratios = -Re(lambda)/|lambda| (> 0: stable); whirl: "forward"/"backward" per mode,
    judged at `whirl_nodes` (the node with the largest orbit unless given); forward_ratio
    |Zf|/(|Zf| + |Zb|) there (on isotropic supports at Omega = 0 every frequency is double and the
    forward/backward split of such a pair is arbitrary); modes (n_dof, n_modes), each normalized to a
    largest translation of 1; n_overdamped: roots (of 2 n_dof) that belong to no listed pair; max_real_part over all roots (1/s).
    """

    omega: float
    eigenvalues: np.ndarray
    natural_frequencies: np.ndarray
    damped_frequencies: np.ndarray
    damping_ratios: np.ndarray
    whirl: tuple[str, ...]
    forward_ratio: np.ndarray
    whirl_nodes: np.ndarray
    modes: np.ndarray
    n_overdamped: int
    max_real_part: float

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        return self.natural_frequencies / (2.0 * np.pi)

    @property
    def damped_frequencies_hz(self) -> np.ndarray:
        return self.damped_frequencies / (2.0 * np.pi)

    @property
    def stable(self) -> bool:
        """Asymptotically stable: every root of the state matrix, listed or overdamped, has Re < 0."""
        return self.max_real_part < 0.0


def state_matrix(M: np.ndarray, C: np.ndarray, K: np.ndarray) -> np.ndarray:
    """First-order form of M q'' + C q' + K q = 0 (C here includes Omega G)."""
    n = M.shape[0]
    lu = scipy.linalg.lu_factor(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -scipy.linalg.lu_solve(lu, K)
    A[n:, n:] = -scipy.linalg.lu_solve(lu, C)
    return A


def modal_analysis(rotor: Rotor, omega: float, bearings, *, n_modes: int | None = None,
                   whirl_node: int | None = None, max_damping_ratio: float = 0.99) -> ModalResult:
    """Damped complex modes of Eq. 8 at shaft speed `omega` (rad/s) on the given bearings.

    `bearings`: one (K, C) pair per `rotor.bearing_nodes` or LinearBearing objects (2x2 each).
    `n_modes`: keep the lowest n (default all underdamped ones). `whirl_node`: judge the whirl
    direction at this node (paper numbering) instead of at each mode's largest orbit.
    """
    omega = _check_speed(omega)
    K, C = bearing_matrices(rotor, bearings)
    if K.ndim != 2:
        raise InputError(f"modal analysis takes one 2x2 K and C per bearing; got stacked coefficients "
                         f"of shape {K.shape[:-2]}: call it once per speed (see campbell)")
    if whirl_node is not None:
        rotor.check_node(whirl_node, "whirl node")
    lam, vec = scipy.linalg.eig(state_matrix(rotor.M, C + omega * rotor.G, K))
    n = rotor.n_dof
    max_real = float(lam.real.max())
    zeta_all = -lam.real / np.maximum(np.abs(lam), np.finfo(float).tiny)
    osc = (lam.imag > 0.0) & (zeta_all < max_damping_ratio)
    n_over = lam.size - 2 * int(osc.sum())  # roots outside underdamped pairs
    lam, vec = lam[osc], vec[:n, osc]
    order = np.argsort(lam.imag)
    if n_modes is not None:
        if n_modes < 1:
            raise InputError(f"n_modes = {n_modes!r}; expected a positive integer")
        order = order[:n_modes]
    lam, vec = lam[order], vec[:, order]

    shaft = rotor.shaft_dofs  # a pedestal's housing moves too; the whirl is the shaft's
    qx, qy = vec[X:shaft:DOF_PER_NODE], vec[Y:shaft:DOF_PER_NODE]  # (n_nodes, n_modes)
    zf, zb = directional_components(qx, qy)
    orbit = np.abs(zf) + np.abs(zb)  # semi-major axis of each node's orbit
    nodes = (np.argmax(orbit, axis=0) if whirl_node is None
             else np.full(lam.size, whirl_node - 1))
    cols = np.arange(lam.size)
    ratio = np.abs(zf[nodes, cols]) / orbit[nodes, cols]
    whirl = tuple("forward" if r > 0.5 else "backward" for r in ratio)

    trans = np.concatenate([qx, qy])
    peak = trans[np.argmax(np.abs(trans), axis=0), cols]
    modes = vec / peak
    wn = np.abs(lam)
    return ModalResult(omega=omega, eigenvalues=lam, natural_frequencies=wn, damped_frequencies=lam.imag,
                       damping_ratios=-lam.real / wn, whirl=whirl, forward_ratio=ratio,
                       whirl_nodes=nodes + 1, modes=modes, n_overdamped=n_over, max_real_part=max_real)


@dataclass(frozen=True)
class CampbellResult:
    """Campbell diagram: per speed (rows) the lowest `n_modes` modes sorted by damped frequency.

    speeds (rad/s); natural_frequencies, damped_frequencies (rad/s), damping_ratios, forward_ratio:
    arrays (n_speeds, n_modes), NaN where fewer modes exist; whirl: tuple of tuples of str.
    Modes are sorted, not tracked: where two lines cross their labels swap.
    """

    speeds: np.ndarray
    natural_frequencies: np.ndarray
    damped_frequencies: np.ndarray
    damping_ratios: np.ndarray
    forward_ratio: np.ndarray
    whirl: tuple[tuple[str, ...], ...]

    @property
    def damped_frequencies_hz(self) -> np.ndarray:
        return self.damped_frequencies / (2.0 * np.pi)

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        return self.natural_frequencies / (2.0 * np.pi)


def campbell(rotor: Rotor, speeds: Sequence[float], bearing_coefficients: Callable[[float], list],
             *, n_modes: int = 8, whirl_node: int | None = None) -> CampbellResult:
    """Modes at each speed (rad/s); `bearing_coefficients(omega)` returns one (K, C) per bearing."""
    speeds = np.atleast_1d(np.asarray(speeds, dtype=float))
    if speeds.ndim != 1 or speeds.size == 0:
        raise InputError(f"speeds must be a non-empty 1-D sequence (rad/s), got shape {speeds.shape}")
    if not callable(bearing_coefficients):
        raise InputError("bearing_coefficients must be a callable speed (rad/s) -> list of (K, C) per bearing")
    out = {k: np.full((speeds.size, n_modes), np.nan)
           for k in ("natural_frequencies", "damped_frequencies", "damping_ratios", "forward_ratio")}
    whirl = []
    for i, w in enumerate(speeds):
        res = modal_analysis(rotor, w, bearing_coefficients(w), n_modes=n_modes, whirl_node=whirl_node)
        m = res.eigenvalues.size
        out["natural_frequencies"][i, :m] = res.natural_frequencies
        out["damped_frequencies"][i, :m] = res.damped_frequencies
        out["damping_ratios"][i, :m] = res.damping_ratios
        out["forward_ratio"][i, :m] = res.forward_ratio
        whirl.append(res.whirl)
    return CampbellResult(speeds=speeds, whirl=tuple(whirl), **out)
