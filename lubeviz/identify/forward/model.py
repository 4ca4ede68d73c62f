"""The forward model of the identification: supply flows (Q1, Q2) -> orbit features at two planes.

One evaluation is the steady unbalance response of Eq. 8 with each bearing's K, C read from its
coefficient table. The bearings touch only four DOFs (x, y of the two journals), so with a reference
dynamic stiffness D0 (both bearings at their Q_T) factorized once, any other flows are a rank-4
update (Woodbury):

    D = D0 + U dB U^T,   dB = blockdiag(dK1 + i Omega dC1, dK2 + i Omega dC2),
    x = x0 - Z (I + dB W)^-1 dB x0_U,   x0 = D0^-1 F,  Z = D0^-1 U,  W = U^T Z,

a 4x4 solve per evaluation (microseconds, batched over whole Q1 x Q2 grids) instead of an 84x84 one.
Tests check it against the direct solve.

Features (SPEC §1): Zf, Zb, fb = |Zf|/|Zb|, phi at each plane; and, for the best mode, the invariants
of the response to an unbalance of unknown size and phase (the response scales by one complex
factor): fb and phi at both planes plus Zf2/Zf1 (log-magnitude and phase).
"""

from __future__ import annotations

import functools

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...errors import InputError
from ...rotor.assembly import rotor_from_machine
from ...rotor.directional import directional_components, orbit_angle
from ...rotor.elements import X, Y, node_dofs
from ...rotor.response import dynamic_stiffness, machine_unbalance, unbalance_force
from ..tables.supply import CoefficientTable

PAPER_FEATURES = ("fb1", "fb2", "phi1", "phi2")
ALL_FEATURES = ("fb1", "fb2", "phi1", "phi2", "log_zf_ratio", "arg_zf_ratio")
ANGULAR = {"phi1": math.pi, "phi2": math.pi, "arg_zf_ratio": 2 * math.pi}  # feature -> period (two planes)


def plane_features(n_planes: int) -> tuple[str, ...]:
    """The 1X invariants of `n_planes` planes (SPEC §8): fb and phi at each plane, and each plane's forward
    component against the first one's (log-magnitude and phase: the response to an unbalance of unknown size and
    phase scales by one complex factor). Planes 1 and 2 keep the paper's names (`ALL_FEATURES` for two planes:
    the ratio of plane 2's is `log_zf_ratio`); plane p > 2 adds `log_zf_ratio{p}`, `arg_zf_ratio{p}`."""
    if n_planes < 1:
        raise InputError(f"{n_planes} measurement planes; expected at least one")
    fb = [f"fb{p}" for p in range(1, n_planes + 1)]
    phi = [f"phi{p}" for p in range(1, n_planes + 1)]
    ratios = [n for p in range(2, n_planes + 1) for n in (_ratio_name("log", p), _ratio_name("arg", p))]
    return tuple(fb + phi + ratios)


def _ratio_name(kind: str, plane: int) -> str:
    return f"{kind}_zf_ratio" if plane == 2 else f"{kind}_zf_ratio{plane}"


@functools.lru_cache(maxsize=512)
def feature_plane(name: str) -> tuple[str, int]:
    """(kind, plane) of a feature name: ('fb', 1), ('phi', 3), ('log_zf_ratio', 2), ('sx', 2)... InputError for a
    name that is not a feature."""
    for kind in ("log_zf_ratio", "arg_zf_ratio", "fb", "phi", "sx", "sy"):
        if name.startswith(kind):
            rest = name[len(kind):]
            if kind.endswith("ratio") and rest == "":
                return kind, 2
            if rest.isdigit() and int(rest) >= 1 and not rest.startswith("0"):
                plane = int(rest)
                if not (kind.endswith("ratio") and plane < 3):
                    return kind, plane
    raise InputError(f"unknown feature {name!r}; expected fb<p>, phi<p>, log_zf_ratio, arg_zf_ratio, "
                     "log_zf_ratio<p>, arg_zf_ratio<p> (p >= 3), sx<p> or sy<p> for plane p")


def is_static(name: str) -> bool:
    """Whether `name` is a static-position feature (sx<p>, sy<p>: the journal's offset from the rest reading)."""
    return name[:2] in ("sx", "sy") and name[2:].isdigit()


def static_features(planes) -> tuple[str, ...]:
    """The static-position features of `planes` (1-based plane numbers, or their count)."""
    planes = range(1, planes + 1) if isinstance(planes, int) else planes
    return tuple(f"s{a}{p}" for p in planes for a in "xy")


@functools.lru_cache(maxsize=512)
def angular_period(name: str) -> float | None:
    """The period of an angular feature (phi: pi; the ratio's phase: 2 pi), None for the others."""
    if name in ANGULAR:
        return ANGULAR[name]
    kind = feature_plane(name)[0] if not is_static(name) else "s"
    return {"phi": math.pi, "arg_zf_ratio": 2 * math.pi}.get(kind)


