"""Whether the machine stays on the periodic orbit: the orbit's Floquet multipliers (Hill's method).

The harmonic balance (`orbit_balance`) finds a periodic orbit; it does not say that the machine stays on it. A
small disturbance d of the orbit obeys the rotor's equations with the films' tangents along the orbit, whose
coefficients have the period T = 2 pi / Omega:

    M d'' + (C + Omega G) d' + K d = L^T [P(t) d_b + V(t) d_b'],   P = dF/dq + K0, V = dF/dv + C0

(K, C hold the bearings' K0, C0, as in the balance; F is the film force, its tangent taken with the cavitation
pattern held, `film.linearize.force_jacobian`). By Floquet's theorem the solutions are e^{st} p(t) with p
periodic; the multiplier e^{sT} per revolution says whether a disturbance grows. Hill's method writes p as
harmonics. With whole orders m Omega it finds the multipliers on the positive real axis (one above +1: a fold,
the machine leaves this orbit for another). With half orders (m + 1/2) Omega it finds those on the negative real
axis (one below -1: period doubling, a line at 0.5X grows). Condensed to the bearings (B(s): the rotor's
receptance there at s + i w_m), the condition is

    det(I - B(s) T(s)) = 0,   T_mk = P_(m-k) + V_(m-k) (s + i w_k)   (P_j, V_j: the tangents' harmonics)

a real function of real s (the orders come in conjugate pairs). Its real roots are found by a scan for sign
changes, then bisection; two roots closer than the scan's step leave a dip of |det| instead, scanned again finer
(`real_roots`).

Complex multipliers (a whirl riding on the orbit; one leaving the unit circle is a Neimark-Sacker bifurcation,
the motion becomes quasi-periodic with lines at nu and 1 - nu of the shaft speed) are searched from the modes of
the machine linearized at its equilibrium, where a small orbit's exponents tend: Newton's method on
log D(s), D = det(I - B T) prod_m det Z(s + i w_m) (Z the rotor's dynamic stiffness on K0, C0, so that D has no
poles and its zeros are the exponents), each zero found divided out before the next start (two modes' exponents
can lie within 1e-3 Omega of each other), `complex_roots`. A root the starts do not lead to is missed; the starts
are every mode with Re lambda above the scan's lower end, up to half the orders kept. The orders kept are those
the orbit's N points resolve (the tangents' harmonics up to N / 2 - 1).

Checked (tests/rotor/test_orbit_stability.py):
- against the monodromy matrix integrated over one period (a rotor with periodically modulated bearing
  stiffness and damping, the damped Mathieu problem on a Timoshenko shaft): the real multipliers agree to 1e-6,
  the complex ones to 1e-8;
- a small orbit on the films: its complex exponents tend to the equilibrium's eigenvalues (at 0.002 x the paper's
  unbalance within 1e-4 Omega);
- against the time integration on the films (`film_transient`) started on the balance's orbit, where the 0.5X
  line it leaves shows the multiplier near -1 at the paper's unbalance (BENCHMARKS "Stability of the orbit"):
  100 x 100 films, 460 / 600 ml/min: Hill -0.956 (16 harmonics), the time integration about -0.974; 60 x 40
  films at Q_T: Hill -0.988, the time integration -1.0035 over 32 revolutions (0.5X 0.36 -> 0.40 um). They
  differ by up to MARGIN, so a multiplier within MARGIN of 1 in size is reported as undecided.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError, InputError
from ..film.feed import Feed, setup_problem
from ..film.linearize import force_jacobian
from ..film.solver import solve
from .assembly import Rotor, bearing_matrices
from .elements import X, Y, node_dofs
from .film_bearings import FilmBearings
from .transient import linear_system

SCAN = (-0.2, 0.1)  # the real exponents scanned, relative to Omega (at 75 Hz: -94 ... +47 /s) ...
SCAN_POINTS = 121  # ... at this many points (a root is bracketed by a change of the determinant's sign)
DIP_POINTS = 41  # points of the finer scan over the two steps about a dip of |det| with no sign change
NEWTON_ITERATIONS = 40  # Newton steps on log D from each start (the linear system's eigenvalues) ...
NEWTON_TOL = 1e-10  # ... until the step is below this x Omega
MAX_STEP = 0.05  # a Newton step is at most this x Omega
START_ORDERS = 0.5  # the starts: the linear system's modes up to this fraction of the orders kept (x Omega)
DEDUP = 1e-5  # exponents closer than this x Omega are one; those this close to Im s = 0 or Omega / 2 are real
MARGIN = 0.03  # a multiplier's size within this of 1 is not decided: about twice what Hill at 16 harmonics and
# the time integration differed by at the paper's unbalance (the module's doc; BENCHMARKS "Stability of the orbit")


def _band(size: float) -> str:
    """A multiplier of this size a revolution: "unstable" beyond 1 + MARGIN, "undecided" within MARGIN of 1."""
    return "unstable" if size > 1 + MARGIN else "undecided" if size >= 1 - MARGIN else "stable"


@dataclass(frozen=True)
class OrbitStability:
    """The periodic orbit's real Floquet exponents s (1/s), largest first: for whole orders the multiplier is
    e^{sT} per revolution (positive), for half orders -e^{sT} (negative)."""

    omega: float
    half_order: tuple[float, ...]
    whole_order: tuple[float, ...]
    scanned: tuple[float, float]  # the range of s scanned (1/s)
    harmonics: int = 0  # of the orbit the tangents were taken along
    complex_order: tuple[complex, ...] = ()  # complex exponents, 0 < Im s < Omega / 2, largest real part first

    @property
    def complex_multiplier(self) -> float | None:
        """The size of the complex multiplier farthest out, e^{Re s T} (None: none found)."""
        return math.exp(self.complex_order[0].real * self.period) if self.complex_order else None

    @property
    def whirl_orders(self) -> tuple[float, float] | None:
        """The two lines (of the shaft speed) a disturbance of the farthest complex multiplier shows: Im s / Omega
        and 1 - that (a whirl riding on the 1X orbit shows both)."""
        if not self.complex_order:
            return None
        nu = self.complex_order[0].imag / self.omega
        return (nu, 1.0 - nu)

    @property
    def period(self) -> float:
        return 2 * math.pi / self.omega

    @property
    def half_order_multiplier(self) -> float | None:
        """The size of the negative multiplier farthest out, e^{sT} of the largest half-order exponent (None:
        none in the scan)."""
        return math.exp(self.half_order[0] * self.period) if self.half_order else None

    @property
    def whole_order_multiplier(self) -> float | None:
        return math.exp(self.whole_order[0] * self.period) if self.whole_order else None

    @property
    def state(self) -> str:
        """"stable", "undecided" (a multiplier within MARGIN of 1 in size) or "unstable"."""
        bands = {_band(mu) for mu in (self.half_order_multiplier, self.whole_order_multiplier,
                                      self.complex_multiplier) if mu is not None}
        return next((b for b in ("unstable", "undecided") if b in bands), "stable")

    @property
    def unstable(self) -> bool:
        return self.state == "unstable"

    def describe(self) -> str:
        parts = []
        mu = self.half_order_multiplier
        if mu is not None:
            what = {"unstable": "period doubling: a line at 0.5X grows and the orbit doubles its period",
                    "undecided": "at the threshold of period doubling: a 0.5X line neither grows nor dies out over "
                                 f"tens of revolutions (within {100 * MARGIN:g} % of -1, the model cannot say which)",
                    "stable": "period doubling near: a 0.5X disturbance dies out slowly" if mu > 0.8 else
                              "a 0.5X disturbance dies out"}[_band(mu)]
            parts.append(f"multiplier -{mu:.3f} a revolution ({what})")
        mu = self.whole_order_multiplier
        if mu is not None:
            what = {"unstable": "the orbit is unstable: the machine leaves it for another",
                    "undecided": f"at the threshold of a jump to another orbit (within {100 * MARGIN:g} % of +1)",
                    "stable": "a slow disturbance dies out"}[_band(mu)]
            parts.append(f"multiplier +{mu:.3f} a revolution ({what})")
        mu = self.complex_multiplier
        if mu is not None and mu > 0.8:  # a whirl that dies out fast is not worth a line
            a, b = self.whirl_orders
            what = {"unstable": "a whirl riding on the orbit grows: the motion becomes quasi-periodic "
                                f"(lines at {a:.2f}X and {b:.2f}X)",
                    "undecided": f"at the threshold of a whirl riding on the orbit (lines at {a:.2f}X and {b:.2f}X; "
                                 f"within {100 * MARGIN:g} % of 1 in size, the model cannot say which)",
                    "stable": f"a whirl at {a:.2f}X and {b:.2f}X riding on the orbit dies out slowly"}[_band(mu)]
            parts.append(f"complex multiplier of size {mu:.3f} a revolution ({what})")
        if not parts:
            lo, hi = (math.exp(s * self.period) for s in self.scanned)
            return (f"no real multiplier of size {lo:.2f}-{hi:.2f} a revolution and no complex one above 0.8: no "
                    "period doubling, jump or whirl near this orbit")
        return "; ".join(parts)

    def summary(self) -> dict:
        """JSON-ready."""
        return {"state": self.state, "text": self.describe(),
                "half_order_multiplier": None if self.half_order_multiplier is None else -self.half_order_multiplier,
                "whole_order_multiplier": self.whole_order_multiplier,
                "half_order_exponents_per_s": list(self.half_order), "whole_order_exponents_per_s":
                list(self.whole_order), "complex_multiplier": self.complex_multiplier,
                "whirl_orders": None if self.whirl_orders is None else list(self.whirl_orders),
                "complex_exponents_per_s": [[z.real, z.imag] for z in self.complex_order],
                "harmonics": self.harmonics, "margin": MARGIN}


def orbit_tangents(orbit, bearings: FilmBearings) -> tuple[np.ndarray, np.ndarray]:
    """P(t), V(t) (n_bearings, N, 2, 2) along `orbit` (an `OrbitBalance` that carries its films): each film
    re-solved at its phase point (warm from the balance's own), its tangent with the pattern held, plus K0, C0."""
    if orbit.films is None:
        raise InputError("orbit stability: the orbit carries no films")
    eqs = bearings.equilibria
    n_pts = len(orbit.films[0])
    omega = orbit.omega
    E = np.exp(1j * np.outer(np.arange(orbit.harmonics + 1), 2 * math.pi * np.arange(n_pts) / n_pts))
    qb = orbit.journal_harmonics
    q_t = np.real(qb.T @ E)
    v_t = np.real((qb * (1j * omega * np.arange(orbit.harmonics + 1))[:, None]).T @ E)
    P = np.zeros((len(eqs), n_pts, 2, 2))
    V = np.zeros_like(P)
    for j, e in enumerate(eqs):
        sl = slice(2 * j, 2 * j + 2)
        for k in range(n_pts):
            problem = setup_problem(e.bearing, omega, e.position + q_t[sl, k], Feed.flow(bearings.flows[j]),
                                    velocity=v_t[sl, k])
            sol = solve(problem, warm=orbit.films[j][k])
            if not sol.converged or sol.linear is None:
                raise ConvergenceError(f"orbit stability: film {j + 1} at phase {360 * k / n_pts:.0f} deg has no "
                                       "tangent (its active-set solve did not settle)")
            dF = force_jacobian(sol)
            P[j, k] = dF[:, :2] + e.coefficients.K
            V[j, k] = dF[:, 2:] + e.coefficients.C
    return P, V


def hill_determinant(rotor: Rotor, coefficients, omega: float, P: np.ndarray, V: np.ndarray, *, half: bool,
                     entire: bool = False):
    """s -> (sign, log|det|) of I - B(s) T(s) for `rotor` on bearings of `coefficients` (K0, C0 per bearing, as
    `bearing_matrices` takes them) with the periodic bearing terms P(t), V(t) (n_bearings, N, 2, 2) sampled at N
    equal steps of a revolution, over the orders those points resolve: half orders (m + 1/2) Omega or whole ones
    m Omega. Real for real s (the sign is +-1 then). `entire`: times prod_m det Z(s + i w_m) (Z the rotor's
    dynamic stiffness on K0, C0), so that it has no poles (B has them at the linear system's eigenvalues, which
    a complex exponent of a small orbit lies next to): its zeros are the exponents, for complex s too."""
    nb, n_pts = P.shape[:2]
    if P.shape != (len(rotor.bearing_nodes), n_pts, 2, 2) or V.shape != P.shape:
        raise InputError(f"hill_determinant: P, V of shape {P.shape}, {V.shape}; expected "
                         f"({len(rotor.bearing_nodes)}, N, 2, 2) each")
    K = (n_pts // 2 - 1) // 2  # orders up to K + 1/2 (or K): their differences' harmonics stay below N / 2
    ms = np.arange(-(K + 1), K + 1) + 0.5 if half else np.arange(-K, K + 1).astype(float)
    w = ms * omega
    J = int(round(ms[-1] - ms[0]))
    js = np.arange(-J, J + 1)
    Ej = np.exp(-1j * np.outer(js, 2 * math.pi * np.arange(n_pts) / n_pts)) / n_pts
    d = 2 * nb
    Ph = np.zeros((len(js), d, d), complex)
    Vh = np.zeros_like(Ph)
    for b in range(nb):
        Ph[:, 2 * b:2 * b + 2, 2 * b:2 * b + 2] = np.einsum("jn,nab->jab", Ej, P[b])
        Vh[:, 2 * b:2 * b + 2, 2 * b:2 * b + 2] = np.einsum("jn,nab->jab", Ej, V[b])
    Kt, Ct = bearing_matrices(rotor, coefficients)
    Lb = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes]).ravel()
    unit = np.eye(rotor.n_dof)[:, Lb]
    damping = Ct + omega * rotor.G
    diff = np.rint(ms[:, None] - ms[None, :]).astype(int) + J  # index of P_(m-k)
    n = len(ms) * d

    def det(s):
        lam = s + 1j * w
        Z = [Kt + v * damping + v * v * rotor.M for v in lam]
        B = np.array([np.linalg.solve(z, unit)[Lb] for z in Z])  # (n_m, d, d)
        T = Ph[diff] + Vh[diff] * lam[None, :, None, None]  # (n_m, n_m, d, d): row m, column k
        sign, logdet = np.linalg.slogdet(np.eye(n, dtype=complex) - np.einsum("mab,mkbc->makc", B, T).reshape(n, n))
        if entire:  # times prod_m det Z(s + i w_m): the poles of B cancel, the exponents are its only zeros
            for z in Z:
                sz, lz = np.linalg.slogdet(z)
                sign, logdet = sign * sz, logdet + lz
        return sign, logdet

    return det


