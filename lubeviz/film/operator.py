"""The discrete p-theta mass balance of every finite volume (Eq. 2-6), shared by all solvers.

Per cell P, in the nondimensional form used by every solver (outflow - inflow = source):

    R_P = C1 theta_P - C2 theta_W + aP p_P - aE p_E - aW p_W - aN p_N - aS p_S - S_P      (Eq. 3-4)

    C1 = H_e + sq_P        upwind Couette flux out of the east face, plus the explicit squeeze term
    C2 = H_w               upwind Couette flux in through the west face (theta of the upstream cell)
    aE = H_e^3 / da        central Poiseuille conductances (circumferential) ...
    aN = H_n^3 da (R/dz)^2 ... and axial; a face on a film edge (p = 0, theta = 1: Eq. 5) is half a
                           cell away, so its conductance is doubled and its neighbour pressure is 0
    aP = aE + aW + aN + aS

Scales: H = h / c; pressure p = P * p_ref with p_ref = 6 mu U R / c^2 (U = Omega R); fluxes in units
of F0 = (U / 2) c dz, the Couette flux through one face of height c. The squeeze term (Eq. 2,
d(h theta)/dt, evaluated explicitly as theta_P dh/dt: the oil fraction is carried by the moving
surfaces, its own time derivative is dropped) is sq_P = 2 da (dh/dt) / (Omega c).

Complementarity (Eq. 6): in every cell either p > 0 and theta = 1 (full film) or p = 0 and
theta <= 1 (cavitated or starved).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .mesh import FilmMesh


@dataclass(frozen=True)
class Coefficients:
    """Coefficient arrays of the cell balance, each of shape (nz, n_circ)."""

    C1: np.ndarray
    C2: np.ndarray
    aE: np.ndarray
    aW: np.ndarray
    aN: np.ndarray
    aS: np.ndarray
    S: np.ndarray

    @property
    def aP(self) -> np.ndarray:
        return self.aE + self.aW + self.aN + self.aS


@dataclass(frozen=True)
class FilmProblem:
    """Everything one steady p-theta solve needs, already nondimensional.

    `fixed` marks cells held at ambient pressure and full film (p = 0, theta = 1): the flooded
    groove, or the feed line of a plain bearing. `interior_n`/`interior_s` say whether the north /
    south neighbour is a cell (True) or a film edge or symmetry plane (False).
    """

    mesh: FilmMesh
    coef: Coefficients
    fixed: np.ndarray  # bool (nz, n_circ)
    groove: np.ndarray  # bool (nz, n_circ): cells of the groove (source or fixed cells)
    edge_s: np.ndarray  # conductance of the z = 0 edge face for row j = 0, (n_circ,)
    edge_n: np.ndarray  # conductance of the z = L edge face for the last row (zero at a symmetry plane)
    H: np.ndarray  # film thickness at cell centres / c, (nz, n_circ)
    H_e: np.ndarray  # film thickness at east faces / c, (nz, n_circ)
    sq: np.ndarray  # squeeze coefficient, (nz, n_circ)
    p_ref: float  # Pa per unit P
    flux_ref: float  # m^3/s per unit flux (one solved cell row's face, see module doc)
    omega: float
    clearance: float
    viscosity: float


def film_thickness(alpha, e_x, e_y, clearance):
    """Eq. 1: h(alpha) = c + eX sin(alpha) - eY cos(alpha)."""
    return clearance + e_x * np.sin(alpha) - e_y * np.cos(alpha)


def build_coefficients(mesh: FilmMesh, H, H_e, sq, source) -> Coefficients:
    """Coefficient arrays from film thickness at centres (H) and east faces (H_e), squeeze and source.

    Also used with *derivatives* of (H^3, H_e, ...) through `coefficient_derivatives`; the balance
    is linear in every coefficient, so its derivative at fixed (p, theta) is the same formula.
    """
    da = mesh.d_alpha  # column widths (n_circ,)
    da_e = mesh.d_alpha_east  # centre-to-centre spacing across each east face
    H_w = np.roll(H_e, 1, axis=1)
    axial = da * (mesh.radius / mesh.dz) ** 2
    H_n3 = np.empty_like(H)
    H_n3[:-1] = (0.5 * (H[:-1] + H[1:])) ** 3
    H_n3[-1] = H[-1] ** 3
    aN = axial * H_n3
    aS = np.empty_like(aN)
    aS[1:] = aN[:-1]
    aS[0] = 2.0 * axial * H[0] ** 3  # film edge z = 0, half a cell away
    if mesh.half:
        aN[-1] = 0.0  # symmetry plane z = L/2: no flux
    else:
        aN[-1] = 2.0 * axial * H[-1] ** 3  # film edge z = L
    return Coefficients(
        C1=H_e + sq, C2=H_w, aE=H_e**3 / da_e, aW=H_w**3 / np.roll(da_e, 1), aN=aN, aS=aS, S=source
    )


def coefficient_derivatives(mesh: FilmMesh, H, H_e, dH, dH_e, dsq) -> Coefficients:
    """d(coefficients)/ds for a parameter s moving H by dH, H_e by dH_e and sq by dsq (S fixed)."""
    da, da_e = mesh.d_alpha, mesh.d_alpha_east
    H_w, dH_w = np.roll(H_e, 1, axis=1), np.roll(dH_e, 1, axis=1)
    axial = da * (mesh.radius / mesh.dz) ** 2
    dH_n3 = np.empty_like(H)
    Hn = 0.5 * (H[:-1] + H[1:])
    dH_n3[:-1] = 3.0 * Hn**2 * 0.5 * (dH[:-1] + dH[1:])
    dH_n3[-1] = 3.0 * H[-1] ** 2 * dH[-1]
    daN = axial * dH_n3
    daS = np.empty_like(daN)
    daS[1:] = daN[:-1]
    daS[0] = 2.0 * axial * 3.0 * H[0] ** 2 * dH[0]
    daN[-1] = 0.0 if mesh.half else 2.0 * axial * 3.0 * H[-1] ** 2 * dH[-1]
    return Coefficients(
        C1=dH_e + dsq, C2=dH_w, aE=3.0 * H_e**2 * dH_e / da_e, aW=3.0 * H_w**2 * dH_w / np.roll(da_e, 1),
        aN=daN, aS=daS, S=np.zeros_like(H),
    )


def residual(coef: Coefficients, P, theta) -> np.ndarray:
    """Mass balance R_P of every cell (outflow - inflow - source), nondimensional, (nz, n_circ)."""
    R = coef.C1 * theta - coef.C2 * np.roll(theta, 1, axis=1) + coef.aP * P
    R -= coef.aE * np.roll(P, -1, axis=1) + coef.aW * np.roll(P, 1, axis=1)
    R[:-1] -= coef.aN[:-1] * P[1:]
    R[1:] -= coef.aS[1:] * P[:-1]
    return R - coef.S


def build_problem(
    mesh: FilmMesh,
    *,
    clearance: float,
    viscosity: float,
    omega: float,
    position: tuple[float, float],
    velocity: tuple[float, float] = (0.0, 0.0),
    groove: np.ndarray | None = None,
    fixed: np.ndarray | None = None,
    q_supply: float = 0.0,
) -> FilmProblem:
    """Assemble the nondimensional problem.

    `groove` marks the groove cells; with `fixed` None they receive the supply `q_supply` (m^3/s, the
    whole bearing's) split evenly, Eq. 4: Qs / Ng. `fixed` cells are held at p = 0, theta = 1.
    """
    e_x, e_y = position
    v_x, v_y = velocity
    U = omega * mesh.radius
    H = np.broadcast_to(film_thickness(mesh.alpha, e_x, e_y, clearance) / clearance, mesh.shape).copy()
    H_e = np.broadcast_to(film_thickness(mesh.alpha_east, e_x, e_y, clearance) / clearance, mesh.shape).copy()
    hdot = v_x * np.sin(mesh.alpha) - v_y * np.cos(mesh.alpha)
    sq = np.broadcast_to(2.0 * mesh.d_alpha * hdot / (omega * clearance), mesh.shape).copy()
    if np.any(H <= 0.0) or np.any(H_e <= 0.0):
        raise ValueError("film thickness must be positive everywhere (eccentricity < clearance)")
    flux_ref = 0.5 * U * clearance * mesh.dz
    source = np.zeros(mesh.shape)
    groove = np.zeros(mesh.shape, bool) if groove is None else groove
    fixed = np.zeros(mesh.shape, bool) if fixed is None else fixed
    if q_supply and groove.any():
        # Eq. 4: Qs / Ng per groove volume; with refined columns, in proportion to each volume's area
        area = np.where(groove, mesh.cell_area, 0.0)
        source = q_supply * area / (area.sum() * mesh.mirror_factor) / flux_ref
    coef = build_coefficients(mesh, H, H_e, sq, source)
    p_ref = 6.0 * viscosity * U * mesh.radius / clearance**2
    edge_n = coef.aN[-1] if not mesh.half else np.zeros(mesh.n_circ)
    return FilmProblem(
        mesh=mesh, coef=coef, fixed=fixed, groove=groove, edge_s=coef.aS[0].copy(),
        edge_n=np.array(edge_n, copy=True), H=H, H_e=H_e, sq=sq, p_ref=p_ref, flux_ref=flux_ref,
        omega=omega, clearance=clearance, viscosity=viscosity,
    )


def edge_leakage(problem: FilmProblem, P) -> tuple[float, float]:
    """Oil leaving through the z = 0 and z = L film edges (m^3/s), Poiseuille only (Eq. 5)."""
    out_0 = float(problem.edge_s @ P[0] * problem.flux_ref)
    out_l = out_0 if problem.mesh.half else float(problem.edge_n @ P[-1] * problem.flux_ref)
    return out_0, out_l


def side_leakage(problem: FilmProblem, P) -> float:
    """Oil leaving through both film edges (m^3/s)."""
    return sum(edge_leakage(problem, P))


def film_force(problem: FilmProblem, P) -> np.ndarray:
    """Film force on the journal [Fx, Fy] (N): the pressure pushes the journal away from the wall.

    The wall point at alpha lies in the direction n = (-sin alpha, cos alpha) from the centre, so
    F = -integral(p n dA) = (integral p sin alpha dA, -integral p cos alpha dA).
    """
    m = problem.mesh
    col = P.sum(axis=0) * (problem.p_ref * m.cell_area * m.mirror_factor)
    return np.array([col @ np.sin(m.alpha), -(col @ np.cos(m.alpha))])


def force_weights(problem: FilmProblem) -> np.ndarray:
    """(2, nz, n_circ) weights w with F = sum(w * P): the linear map from nondim pressure to force."""
    m = problem.mesh
    scale = problem.p_ref * m.cell_area * m.mirror_factor
    w = np.empty((2,) + m.shape)
    w[0] = scale * np.sin(m.alpha)
    w[1] = -scale * np.cos(m.alpha)
    return w


def max_film_angle(e_x: float, e_y: float) -> float:
    """Angle alpha of the thickest film, where a plain bearing is fed (0 when centred)."""
    if e_x == 0.0 and e_y == 0.0:
        return 0.0
    return math.atan2(e_x, -e_y) % (2.0 * math.pi)
