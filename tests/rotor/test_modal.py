"""Natural frequencies against beam theory, the gyroscopic split against the rigid-disc solution."""

import math

import numpy as np
import pytest
import scipy.linalg

from lubeviz.errors import InputError
from lubeviz.rotor import (RigidDisc, TimoshenkoBeam, assemble, campbell, cowper_shear_coefficient, isotropic,
                           modal_analysis, node_dofs, rotor_from_machine)

E, NU, RHO = 210e9, 0.3, 7850.0
G_SHEAR = E / (2 * (1 + NU))
PINNED = 1e12  # N/m, effectively rigid for the shafts below


def _uniform_shaft(L, D, n_el, shear=True):
    beams = [TimoshenkoBeam(k, L / n_el, D, E, NU, RHO, shear=shear) for k in range(1, n_el + 1)]
    return assemble(beams, bearing_nodes=[1, n_el + 1])


def _euler_bernoulli_ss(L, D, n):
    A, I = math.pi * D**2 / 4, math.pi * D**4 / 64
    return (n * math.pi / L) ** 2 * math.sqrt(E * I / (RHO * A))


def _timoshenko_ss(L, D, n):
    """Lowest root of the Timoshenko simply supported frequency equation for mode n (rad/s):
    w = W sin(kz), psi = P cos(kz), k = n pi / L in
      kGA (w'' - psi') + rho A w_tt = 0,  EI psi'' + kGA (w' - psi) - rho I psi_tt = 0
    gives (rho A w^2 - kGA k^2)(rho I w^2 - EI k^2 - kGA) = (kGA k)^2, a quadratic in w^2."""
    A, I = math.pi * D**2 / 4, math.pi * D**4 / 64
    kGA = cowper_shear_coefficient(NU) * G_SHEAR * A
    k = n * math.pi / L
    a = RHO * A * RHO * I
    b = -(RHO * A * (E * I * k**2 + kGA) + RHO * I * kGA * k**2)
    c = kGA * k**2 * (E * I * k**2 + kGA) - (kGA * k) ** 2
    return math.sqrt((-b - math.sqrt(b * b - 4 * a * c)) / (2 * a))


def _distinct(freqs, n):
    """Every lateral frequency comes twice (X and Y planes) at zero speed: take one of each pair."""
    return np.asarray(freqs)[: 2 * n : 2]


def test_slender_simply_supported_shaft_matches_euler_bernoulli():
    L, D = 2.0, 0.02  # L/D = 100
    rotor = _uniform_shaft(L, D, 20)
    res = modal_analysis(rotor, 0.0, [isotropic(PINNED)] * 2, n_modes=6)
    expected = [_euler_bernoulli_ss(L, D, n) for n in (1, 2, 3)]
    np.testing.assert_allclose(_distinct(res.natural_frequencies, 3), expected, rtol=5e-3)


def test_stubby_simply_supported_shaft_matches_timoshenko_theory():
    L, D = 0.5, 0.1  # L/D = 5: shear and rotary inertia lower mode 1 by ~5 %
    rotor = _uniform_shaft(L, D, 20)
    res = modal_analysis(rotor, 0.0, [isotropic(PINNED * 1e3)] * 2, n_modes=6)
    got = _distinct(res.natural_frequencies, 3)
    expected = [_timoshenko_ss(L, D, n) for n in (1, 2, 3)]
    np.testing.assert_allclose(got, expected, rtol=5e-3)
    euler = [_euler_bernoulli_ss(L, D, n) for n in (1, 2, 3)]
    assert np.all(got < 0.97 * np.array(euler))  # the element really carries shear + rotary inertia
    rayleigh = modal_analysis(_uniform_shaft(L, D, 20, shear=False), 0.0, [isotropic(PINNED * 1e3)] * 2,
                              n_modes=2).natural_frequencies[0]
    assert rayleigh > 1.02 * expected[0]


def _disc_on_stiff_shaft(a, k, disc):
    """Rigid disc in the middle of a stiff, nearly massless shaft of length 2a on two bearings k."""
    beams = [TimoshenkoBeam(n, a, 0.05, E * 1e4, NU, RHO * 1e-6) for n in (1, 2)]
    rotor = assemble(beams, [disc], bearing_nodes=[1, 3])
    return rotor, [isotropic(k)] * 2