def real_roots(det, lo: float, hi: float, points: int = SCAN_POINTS) -> tuple[float, ...]:
    """The real s in [lo, hi] where `det` (s -> (sign, log|det|), real) changes sign, largest first.

    A sign change between the scan's points is bisected. Two roots closer than the scan's step leave no sign
    change, only a dip of |det|: at each point where log|det| has a local minimum with no sign change on either
    side, the two steps about it are scanned again at DIP_POINTS points (a locked pair of multipliers just past
    the tongue's edge, 0.002 Omega apart, against a step of 0.0025 Omega; between them |det| rises again, so the
    dip is no minimum to follow). Pairs closer than that finer step are still missed."""
    from scipy.optimize import brentq

    grid = np.linspace(lo, hi, points)
    vals = [det(s) for s in grid]
    ref = float(np.median([v[1] for v in vals]))

    def real(s):
        sign, logdet = det(s)
        return float(np.real(sign)) * math.exp(min(logdet - ref, 700.0))

    xtol = 1e-9 * (hi - lo)
    signs = np.sign([np.real(v[0]) for v in vals])
    logs = np.array([v[1] for v in vals])
    roots = [brentq(real, a, b, xtol=xtol)
             for a, b, sa, sb in zip(grid, grid[1:], signs, signs[1:]) if sa * sb < 0]
    for i in range(1, points - 1):
        if not (logs[i] < logs[i - 1] and logs[i] < logs[i + 1] and signs[i - 1] == signs[i] == signs[i + 1]):
            continue
        fine = np.linspace(grid[i - 1], grid[i + 1], DIP_POINTS)  # a finer scan between the neighbours
        vf = [real(s) for s in fine]
        roots += [brentq(real, a, b, xtol=xtol) for a, b, fa, fb in zip(fine, fine[1:], vf, vf[1:]) if fa * fb < 0]
    return tuple(sorted(roots, reverse=True))


