"""Steady unbalance response: Jeffcott limit, full-spectrum features, invariances, DFT of the orbit."""

import math

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.rotor import (RigidDisc, TimoshenkoBeam, Unbalance, assemble, forward_backward_ratio, isotropic,
                           machine_unbalance, orbit_angle, rotor_from_machine, unbalance_force, unbalance_response,
                           unbalance_sweep)

E, NU, RHO = 210e9, 0.3, 7850.0
OMEGA = 2 * math.pi * 75.0
# cross-coupled, anisotropic bearings of the size a journal bearing of the paper gives at 75 Hz
K_BRG = np.array([[1.2e8, 0.6e8], [-1.5e8, 2.5e8]])
C_BRG = np.array([[3.0e5, 0.4e5], [0.4e5, 6.0e5]])


@pytest.fixture(scope="module")
def paper_rotor(machine):
    return rotor_from_machine(machine)


def test_unbalance_force_turns_with_the_shaft():
    # Eq. 9: Fx = m_u O^2 cos(O t + p), Fy = m_u O^2 sin(O t + p); F(t) = Re(F e^{i O t})
    rotor = assemble([TimoshenkoBeam(1, 0.1, 0.05, E, NU, RHO)])
    mu, p, om = 2e-3, 0.7, 300.0
    F = unbalance_force(rotor, om, [Unbalance(2, mu, p)])[4:6]
    t = np.linspace(0, 0.05, 17)
    ft = np.real(F[:, None] * np.exp(1j * om * t))
    np.testing.assert_allclose(ft[0], mu * om**2 * np.cos(om * t + p), atol=1e-12)
    np.testing.assert_allclose(ft[1], mu * om**2 * np.sin(om * t + p), atol=1e-12)


def test_rigid_disc_on_damped_bearings_follows_the_jeffcott_solution():
    # A stiff, massless shaft carrying a central disc on two isotropic bearings (k, c) moves as one mass:
    # Zf = m_u O^2 e^{ip} / (2k - m O^2 + i O 2c), Zb = 0 (forward circular orbit, lagging the force).
    disc = RigidDisc.annular(2, 0.05, 0.6, 0.05, RHO)
    beams = [TimoshenkoBeam(n, 0.3, 0.1, E * 1e4, NU, RHO * 1e-9) for n in (1, 2)]  # shaft/bearing stiffness ~1e6
    rotor = assemble(beams, [disc], bearing_nodes=[1, 3])
    k, c, mu, p = 2e6, 3e3, 1e-3, 0.4
    for om in (50.0, math.sqrt(2 * k / disc.mass), 300.0):
        res = unbalance_response(rotor, om, [Unbalance(2, mu, p)], [isotropic(k, c)] * 2, nodes=[2])
        expected = mu * om**2 * np.exp(1j * p) / (2 * k - disc.mass * om**2 + 2j * om * c)
        assert abs(res.zf[0] - expected) < 1e-5 * abs(expected)
        assert abs(res.zb[0]) < 1e-9 * abs(expected)


def test_isotropic_bearings_give_circular_forward_orbits(paper_rotor, machine):
    res = unbalance_response(paper_rotor, OMEGA, machine_unbalance(machine), [isotropic(1.5e8, 8e5)] * 2)
    assert np.all(np.abs(res.zb) < 1e-9 * np.abs(res.zf))
    assert res.nodes == tuple(range(1, 22))


def _features(rotor, unbalances, nodes=(5, 6, 20, 21)):
    return unbalance_response(rotor, OMEGA, unbalances, [(K_BRG, C_BRG), (0.8 * K_BRG, 1.3 * C_BRG)],
                              nodes=nodes)


def test_fb_and_orbit_angle_do_not_depend_on_unbalance_size_or_phase(paper_rotor):
    ref = _features(paper_rotor, [Unbalance(13, 1.24e-2, 0.0)])
    assert np.all(np.abs(ref.zb) > 1e-3 * np.abs(ref.zf))  # really elliptic
    for mu, p in ((3e-3, 1.0), (5e-2, -2.5), (1.24e-2, math.pi)):
        other = _features(paper_rotor, [Unbalance(13, mu, p)])
        np.testing.assert_allclose(other.fb, ref.fb, rtol=1e-9)
        d = np.angle(np.exp(2j * (other.phi - ref.phi))) / 2  # compare modulo pi
        np.testing.assert_allclose(d, 0.0, atol=1e-9)
        np.testing.assert_allclose(np.abs(other.zf), np.abs(ref.zf) * mu / 1.24e-2, rtol=1e-9)


