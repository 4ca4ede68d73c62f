"""Finite elements of the rotor (paper Sec. 2.2): Timoshenko shaft, rigid disc, linear bearing.

Axes and DOFs (SPEC §1): X horizontal, Y vertical up, Z along the shaft, spin +Omega about +Z
(counter-clockwise seen with X right and Y up). Each node carries four DOFs, in this order:

    (x, y, theta_x, theta_y)

theta_x and theta_y are small right-hand rotations of the cross-section about +X and +Y. A rotation
about +X by theta_x tilts the shaft axis (the section normal, +Z) towards -Y, one about +Y by theta_y
tilts it towards +X, so for an Euler-Bernoulli beam

    theta_x = -dy/dz,    theta_y = +dx/dz.

(These are ROSS's (x, y, alpha, beta).) Every shaft matrix below is built from the textbook planar
Timoshenko element with DOFs (w1, psi1, w2, psi2), psi = section rotation ~ dw/dz, applied twice:
in the XZ plane with (w, psi) = (x, theta_y) and in the YZ plane with (w, psi) = (y, -theta_x).

Gyroscopic moment (Euler's equation with H = Id*(dtheta_x, dtheta_y, 0) + Ip*Omega*n, where the spin
axis is n = (theta_y, -theta_x, 1)):

    Id theta_x'' + Ip Omega theta_y' = M_x,     Id theta_y'' - Ip Omega theta_x' = M_y,

i.e. a term + Omega G q' on the left of Eq. 8 with G[theta_x, theta_y] = +Ip, G[theta_y, theta_x] = -Ip.
For a conical motion Theta = theta_x + i theta_y = e^{i w t} this gives -Id w^2 + Ip Omega w + k = 0:
the forward (w > 0) branch stiffens with speed, as it must (tests check it against the analytic disc).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

DOF_PER_NODE = 4
X, Y, THETA_X, THETA_Y = range(DOF_PER_NODE)


def node_dofs(node: int) -> np.ndarray:
    """Global indices of the four DOFs (x, y, theta_x, theta_y) of a node (paper numbering, from 1)."""
    return DOF_PER_NODE * (node - 1) + np.arange(DOF_PER_NODE)


def cowper_shear_coefficient(poisson_ratio: float, bore_ratio: float = 0.0) -> float:
    """Cowper (1966) shear coefficient of a circular section, hollow with bore_ratio m = d_inner / d_outer:
    6(1+nu)(1+m^2)^2 / ((7+6nu)(1+m^2)^2 + (20+12nu)m^2); solid (m = 0): 6(1+nu)/(7+6nu)."""
    m2 = bore_ratio * bore_ratio
    a = (1.0 + m2) ** 2
    return 6.0 * (1.0 + poisson_ratio) * a / ((7.0 + 6.0 * poisson_ratio) * a + (20.0 + 12.0 * poisson_ratio) * m2)


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f"{name} = {value!r}; expected a positive finite number (SI units)")
    return value


# --- planar Timoshenko element (w1, psi1, w2, psi2): Nelson (1980), Friedman & Kosmatka (1993) ------------

def planar_stiffness(EI: float, L: float, phi: float) -> np.ndarray:
    """Bending + shear stiffness of the planar Timoshenko element; phi = 12 EI / (kappa G A L^2)."""
    return EI / ((1.0 + phi) * L**3) * np.array([
        [12.0, 6.0 * L, -12.0, 6.0 * L],
        [6.0 * L, (4.0 + phi) * L**2, -6.0 * L, (2.0 - phi) * L**2],
        [-12.0, -6.0 * L, 12.0, -6.0 * L],
        [6.0 * L, (2.0 - phi) * L**2, -6.0 * L, (4.0 + phi) * L**2],
    ])


def planar_translational_mass(rhoA: float, L: float, phi: float) -> np.ndarray:
    """Consistent translational mass, rho A int(Nw^T Nw) dz, of the Timoshenko element."""
    m1 = 13 / 35 + 7 * phi / 10 + phi**2 / 3
    m2 = (11 / 210 + 11 * phi / 120 + phi**2 / 24) * L
    m3 = 9 / 70 + 3 * phi / 10 + phi**2 / 6
    m4 = (13 / 420 + 3 * phi / 40 + phi**2 / 24) * L
    m5 = (1 / 105 + phi / 60 + phi**2 / 120) * L**2
    m6 = (1 / 140 + phi / 60 + phi**2 / 120) * L**2
    return rhoA * L / (1.0 + phi) ** 2 * np.array([
        [m1, m2, m3, -m4],
        [m2, m5, m4, -m6],
        [m3, m4, m1, -m2],
        [-m4, -m6, -m2, m5],
    ])


def planar_rotary_mass(rhoI: float, L: float, phi: float) -> np.ndarray:
    """Consistent rotary inertia, rho I int(Npsi^T Npsi) dz, of the Timoshenko element."""
    r1 = 6 / 5
    r2 = (1 / 10 - phi / 2) * L
    r3 = (2 / 15 + phi / 6 + phi**2 / 3) * L**2
    r4 = (1 / 30 + phi / 6 - phi**2 / 6) * L**2
    return rhoI / (L * (1.0 + phi) ** 2) * np.array([
        [r1, r2, -r1, r2],
        [r2, r3, -r2, -r4],
        [-r1, -r2, r1, -r2],
        [r2, -r4, -r2, r3],
    ])


def _plane_maps() -> tuple[np.ndarray, np.ndarray]:
    """T_xz, T_yz: 4x8 maps from the element DOFs to the planar (w1, psi1, w2, psi2) of each plane."""
    t_xz = np.zeros((4, 8))
    t_yz = np.zeros((4, 8))
    for side in (0, 1):
        base = DOF_PER_NODE * side
        t_xz[2 * side, base + X] = 1.0          # w = x
        t_xz[2 * side + 1, base + THETA_Y] = 1.0  # psi = dx/dz = theta_y
        t_yz[2 * side, base + Y] = 1.0          # w = y
        t_yz[2 * side + 1, base + THETA_X] = -1.0  # psi = dy/dz = -theta_x
    return t_xz, t_yz


_T_XZ, _T_YZ = _plane_maps()


def _both_planes(planar: np.ndarray) -> np.ndarray:
    return _T_XZ.T @ planar @ _T_XZ + _T_YZ.T @ planar @ _T_YZ


@dataclass(frozen=True)
class TimoshenkoBeam:
    """A uniform circular shaft element between `node` and `node + 1` (Nelson 1980), hollow when
    `inner_diameter` > 0.

    Consistent translational and rotary inertia, bending with shear (Phi = 12 E I / (kappa G A L^2)),
    gyroscopic matrix G (multiplied by Omega in Eq. 8). SI units. `shear_coefficient` defaults to
    Cowper's value for a solid circular section; set `shear=False` for a Rayleigh beam (Phi = 0).
    """

    node: int
    length: float
    diameter: float
    young_modulus: float
    poisson_ratio: float
    density: float
    shear_coefficient: float | None = None
    shear: bool = True
    inner_diameter: float = 0.0

    def __post_init__(self):
        if not (isinstance(self.node, (int, np.integer)) and self.node >= 1):
            raise InputError(f"shaft element node {self.node!r}; expected an integer >= 1 (paper numbering)")
        for name in ("length", "diameter", "young_modulus", "density"):
            _positive(f"shaft element {name}", getattr(self, name))
        if not 0.0 <= self.poisson_ratio < 0.5:
            raise InputError(f"Poisson's ratio {self.poisson_ratio!r}; expected 0 <= nu < 0.5")
        if self.shear_coefficient is not None:
            _positive("shear coefficient", self.shear_coefficient)
        if not (math.isfinite(self.inner_diameter) and 0.0 <= self.inner_diameter < self.diameter):
            raise InputError(f"shaft element inner diameter {self.inner_diameter!r} m; expected 0 <= inner < outer "
                             f"diameter {self.diameter!r} m")

    @property
    def area(self) -> float:
        return math.pi * (self.diameter**2 - self.inner_diameter**2) / 4.0

    @property
    def inertia(self) -> float:
        """Second moment of area I (diametral); the polar one is 2 I."""
        return math.pi * (self.diameter**4 - self.inner_diameter**4) / 64.0

    @property
    def mass(self) -> float:
        return self.density * self.area * self.length

    @property
    def kappa(self) -> float:
        if self.shear_coefficient is not None:
            return self.shear_coefficient
        return cowper_shear_coefficient(self.poisson_ratio, self.inner_diameter / self.diameter)

    @property
    def phi(self) -> float:
        """Shear parameter Phi = 12 E I / (kappa G A L^2); 0 without shear."""
        if not self.shear:
            return 0.0
        G = self.young_modulus / (2.0 * (1.0 + self.poisson_ratio))
        return 12.0 * self.young_modulus * self.inertia / (self.kappa * G * self.area * self.length**2)

    def dofs(self) -> np.ndarray:
        return np.concatenate([node_dofs(self.node), node_dofs(self.node + 1)])

    def M(self) -> np.ndarray:
        L, phi = self.length, self.phi
        planar = (planar_translational_mass(self.density * self.area, L, phi)
                  + planar_rotary_mass(self.density * self.inertia, L, phi))
        return _both_planes(planar)

    def K(self) -> np.ndarray:
        return _both_planes(planar_stiffness(self.young_modulus * self.inertia, self.length, self.phi))

    def G(self) -> np.ndarray:
        # The spin inertia per unit length is rho * 2I; with theta_y = Npsi.q_xz, theta_x = -Npsi.q_yz the
        # gyroscopic moments above become, in plane coordinates, [[0, 2R], [-2R, 0]] (R = rotary mass).
        R2 = 2.0 * planar_rotary_mass(self.density * self.inertia, self.length, self.phi)
        return _T_XZ.T @ R2 @ _T_YZ - _T_YZ.T @ R2 @ _T_XZ


@dataclass(frozen=True)
class RigidDisc:
    """A rigid disc at a node: mass, diametral inertia Id, polar inertia Ip (SI)."""

    node: int
    mass: float
    diametral_inertia: float
    polar_inertia: float

    def __post_init__(self):
        if not (isinstance(self.node, (int, np.integer)) and self.node >= 1):
            raise InputError(f"disc node {self.node!r}; expected an integer >= 1 (paper numbering)")
        _positive("disc mass", self.mass)
        if self.diametral_inertia < 0.0 or self.polar_inertia < 0.0:
            raise InputError(f"disc inertias Id = {self.diametral_inertia!r}, Ip = {self.polar_inertia!r}; "
                             "expected non-negative values")

    @classmethod
    def annular(cls, node: int, width: float, outer_diameter: float, bore_diameter: float,
                density: float) -> "RigidDisc":
        """A uniform annular disc (bore = local shaft diameter in the paper's machine)."""
        for name, v in (("width", width), ("outer diameter", outer_diameter), ("density", density)):
            _positive(f"disc {name}", v)
        if not 0.0 <= bore_diameter < outer_diameter:
            raise InputError(f"disc bore {bore_diameter!r} m; expected 0 <= bore < outer diameter "
                             f"{outer_diameter!r} m")
        ro2, ri2 = (outer_diameter / 2.0) ** 2, (bore_diameter / 2.0) ** 2
        mass = density * math.pi * (ro2 - ri2) * width
        polar = 0.5 * mass * (ro2 + ri2)
        diametral = 0.25 * mass * (ro2 + ri2) + mass * width**2 / 12.0
        return cls(node, mass, diametral, polar)

    def dofs(self) -> np.ndarray:
        return node_dofs(self.node)

    def M(self) -> np.ndarray:
        return np.diag([self.mass, self.mass, self.diametral_inertia, self.diametral_inertia])

    def K(self) -> np.ndarray:
        return np.zeros((4, 4))

    def G(self) -> np.ndarray:
        g = np.zeros((4, 4))
        g[THETA_X, THETA_Y] = self.polar_inertia
        g[THETA_Y, THETA_X] = -self.polar_inertia
        return g


def coefficient_matrix(value, name: str) -> np.ndarray:
    """A bearing coefficient as a float array of shape (..., 2, 2): a 2x2 or a stack (e.g. per speed)."""
    a = np.asarray(value, dtype=float)
    if a.ndim < 2 or a.shape[-2:] != (2, 2):
        raise InputError(f"bearing {name} has shape {a.shape}; expected (2, 2) [[XX, XY], [YX, YY]] "
                         "or a stack (..., 2, 2)")
    if not np.all(np.isfinite(a)):
        raise InputError(f"bearing {name} holds NaN or inf: {a.tolist()}")
    return a


@dataclass(frozen=True)
class LinearBearing:
    """Linearized bearing at a node (Lund's sign, SPEC §1): f = f0 - K (q - q0) - C q' on (x, y).

    `stiffness` and `damping` are [[XX, XY], [YX, YY]] (N/m, N*s/m); XY couples force X to displacement
    Y. They enter the global K and C with a + sign. A leading stack dimension (e.g. speeds) is allowed.
    """

    node: int
    stiffness: np.ndarray
    damping: np.ndarray

    def __post_init__(self):
        if not (isinstance(self.node, (int, np.integer)) and self.node >= 1):
            raise InputError(f"bearing node {self.node!r}; expected an integer >= 1 (paper numbering)")
        object.__setattr__(self, "stiffness", coefficient_matrix(self.stiffness, "stiffness K"))
        object.__setattr__(self, "damping", coefficient_matrix(self.damping, "damping C"))

    def dofs(self) -> np.ndarray:
        return node_dofs(self.node)[:2]

    def K(self) -> np.ndarray:
        return self.stiffness

    def C(self) -> np.ndarray:
        return self.damping