def complex_roots(det, starts, omega: float, lo: float, hi: float, *, tol: float = NEWTON_TOL,
                  iterations: int = NEWTON_ITERATIONS) -> tuple[complex, ...]:
    """The complex exponents s (Re s in [lo, hi]) reached by Newton's method on log D(s) from each of `starts`,
    where `det` is s -> (sign, log|D|) of an entire D (`hill_determinant(..., entire=True)`, whole orders):
    s <- s - 1 / (log D)'(s), the derivative a central difference. Each answer is brought into the strip
    0 <= Im s <= Omega / 2 (an exponent is one modulo i Omega, and its conjugate is one too); those on its edges
    (within `tol` x Omega of Im s = 0 or Omega / 2: the real multipliers, `real_roots`) and duplicates are left
    out. Largest real part first."""
    found: list[complex] = []
    deflate: list[complex] = []
    for s0 in starts:
        s = complex(s0)
        s -= 1j * omega * round(s.imag / omega)  # into |Im s| <= Omega / 2, where the orders kept are centred
        converged = False
        h = 1e-7 * omega
        for _ in range(iterations):
            (sp, lp), (sm, lm) = det(s + h), det(s - h)
            dlog = (lp - lm + 1j * np.angle(sp / sm)) / (2 * h)
            dlog -= sum(1.0 / (s - r) for r in deflate)  # the zeros found already divided out
            if not np.isfinite(dlog) or dlog == 0:
                break
            step = 1.0 / dlog
            if abs(step) > MAX_STEP * omega:  # far from a zero: a bounded step along the descent
                step *= MAX_STEP * omega / abs(step)
            s -= step
            h = min(h, 1e-3 * abs(step))  # the difference well inside the distance to the zero
            if abs(step) < tol * omega:
                converged = True
                break
        if not converged:
            continue
        # two modes' exponents can lie within a few 1e-3 Omega of each other: from the second one's start Newton's
        # method would go to the first's, so each zero found is divided out of D, with its conjugate and their
        # copies one order away
        deflate += [z + 1j * m * omega for z in (s, s.conjugate()) for m in (-1, 0, 1)]
        nu = abs((s.imag + omega / 2) % omega - omega / 2)  # into 0 .. Omega / 2
        r = complex(s.real, nu)
        edge = nu < DEDUP * omega or nu > (0.5 - DEDUP) * omega
        if edge or not lo <= r.real <= hi or any(abs(r - f) < DEDUP * omega for f in found):
            continue
        found.append(r)
    return tuple(sorted(found, key=lambda z: -z.real))