def test_rigid_disc_gyroscopic_split_matches_analytic():
    # Cylindrical mode: w = sqrt(2k/m), speed independent. Conical mode (k_theta = 2 k a^2):
    # Id w^2 -/+ Ip Omega w - k_theta = 0 -> forward w_f = (Ip O + sqrt((Ip O)^2 + 4 Id kt)) / (2 Id).
    a, k = 0.3, 1e6
    disc = RigidDisc.annular(2, 0.05, 0.6, 0.05, RHO)
    rotor, bearings = _disc_on_stiff_shaft(a, k, disc)
    m, Id, Ip = disc.mass, disc.diametral_inertia, disc.polar_inertia
    kt = 2 * k * a**2
    w_cyl = math.sqrt(2 * k / m)
    for omega in (0.0, 100.0, 400.0, 1000.0):
        res = modal_analysis(rotor, omega, bearings, n_modes=4)
        root = math.sqrt((Ip * omega) ** 2 + 4 * Id * kt)
        w_f, w_b = (Ip * omega + root) / (2 * Id), (-Ip * omega + root) / (2 * Id)
        got = res.natural_frequencies
        for w in (w_cyl, w_cyl, w_f, w_b):
            assert np.min(np.abs(got - w) / w) < 2e-4, (omega, w, got)
        if omega > 0:
            f_idx = np.argmin(np.abs(got - w_f))
            b_idx = np.argmin(np.abs(got - w_b))
            assert res.whirl[f_idx] == "forward" and res.whirl[b_idx] == "backward"


def test_free_disc_nutation_is_ip_over_id_times_speed():
    # A disc whose tilt is unrestrained (one soft bearing at its own node) nutates forward at
    # Ip/Id * Omega; its precession root is zero.
    disc = RigidDisc.annular(1, 0.05, 0.6, 0.05, RHO)
    rotor = assemble([TimoshenkoBeam(1, 0.01, 0.02, E, NU, RHO * 1e-6)], [disc], bearing_nodes=[1])
    omega = 300.0
    res = modal_analysis(rotor, omega, [isotropic(1e3)], n_modes=8)
    nutation = disc.polar_inertia / disc.diametral_inertia * omega
    i = np.argmin(np.abs(res.natural_frequencies - nutation))
    assert res.natural_frequencies[i] == pytest.approx(nutation, rel=1e-3)
    assert res.whirl[i] == "forward"


@pytest.fixture(scope="module")
def paper_rotor(machine):
    return rotor_from_machine(machine)


def test_stiff_bearings_give_a_stable_nearly_pinned_rotor(paper_rotor):
    rotor = paper_rotor
    # reference: the rotor with x = y = 0 at the bearing nodes, undamped, at rest
    fixed = np.concatenate([node_dofs(n)[:2] for n in rotor.bearing_nodes])
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    w2 = scipy.linalg.eigh(rotor.K[np.ix_(free, free)], rotor.M[np.ix_(free, free)], eigvals_only=True)
    pinned = np.sqrt(w2[:4:2])
    res0 = modal_analysis(rotor, 0.0, [isotropic(1e12)] * 2, n_modes=4)
    np.testing.assert_allclose(_distinct(res0.natural_frequencies, 2), pinned, rtol=1e-3)
    res = modal_analysis(rotor, 2 * math.pi * 75.0, [isotropic(1e12)] * 2, n_modes=12)
    assert res.stable and np.all(res.damping_ratios > 0)
    assert abs(res.natural_frequencies[0] / pinned[0] - 1) < 0.05  # gyroscopic shift only
    # forward branch above backward branch in the first pair
    assert res.whirl[:2] == ("backward", "forward")


def test_negative_bearing_stiffness_is_reported_unstable(paper_rotor):
    res = modal_analysis(paper_rotor, 2 * math.pi * 75.0, [isotropic(-1e7)] * 2, n_modes=4)
    assert not res.stable


def test_campbell_follows_the_analytic_disc():
    a, k = 0.3, 1e6
    disc = RigidDisc.annular(2, 0.05, 0.6, 0.05, RHO)
    rotor, bearings = _disc_on_stiff_shaft(a, k, disc)
    speeds = np.linspace(0.0, 800.0, 5)
    res = campbell(rotor, speeds, lambda w: bearings, n_modes=4)
    assert res.damped_frequencies.shape == (5, 4)
    Id, Ip, kt = disc.diametral_inertia, disc.polar_inertia, 2 * k * a**2
    w_f = (Ip * speeds + np.sqrt((Ip * speeds) ** 2 + 4 * Id * kt)) / (2 * Id)
    top = np.nanmax(res.natural_frequencies, axis=1)
    np.testing.assert_allclose(top, w_f, rtol=2e-4)


def test_modal_rejects_stacked_coefficients(paper_rotor):
    with pytest.raises(InputError, match="stacked"):
        modal_analysis(paper_rotor, 100.0, [(np.zeros((3, 2, 2)), np.zeros((2, 2)))] * 2)