@dataclass(frozen=True)
class Response:
    """Complex 1X amplitudes x, y (..., n_nodes) and their directional components."""

    x: np.ndarray
    y: np.ndarray

    @property
    def zf(self):
        return directional_components(self.x, self.y)[0]

    @property
    def zb(self):
        return directional_components(self.x, self.y)[1]


def feature_vector(x: np.ndarray, y: np.ndarray, names: Sequence[str] = PAPER_FEATURES) -> np.ndarray:
    """Features (last axis, in `names` order) of responses with planes on the last axis of x, y (any number of
    planes: `plane_features`)."""
    zf, zb = directional_components(np.asarray(x), np.asarray(y))
    plan = _feature_plan(tuple(names), zf.shape[-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        fb = np.abs(zf) / np.abs(zb)
        ratio = zf / zf[..., :1]
    phi = orbit_angle(zf, zb)
    out = np.empty(zf.shape[:-1] + (len(plan),))
    for j, (kind, p) in enumerate(plan):
        out[..., j] = (fb[..., p] if kind == "fb" else phi[..., p] if kind == "phi"
                       else np.log(np.abs(ratio[..., p])) if kind == "log_zf_ratio" else np.angle(ratio[..., p]))
    return out


@functools.lru_cache(maxsize=256)
def _feature_plan(names: tuple, n_planes: int) -> tuple:
    """((kind, 0-based plane), ...) of the 1X features `names` at a response of `n_planes` planes (a fit asks for
    the same names thousands of times)."""
    out = []
    for n in names:
        kind, p = feature_plane(n)
        if kind in ("sx", "sy") or p > n_planes:
            raise InputError(f"unknown feature {n!r} for a response at {n_planes} planes; expected some of "
                             f"{plane_features(n_planes)}")
        out.append((kind, p - 1))
    return tuple(out)


def wrap_difference(d: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """Feature differences with angles wrapped to their half-period (phi modulo pi, phases modulo 2 pi)."""
    d = np.array(d, dtype=float, copy=True)
    which, periods = _periods(tuple(names))
    if which.size:
        d[..., which] = (d[..., which] + 0.5 * periods) % periods - 0.5 * periods
    return d


@functools.lru_cache(maxsize=256)
def _periods(names: tuple) -> tuple[np.ndarray, np.ndarray]:
    """(indices, periods) of the angular features among `names` (a fit asks for the same names thousands of
    times: Python's loop over them was a tenth of a fan's fit, session 46)."""
    pairs = [(k, angular_period(n)) for k, n in enumerate(names) if angular_period(n) is not None]
    return np.array([k for k, _ in pairs], dtype=int), np.array([p for _, p in pairs], dtype=float)


class ForwardModel:
    """Flows (m^3/s) -> responses and features at two measurement `nodes`, from coefficient tables."""

    def __init__(self, machine, tables: Sequence[CoefficientTable], nodes: Sequence[int], *,
                 rotor=None, unbalances=None):
        self.machine = machine
        self.tables = tuple(tables)
        if len(self.tables) != 2:
            raise InputError(f"the paper's table model (paper mode, its maps) is for a machine of two oil-film "
                             f"bearings; this one has {len(self.tables)}: use best mode")
        omega = self.tables[0].omega
        if any(abs(t.omega - omega) > 1e-9 * omega for t in self.tables):
            raise InputError("coefficient tables at different speeds")
        self.omega = omega
        self.rotor = rotor_from_machine(machine) if rotor is None else rotor
        if any(h.part == "bearing" for h in self.rotor.housings):
            raise InputError("the paper's table model (paper mode, its maps) takes its films on the ground; this "
                             "machine's bearings stand on pedestals: use best mode")
        self.nodes = tuple(self.rotor.check_node(int(n), "measurement node") for n in nodes)
        if len(self.nodes) != 2:
            raise InputError(f"two measurement planes expected, got nodes {self.nodes}")
        self.q_threshold = np.array([t.q_threshold for t in self.tables])
        self.q_ref = self.q_threshold.copy()
        unb = machine_unbalance(machine) if unbalances is None else unbalances
        F = unbalance_force(self.rotor, omega, unb)
        K0, C0 = zip(*(t.coefficients(q) for t, q in zip(self.tables, self.q_ref)))
        self._B0 = [k + 1j * omega * c for k, c in zip(K0, C0)]
        from ...rotor.assembly import bearing_matrices

        Kt, Ct = bearing_matrices(self.rotor, list(zip(K0, C0)))
        D0 = dynamic_stiffness(self.rotor, omega, Kt, Ct)
        self._U = np.concatenate([node_dofs(n)[[X, Y]] for n in self.rotor.bearing_nodes])
        out = np.concatenate([node_dofs(n)[[X, Y]] for n in self.nodes])
        rhs = np.zeros((self.rotor.n_dof, 5), dtype=complex)
        rhs[:, 0] = F
        rhs[self._U, np.arange(1, 5)] = 1.0
        sol = np.linalg.solve(D0, rhs)
        self._x0_out, self._x0_U = sol[out, 0], sol[self._U, 0]
        self._Z_out, self._W = sol[out, 1:], sol[self._U, 1:]
        self.evaluations = 0

    def response(self, q1, q2) -> Response:
        """x, y complex amplitudes at the two nodes; q1, q2 broadcast (m^3/s)."""
        q1, q2 = np.broadcast_arrays(np.asarray(q1, dtype=float), np.asarray(q2, dtype=float))
        shape = q1.shape
        dB = np.zeros(shape + (4, 4), dtype=complex)
        for k, (t, q) in enumerate(zip(self.tables, (q1, q2))):
            K, C = t.coefficients(q)
            dB[..., 2 * k:2 * k + 2, 2 * k:2 * k + 2] = K + 1j * self.omega * C - self._B0[k]
        A = np.eye(4) + dB @ self._W
        rhs = (dB @ self._x0_U)[..., None]
        corr = np.linalg.solve(A, rhs)[..., 0]
        x_out = self._x0_out - np.einsum("ij,...j->...i", self._Z_out, corr)
        self.evaluations += int(np.prod(shape)) if shape else 1
        return Response(x=x_out[..., 0::2], y=x_out[..., 1::2])

    def response_derivative(self, q1: float, q2: float) -> tuple[Response, np.ndarray, np.ndarray]:
        """Response at (q1, q2) and its exact derivatives d(x, y)/dq_k (k = 1, 2) from the spline tables.

        With c = A^-1 dB x0_U, A = I + dB W, the journal motion is x_U = x0_U - W c, and
        dc/dq_k = A^-1 (d dB/dq_k) x_U, so dx_out/dq_k = -Z_out A^-1 (d dB/dq_k) x_U: one 4x4 solve more.
        """
        dB = np.zeros((4, 4), dtype=complex)
        ddB = np.zeros((2, 4, 4), dtype=complex)
        for k, (t, q) in enumerate(zip(self.tables, (q1, q2))):
            K, C = t.coefficients(q)
            dK, dC = t.coefficient_derivatives(q)
            sl = slice(2 * k, 2 * k + 2)
            dB[sl, sl] = K + 1j * self.omega * C - self._B0[k]
            ddB[k, sl, sl] = dK + 1j * self.omega * dC
        A = np.eye(4) + dB @ self._W
        c = np.linalg.solve(A, dB @ self._x0_U)
        x_U = self._x0_U - self._W @ c
        x_out = self._x0_out - self._Z_out @ c
        d_out = np.stack([-self._Z_out @ np.linalg.solve(A, ddB[k] @ x_U) for k in range(2)])  # (2, 4)
        self.evaluations += 1
        r = Response(x=x_out[0::2], y=x_out[1::2])
        return r, d_out[:, 0::2], d_out[:, 1::2]

    def features_jacobian(self, q1: float, q2: float, names: Sequence[str] = PAPER_FEATURES):
        """Features at (q1, q2) and their Jacobian (n_features, 2) per m^3/s, from one model evaluation."""
        r, dx, dy = self.response_derivative(q1, q2)
        g = feature_vector(r.x, r.y, names)
        J = np.empty((g.size, 2))
        scale = max(np.abs(r.x).max(), np.abs(r.y).max())
        for k in range(2):
            h = 1e-6 * scale / max(np.abs(dx[k]).max(), np.abs(dy[k]).max(), 1e-300)
            hi = feature_vector(r.x + h * dx[k], r.y + h * dy[k], names)
            lo = feature_vector(r.x - h * dx[k], r.y - h * dy[k], names)
            J[:, k] = wrap_difference(hi - lo, names) / (2 * h)
        return g, J

    def features(self, q1, q2, names: Sequence[str] = PAPER_FEATURES) -> np.ndarray:
        r = self.response(q1, q2)
        return feature_vector(r.x, r.y, names)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Flows the tables cover (m^3/s): (lower per bearing, upper per bearing)."""
        return (np.array([t.q_min for t in self.tables]), np.array([t.q_max for t in self.tables]))


def tabled_response(machine, tables: Sequence[CoefficientTable], flows, *, rotor=None, nodes=None):
    """Steady unbalance response (rotor.response.UnbalanceResponse, all nodes by default) with each
    bearing's K, C read from its table at its supply flow (m^3/s): the direct solve, for any nodes."""
    from ...rotor.response import unbalance_response

    rotor = rotor_from_machine(machine) if rotor is None else rotor
    coefficients = [t.coefficients(float(q)) for t, q in zip(tables, flows)]
    return unbalance_response(rotor, tables[0].omega, machine_unbalance(machine), coefficients, nodes=nodes)
