"""The periodic orbit's Floquet multipliers (`rotor.orbit_stability`, Hill's method).

Against an independent reference: the monodromy matrix of the same linear periodic system integrated over one
period (scipy's DOP853), on a short Timoshenko shaft whose bearing stiffness and damping are modulated at the
shaft speed (the damped Mathieu problem): near twice a mode's frequency its multipliers lock onto the negative
real axis (period doubling, one case past -1), near the mode's frequency onto the positive one. Then on the films:
at the paper's unbalance the half-order multiplier lies within MARGIN of -1, where the time integration on the
same films found -1.0035 (40 revolutions, BENCHMARKS "Stability of the orbit"), and a small orbit is stable.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from lubeviz.rotor.assembly import assemble, bearing_matrices
from lubeviz.rotor.elements import RigidDisc, TimoshenkoBeam, X, Y, node_dofs
from lubeviz.rotor.orbit_stability import MARGIN, floquet_exponents, hill_determinant

K0 = 1e7  # N/m, the bearings' x stiffness (y: twice): the bounce modes at 116 Hz (x) and 164 Hz (y)


def _shaft():
    return assemble([TimoshenkoBeam(1, 0.5, 0.1, 2.1e11, 0.3, 7850.0)], [RigidDisc(1, 5.0, 0.02, 0.03)],
                    bearing_nodes=(1, 2))


def _terms(omega, eps, c0):
    """P(t), V(t) of both bearings: the x stiffness modulated at 1X (bearing 2 at 0.7 of it, shifted), a little
    y and a 2X cross-coupled part, and a damping modulation."""
    xm, skew = np.diag([1.0, 0.2]), np.array([[0.0, 1.0], [-1.0, 0.0]])

    def P(t):
        return np.array([eps * K0 * (math.cos(omega * t) * xm + 0.1 * math.sin(2 * omega * t) * skew),
                         eps * K0 * 0.7 * math.cos(omega * t + 0.4) * xm])

    def V(t):
        return np.array([0.3 * eps * c0 * math.sin(omega * t) * np.eye(2)] * 2)

    return P, V


def _monodromy_multipliers(rotor, coefficients, omega, P, V, *, complex_ones: bool = False):
    """The real multipliers of x' = A(t) x over one period, A from the rotor's M, C + Omega G, K and the terms
    (`complex_ones`: all of them, complex)."""
    n = rotor.n_dof
    Kt, Ct = bearing_matrices(rotor, coefficients)
    D = Ct + omega * rotor.G
    Lb = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes])
    Minv = np.linalg.inv(rotor.M)

    def A(t):
        Pb, Vb = np.zeros((n, n)), np.zeros((n, n))
        for b, (p, v) in enumerate(zip(P(t), V(t))):
            Pb[np.ix_(Lb[b], Lb[b])], Vb[np.ix_(Lb[b], Lb[b])] = p, v
        return np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ (Kt - Pb), -Minv @ (D - Vb)]])

    T = 2 * math.pi / omega
    sol = solve_ivp(lambda t, z: (A(t) @ z.reshape(2 * n, 2 * n)).ravel(), (0.0, T), np.eye(2 * n).ravel(),
                    method="DOP853", rtol=1e-11, atol=1e-14)
    mu = np.linalg.eigvals(sol.y[:, -1].reshape(2 * n, 2 * n))
    if complex_ones:
        return mu
    real = mu[np.abs(mu.imag) < 1e-7 * np.abs(mu)].real
    return np.sort(real[np.abs(real) > math.exp(-0.2 * 2 * math.pi)])  # those of the scan's range


@pytest.mark.parametrize("speed_hz, eps, c0, state", [
    (232.4, 0.10, 200.0, "unstable"),  # 2 x the x bounce mode: period doubling (-1.048)
    (232.4, 0.03, 600.0, "stable"),  # locked on the negative axis but damped (-0.953)
    (116.3, 0.30, 200.0, "undecided"),  # at the mode: a positive multiplier at +1.0003
    (232.4, 0.011, 200.0, "undecided"),  # just past the tongue's edge: -0.984 and -0.971, 0.0021 Omega apart in s,
    # closer than the scan's step (found in the dip of |det| between the two scan points about them)
])
def test_hill_gives_the_multipliers_of_the_monodromy_matrix(speed_hz, eps, c0, state):
    rotor = _shaft()
    omega = 2 * math.pi * speed_hz
    coefficients = [(np.diag([K0, 2 * K0]), c0 * np.eye(2))] * 2
    P, V = _terms(omega, eps, c0)
    ref = _monodromy_multipliers(rotor, coefficients, omega, P, V)
    assert len(ref) == 2  # the case has a locked pair on the real axis, in the scan's range
    phase = 2 * math.pi * np.arange(32) / 32 / omega
    Ps, Vs = np.stack([P(t) for t in phase], axis=1), np.stack([V(t) for t in phase], axis=1)
    st = floquet_exponents(rotor, coefficients, omega, Ps, Vs)
    T = st.period
    hill = np.sort([-math.exp(s * T) for s in st.half_order] + [math.exp(s * T) for s in st.whole_order])
    np.testing.assert_allclose(hill, ref, rtol=1e-6)
    assert st.state == state
    assert (st.half_order != ()) == (ref[0] < 0)


@pytest.mark.parametrize("speed_hz, eps, c0, points, found", [
    (232.4, 0.10, 200.0, 32, 3),  # the 116 / 164 Hz modes locked: three complex pairs left in the range
    (232.4, 0.10, 200.0, 64, 5),  # more orders kept: the 6.3 / 6.8 Omega bending pair too
    (116.3, 0.30, 200.0, 64, 3),  # two exponents 0.004 Omega apart (found only with the first divided out)
    (150.0, 0.60, 300.0, 32, 4),  # no mode locked: every start gives its own
])
def test_hill_gives_the_complex_multipliers_of_the_monodromy_matrix(speed_hz, eps, c0, points, found):
    """Each complex multiplier Hill's method finds is one of the monodromy matrix's (to 1e-8), one per mode started
    that is not locked onto the real axis, and none twice."""
    rotor = _shaft()
    omega = 2 * math.pi * speed_hz
    coefficients = [(np.diag([K0, 2 * K0]), c0 * np.eye(2))] * 2
    P, V = _terms(omega, eps, c0)
    ref = _monodromy_multipliers(rotor, coefficients, omega, P, V, complex_ones=True)
    phase = 2 * math.pi * np.arange(points) / points / omega
    Ps, Vs = np.stack([P(t) for t in phase], axis=1), np.stack([V(t) for t in phase], axis=1)
    st = floquet_exponents(rotor, coefficients, omega, Ps, Vs)
    mu = np.exp(np.array(st.complex_order) * st.period)
    assert len(mu) == found
    assert all(abs(m - ref).min() < 1e-8 for m in mu)
    assert all(0 < z.imag < omega / 2 for z in st.complex_order)
    assert len({round(m.real, 6) + 1j * round(m.imag, 6) for m in mu}) == found
    assert st.complex_multiplier == pytest.approx(max(abs(mu)), rel=1e-12)
    nu = st.complex_order[0].imag / omega
    assert st.whirl_orders == pytest.approx((nu, 1 - nu))


def test_the_determinant_is_real_for_real_exponents_and_takes_matching_shapes():
    rotor = _shaft()
    omega = 2 * math.pi * 232.4
    coefficients = [(np.diag([K0, 2 * K0]), 200.0 * np.eye(2))] * 2
    P, V = _terms(omega, 0.1, 200.0)
    phase = 2 * math.pi * np.arange(32) / 32 / omega
    Ps, Vs = np.stack([P(t) for t in phase], axis=1), np.stack([V(t) for t in phase], axis=1)
    for half in (True, False):
        sign, _ = hill_determinant(rotor, coefficients, omega, Ps, Vs, half=half)(-3.0)
        assert abs(sign.imag) < 1e-9 and abs(abs(sign.real) - 1) < 1e-9
    from lubeviz.errors import InputError

    with pytest.raises(InputError, match="expected \\(2, N, 2, 2\\)"):
        hill_determinant(rotor, coefficients, omega, Ps[:1], Vs[:1], half=True)


@pytest.fixture(scope="module")
def films_60x40():
    from lubeviz.model.machine import load_machine
    from lubeviz.rotor import rotor_from_machine
    from lubeviz.rotor.film_bearings import film_bearings, flooded_thresholds

    m = load_machine()
    m.bearings = [b.copy(n_circumferential=60, n_axial=40) for b in m.bearings]
    return m, rotor_from_machine(m), film_bearings(m, list(flooded_thresholds(m)), coefficients="fixed-pattern")


@pytest.mark.parametrize("scale, state, size", [(1.0, "undecided", (0.97, 1.03)), (0.4, "stable", (0.4, 0.8))])
def test_on_the_films_the_paper_s_unbalance_is_at_the_threshold_of_period_doubling(films_60x40, scale, state,
                                                                                    size):
    """60 x 40 films at Q_T, 75 Hz, 5 harmonics: at the paper's unbalance the half-order multiplier lies within
    MARGIN of -1 (5 harmonics -1.019, 16 harmonics -0.988; the time integration on these films over 40
    revolutions -1.0035: the 0.5X line from 0.36 to 0.40 um), so the state is undecided; at 0.4 x it is stable
    (5 harmonics -0.583, 16 harmonics -0.603)."""
    from lubeviz.rotor.orbit_balance import orbit_balance
    from lubeviz.rotor.orbit_stability import orbit_stability
    from lubeviz.rotor.response import machine_unbalance

    m, rotor, fb = films_60x40
    ub = [dataclasses.replace(u, moment=u.moment * scale) for u in machine_unbalance(m)]
    ob = orbit_balance(rotor, fb, ub, tol=1e-8)
    st = orbit_stability(rotor, fb, ob)
    assert st.state == state
    assert size[0] < st.half_order_multiplier < size[1]
    assert st.whole_order == ()  # no jump to another orbit near
    summary = st.summary()
    assert summary["half_order_multiplier"] == pytest.approx(-st.half_order_multiplier)
    assert summary["state"] == state and "0.5X" in summary["text"]
    assert st.complex_multiplier < 1 - MARGIN  # a whirl riding on the orbit dies out (0.82 at 0.4 x, 0.62 at 1 x)
    assert len(summary["complex_exponents_per_s"]) == len(st.complex_order) >= 1


def test_a_small_orbit_s_complex_exponents_are_the_equilibrium_s_modes(films_60x40):
    """The analytic limit: as the orbit shrinks, the films' tangents along it tend to the equilibrium's K0, C0
    (fixed pattern), so its Floquet exponents tend to the eigenvalues of the machine linearized there, brought
    into 0 < Im s < Omega / 2 (the whirl modes at 0.61 and 0.74 Omega show at 0.39 and 0.26). At 0.002 x the
    paper's unbalance they agree within 1e-4 Omega (at 0.05 x the first is 0.003 Omega off in its real part: the
    orbit damps it)."""
    from lubeviz.rotor.orbit_balance import orbit_balance
    from lubeviz.rotor.orbit_stability import orbit_stability
    from lubeviz.rotor.response import machine_unbalance
    from lubeviz.rotor.transient import linear_system

    m, rotor, fb = films_60x40
    ub = [dataclasses.replace(u, moment=u.moment * 0.002) for u in machine_unbalance(m)]
    st = orbit_stability(rotor, fb, orbit_balance(rotor, fb, ub, tol=1e-8))
    omega = fb.omega
    lam = linear_system(rotor, omega, fb.coefficients).eigenvalues
    lam = lam[(lam.imag > 0) & (lam.real > -0.2 * omega)]
    assert len(lam) == 2
    modes = np.array([complex(z.real, abs((z.imag + omega / 2) % omega - omega / 2)) for z in lam])
    assert len(st.complex_order) == 2
    for z in st.complex_order:
        assert abs(z - modes).min() < 1e-4 * omega
    assert st.state == "stable" and st.half_order == () and st.whole_order == ()
    assert st.complex_multiplier == pytest.approx(math.exp(max(modes.real) * st.period), rel=1e-3)
    assert "0.39X and 0.61X" in st.describe()