def floquet_exponents(rotor: Rotor, coefficients, omega: float, P: np.ndarray, V: np.ndarray, *,
                      scan: tuple[float, float] = SCAN, points: int = SCAN_POINTS,
                      harmonics: int = 0) -> OrbitStability:
    """The real Floquet exponents within `scan` x `omega` of the rotor on bearings K0, C0 (`coefficients`) plus
    the periodic terms P(t), V(t) (see `hill_determinant`)."""
    lo, hi = scan[0] * omega, scan[1] * omega
    # the entire determinant (the receptance's poles cancelled): between two close roots it dips through zero
    # instead of passing a pole, so the dip is found (`real_roots`)
    half = real_roots(hill_determinant(rotor, coefficients, omega, P, V, half=True, entire=True), lo, hi, points)
    whole = real_roots(hill_determinant(rotor, coefficients, omega, P, V, half=False, entire=True), lo, hi, points)
    orders = (P.shape[1] // 2 - 1) // 2  # as hill_determinant keeps them
    lam = linear_system(rotor, omega, coefficients).eigenvalues
    starts = lam[(lam.real > lo) & (lam.imag > 0) & (lam.imag <= START_ORDERS * orders * omega)]
    cplx = complex_roots(hill_determinant(rotor, coefficients, omega, P, V, half=False, entire=True),
                         sorted(starts, key=lambda z: -z.real), omega, lo, math.inf)
    return OrbitStability(omega=omega, half_order=half, whole_order=whole, scanned=(lo, hi), harmonics=harmonics,
                          complex_order=cplx)


def orbit_stability(rotor: Rotor, bearings: FilmBearings, orbit, *, scan: tuple[float, float] = SCAN,
                    points: int = SCAN_POINTS) -> OrbitStability:
    """The real Floquet exponents of `orbit` (an `OrbitBalance` of `rotor` on `bearings`' films) within `scan` x
    Omega: the films re-solved along the orbit (one solve per point and bearing), then Hill's determinant for
    half and whole orders."""
    rotor.require_films_on_ground("the orbit's Floquet stability")
    if abs(orbit.omega - bearings.omega) > 1e-9 * orbit.omega:
        raise InputError("orbit stability: the orbit and the films have another speed")
    P, V = orbit_tangents(orbit, bearings)
    return floquet_exponents(rotor, bearings.coefficients, orbit.omega, P, V, scan=scan, points=points,
                             harmonics=orbit.harmonics)


__all__ = ["MARGIN", "OrbitStability", "complex_roots", "floquet_exponents", "hill_determinant", "orbit_stability", "orbit_tangents",
           "real_roots"]