def test_features_match_a_dft_of_the_reconstructed_time_signal(paper_rotor):
    res = _features(paper_rotor, [Unbalance(13, 1.24e-2, 0.3), Unbalance(10, 4e-3, 2.0)])
    n_rev, per_rev = 8, 64
    t = np.arange(n_rev * per_rev) * (2 * math.pi / OMEGA) / per_rev
    x = np.real(res.x[:, None] * np.exp(1j * OMEGA * t))
    y = np.real(res.y[:, None] * np.exp(1j * OMEGA * t))
    Z = np.fft.fft(x + 1j * y, axis=1) / t.size
    zf_dft, zb_dft = Z[:, n_rev], Z[:, -n_rev]  # bins +1X and -1X
    np.testing.assert_allclose(res.zf, zf_dft, rtol=1e-9, atol=1e-18)
    np.testing.assert_allclose(res.zb, zb_dft, rtol=1e-9, atol=1e-18)
    # the orbit's major axis: the direction of largest |Z(t)|, modulo pi
    mags = np.abs(x + 1j * y)
    k = np.argmax(mags, axis=1)
    axis_angle = np.angle((x + 1j * y)[np.arange(len(k)), k])
    d = np.angle(np.exp(2j * (res.phi - axis_angle))) / 2
    assert np.all(np.abs(d) < 2 * math.pi / per_rev)  # within the sampling step
    np.testing.assert_allclose(res.fb, np.abs(zf_dft) / np.abs(zb_dft), rtol=1e-9)


def test_orbit_angle_and_fb_of_a_known_ellipse():
    # Z(t) = e^{i psi} (a cos t + i b sin t): major axis a at inclination psi, fb = (a + b)/(a - b)
    a, b = 3.0, 1.0
    for psi in (-1.2, -0.3, 0.0, 0.8, 1.5):
        zf, zb = np.exp(1j * psi) * (a + b) / 2, np.exp(1j * psi) * (a - b) / 2
        assert float(orbit_angle(zf, zb)) == pytest.approx(psi, abs=1e-12)
        assert float(forward_backward_ratio(zf, zb)) == pytest.approx((a + b) / (a - b))
    # branch (-90, 90]: an ellipse inclined by 100 deg reports -80 deg
    psi = math.radians(100)
    assert float(orbit_angle(np.exp(1j * psi) * 2, np.exp(1j * psi))) == pytest.approx(math.radians(-80))
    assert float(orbit_angle(np.exp(1j * math.pi / 2), np.exp(1j * math.pi / 2))) == pytest.approx(math.pi / 2)


def test_sweep_equals_single_solves_and_unwraps_phi(paper_rotor, machine):
    speeds = 2 * math.pi * np.linspace(20, 120, 21)
    bearings = [(K_BRG, C_BRG), (0.8 * K_BRG, 1.3 * C_BRG)]
    sweep = unbalance_sweep(paper_rotor, speeds, machine_unbalance(machine), lambda w: bearings, nodes=[6, 20])
    assert sweep.zf.shape == (21, 2)
    one = unbalance_response(paper_rotor, speeds[7], machine_unbalance(machine), bearings, nodes=[6, 20])
    np.testing.assert_allclose(sweep.zf[7], one.zf, rtol=1e-12)
    assert np.all(np.abs(np.diff(sweep.phi, axis=0)) < math.pi / 2)


def test_bad_response_inputs_raise_input_error(paper_rotor, machine):
    with pytest.raises(InputError, match="node"):
        unbalance_response(paper_rotor, OMEGA, [Unbalance(22, 1e-2)], [isotropic(1e8)] * 2)
    with pytest.raises(InputError, match="pairs"):
        unbalance_response(paper_rotor, OMEGA, machine_unbalance(machine), [isotropic(1e8)])
    with pytest.raises(InputError, match="speed"):
        unbalance_response(paper_rotor, -1.0, machine_unbalance(machine), [isotropic(1e8)] * 2)
