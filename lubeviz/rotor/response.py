"""Steady synchronous unbalance response of Eq. 8: one complex solve per speed (SPEC §4).

Unbalance force (Eq. 9, SPEC §1) of moment m_u at phase p:
    Fx = m_u Omega^2 cos(Omega t + p) = Re(m_u Omega^2 e^{ip} e^{i Omega t}),
    Fy = m_u Omega^2 sin(Omega t + p) = Re(-i m_u Omega^2 e^{ip} e^{i Omega t}),
a force turning with the shaft. With q = Re(Q e^{i Omega t}):
    (-Omega^2 M + i Omega (C + Omega G) + K) Q = F.
Per node X = Q_x, Y = Q_y; Zf, Zb, fb and phi as in `directional`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ..errors import InputError
from .assembly import Rotor, bearing_matrices
from .directional import directional_components, forward_backward_ratio, orbit_angle, unwrap_orbit_angle
from .elements import DOF_PER_NODE, X, Y, node_dofs


@dataclass(frozen=True)
class Unbalance:
    """An unbalance plane: node (paper numbering), moment m_u (kg*m), phase (rad) at t = 0."""

    node: int
    moment: float
    phase: float = 0.0

    def __post_init__(self):
        if not (np.isfinite(self.moment) and self.moment >= 0.0):
            raise InputError(f"unbalance moment {self.moment!r} kg*m; expected a non-negative number")
        if not np.isfinite(self.phase):
            raise InputError(f"unbalance phase {self.phase!r} rad is not finite")


def machine_unbalance(machine) -> tuple[Unbalance, ...]:
    """The unbalances of a `Machine` model: the main one (paper: 1.24e-2 kg*m at node 13) and any others."""
    return (Unbalance(machine.unbalance_node, machine.unbalance_moment, machine.unbalance_phase),
            *(Unbalance(u.node, u.moment, u.phase) for u in getattr(machine, "other_unbalances", ())))


def unbalance_force(rotor: Rotor, omega: float, unbalances: Sequence[Unbalance]) -> np.ndarray:
    """Complex force amplitude F (Eq. 9) with f(t) = Re(F e^{i Omega t})."""
    F = np.zeros(rotor.n_dof, dtype=complex)
    for u in unbalances:
        if not isinstance(u, Unbalance):
            raise InputError(f"expected Unbalance(node, moment, phase), got {u!r}")
        i = node_dofs(rotor.check_node(u.node, "unbalance node"))
        amp = u.moment * omega**2 * np.exp(1j * u.phase)
        F[i[X]] += amp
        F[i[Y]] += -1j * amp
    return F


def dynamic_stiffness(rotor: Rotor, omega: float, K: np.ndarray, C: np.ndarray) -> np.ndarray:
    """-Omega^2 M + i Omega (C + Omega G) + K for synchronous excitation."""
    return K - omega**2 * rotor.M + 1j * omega * (C + omega * rotor.G)


@dataclass(frozen=True)
class UnbalanceResponse:
    """Synchronous response at speed `omega` (rad/s) of the listed `nodes`.

    x, y: complex amplitudes (m), x(t) = Re(x e^{i Omega t}); zf, zb: forward/backward phasors of
    Z = x + i y (Eq. 10); fb = |zf|/|zb|; phi: orbit angle (rad, branch (-pi/2, pi/2]); q: all DOFs.
    """

    omega: float
    nodes: tuple[int, ...]
    x: np.ndarray
    y: np.ndarray
    zf: np.ndarray
    zb: np.ndarray
    fb: np.ndarray
    phi: np.ndarray
    q: np.ndarray


def _nodes(rotor: Rotor, nodes) -> tuple[int, ...]:
    nodes = tuple(range(1, rotor.n_nodes + 1)) if nodes is None else tuple(nodes)
    return tuple(rotor.check_node(n, "response node") for n in nodes)


def _features(omega, nodes, q):
    idx = np.array(nodes) - 1
    x = q[..., DOF_PER_NODE * idx + X]
    y = q[..., DOF_PER_NODE * idx + Y]
    zf, zb = directional_components(x, y)
    return dict(omega=omega, nodes=nodes, x=x, y=y, zf=zf, zb=zb, fb=forward_backward_ratio(zf, zb),
                phi=orbit_angle(zf, zb), q=q)


def unbalance_response(rotor: Rotor, omega: float, unbalances: Sequence[Unbalance], bearings, *,
                       nodes: Sequence[int] | None = None) -> UnbalanceResponse:
    """Steady response to unbalance at speed `omega` (rad/s) on bearings (one (K, C) per bearing)."""
    if not (np.isfinite(omega) and omega > 0.0):
        raise InputError(f"shaft speed {omega!r} rad/s; expected a positive number")
    nodes = _nodes(rotor, nodes)
    K, C = bearing_matrices(rotor, bearings)
    if K.ndim != 2:
        raise InputError(f"one 2x2 K and C per bearing expected, got stacked coefficients {K.shape[:-2]}; "
                         "use unbalance_sweep for several speeds")
    q = np.linalg.solve(dynamic_stiffness(rotor, omega, K, C), unbalance_force(rotor, omega, unbalances))
    return UnbalanceResponse(**_features(float(omega), nodes, q))


def unbalance_sweep(rotor: Rotor, speeds: Sequence[float], unbalances: Sequence[Unbalance],
                    bearing_coefficients: Callable[[float], list] | list, *,
                    nodes: Sequence[int] | None = None) -> UnbalanceResponse:
    """Response over speeds (rad/s): arrays gain a leading speed axis, phi is unwrapped along it.

    `bearing_coefficients` is either a callable omega -> list of (K, C) per bearing, or one fixed list.
    """
    speeds = np.atleast_1d(np.asarray(speeds, dtype=float))
    if speeds.ndim != 1 or speeds.size == 0 or not np.all(np.isfinite(speeds) & (speeds > 0.0)):
        raise InputError(f"speeds must be a non-empty 1-D array of positive values (rad/s), got {speeds!r}")
    nodes = _nodes(rotor, nodes)
    get = bearing_coefficients if callable(bearing_coefficients) else (lambda w: bearing_coefficients)
    q = np.empty((speeds.size, rotor.n_dof), dtype=complex)
    for i, w in enumerate(speeds):
        K, C = bearing_matrices(rotor, get(w))
        q[i] = np.linalg.solve(dynamic_stiffness(rotor, w, K, C), unbalance_force(rotor, w, unbalances))
    out = _features(speeds, nodes, q)
    out["phi"] = unwrap_orbit_angle(out["phi"], axis=0)
    return UnbalanceResponse(**out)
