"""Element matrices: against shape-function quadrature, beam theory and the rotation convention."""

import math

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.rotor import LinearBearing, RigidDisc, TimoshenkoBeam, cowper_shear_coefficient
from lubeviz.rotor.elements import planar_rotary_mass, planar_stiffness, planar_translational_mass

E, NU, RHO = 210e9, 0.3, 7850.0
G_SHEAR = E / (2 * (1 + NU))


def _shape_functions(xi, L, phi):
    """Timoshenko interpolation (Friedman & Kosmatka 1993): w and psi for DOFs (w1, psi1, w2, psi2),
    plus dw/dz and dpsi/dz. Written here from the paper, independently of the closed forms under test."""
    c = 1.0 / (1.0 + phi)
    Nw = c * np.array([2 * xi**3 - 3 * xi**2 - phi * xi + 1 + phi,
                       L * (xi**3 - (2 + phi / 2) * xi**2 + (1 + phi / 2) * xi),
                       -2 * xi**3 + 3 * xi**2 + phi * xi,
                       L * (xi**3 - (1 - phi / 2) * xi**2 - phi / 2 * xi)])
    dNw = c / L * np.array([6 * xi**2 - 6 * xi - phi,
                            L * (3 * xi**2 - (4 + phi) * xi + 1 + phi / 2),
                            -6 * xi**2 + 6 * xi + phi,
                            L * (3 * xi**2 - (2 - phi) * xi - phi / 2)])
    Npsi = c * np.array([6 / L * (xi**2 - xi), 3 * xi**2 - (4 + phi) * xi + 1 + phi,
                         -6 / L * (xi**2 - xi), 3 * xi**2 - (2 - phi) * xi])
    dNpsi = c / L * np.array([6 / L * (2 * xi - 1), 6 * xi - (4 + phi), -6 / L * (2 * xi - 1), 6 * xi - (2 - phi)])
    return Nw, dNw, Npsi, dNpsi


@pytest.mark.parametrize("L, D", [(0.3, 0.03), (0.045, 0.2625)])  # slender, and the paper's stubby element 11
def test_planar_matrices_equal_shape_function_integrals(L, D):
    A, I = math.pi * D**2 / 4, math.pi * D**4 / 64
    kappa = cowper_shear_coefficient(NU)
    phi = 12 * E * I / (kappa * G_SHEAR * A * L**2)
    xg, wg = np.polynomial.legendre.leggauss(8)
    xi, w = 0.5 * (xg + 1), 0.5 * wg * L
    MT, MR, K = np.zeros((4, 4)), np.zeros((4, 4)), np.zeros((4, 4))
    for x, wt in zip(xi, w):
        Nw, dNw, Npsi, dNpsi = _shape_functions(x, L, phi)
        MT += wt * RHO * A * np.outer(Nw, Nw)
        MR += wt * RHO * I * np.outer(Npsi, Npsi)
        gamma = dNw - Npsi  # shear strain
        K += wt * (E * I * np.outer(dNpsi, dNpsi) + kappa * G_SHEAR * A * np.outer(gamma, gamma))
    np.testing.assert_allclose(planar_translational_mass(RHO * A, L, phi), MT, rtol=1e-10, atol=1e-12 * MT.max())
    np.testing.assert_allclose(planar_rotary_mass(RHO * I, L, phi), MR, rtol=1e-10, atol=1e-12 * MR.max())
    np.testing.assert_allclose(planar_stiffness(E * I, L, phi), K, rtol=1e-9, atol=1e-11 * K.max())


def test_cowper_coefficient_for_steel():
    # 6(1+nu)/(7+6nu) at nu = 0.3: 7.8/8.8
    assert cowper_shear_coefficient(0.3) == pytest.approx(0.886363636, rel=1e-8)


def _cantilever_tip(beam, load_dof, load):
    """Clamp node 1 of a single element; return the tip DOFs (x, y, theta_x, theta_y) under a tip load."""
    K = beam.K()[4:, 4:]
    f = np.zeros(4)
    f[load_dof] = load
    return np.linalg.solve(K, f)


def test_moment_about_x_bends_the_tip_towards_minus_y():
    # A moment vector along +X at the tip of a cantilever along +Z turns the tip's axis from +Z to -Y
    # (right-hand rule): theta_x = M L/EI > 0 and y = -M L^2 / (2 EI) (pure bending, no shear).
    L, D, Mx = 0.5, 0.05, 100.0
    beam = TimoshenkoBeam(1, L, D, E, NU, RHO)
    EI = E * beam.inertia
    x, y, tx, ty = _cantilever_tip(beam, 2, Mx)
    assert tx == pytest.approx(Mx * L / EI, rel=1e-9)
    assert y == pytest.approx(-Mx * L**2 / (2 * EI), rel=1e-9)
    assert x == pytest.approx(0.0, abs=1e-15) and ty == pytest.approx(0.0, abs=1e-15)


def test_moment_about_y_bends_the_tip_towards_plus_x():
    L, D, My = 0.5, 0.05, 100.0
    beam = TimoshenkoBeam(1, L, D, E, NU, RHO)
    EI = E * beam.inertia
    x, y, tx, ty = _cantilever_tip(beam, 3, My)
    assert ty == pytest.approx(My * L / EI, rel=1e-9)
    assert x == pytest.approx(My * L**2 / (2 * EI), rel=1e-9)


def test_cantilever_tip_force_gives_bending_plus_shear_deflection():
    # Timoshenko cantilever: delta = F L^3/(3 EI) + F L/(kappa G A); slope dx/dz = theta_y = F L^2/(2 EI).
    L, D, F = 0.1, 0.08, 1000.0
    beam = TimoshenkoBeam(1, L, D, E, NU, RHO)
    EI, kGA = E * beam.inertia, cowper_shear_coefficient(NU) * G_SHEAR * beam.area
    x, y, tx, ty = _cantilever_tip(beam, 0, F)
    assert x == pytest.approx(F * L**3 / (3 * EI) + F * L / kGA, rel=1e-9)
    assert ty == pytest.approx(F * L**2 / (2 * EI), rel=1e-9)
    x, y, tx, ty = _cantilever_tip(beam, 1, F)
    assert y == pytest.approx(F * L**3 / (3 * EI) + F * L / kGA, rel=1e-9)
    assert tx == pytest.approx(-F * L**2 / (2 * EI), rel=1e-9)


def test_rigid_body_motions_are_strain_free_and_carry_the_element_mass():
    beam = TimoshenkoBeam(1, 0.2, 0.1, E, NU, RHO)
    L = beam.length
    # rigid rotation a about +Y: x = a z, theta_y = a; about +X: y = -a z, theta_x = a
    rot_y = np.array([0, 0, 0, 1, L, 0, 0, 1.0])
    rot_x = np.array([0, 0, 1, 0, 0, -L, 1, 0.0])
    trans = np.array([1, 0, 0, 0, 1, 0, 0, 0.0])
    for u in (rot_y, rot_x, trans):
        assert np.abs(beam.K() @ u).max() < 1e-6 * np.abs(beam.K()).max()
    assert trans @ beam.M() @ trans == pytest.approx(RHO * beam.area * L, rel=1e-12)
    # rigid rotation about Y through the middle: translational inertia m L^2/12 plus rotary rho I L
    mid = rot_y - np.array([L / 2, 0, 0, 0, L / 2, 0, 0, 0])
    assert mid @ beam.M() @ mid == pytest.approx(beam.mass * L**2 / 12 + RHO * beam.inertia * L, rel=1e-12)


def test_element_matrices_are_symmetric_and_gyroscopic_is_skew():
    beam = TimoshenkoBeam(3, 0.045, 0.2625, E, NU, RHO)
    np.testing.assert_allclose(beam.M(), beam.M().T, atol=0)
    np.testing.assert_allclose(beam.K(), beam.K().T, atol=0)
    np.testing.assert_allclose(beam.G(), -beam.G().T, atol=0)
    assert list(beam.dofs()) == list(range(8, 16))
    assert np.all(np.linalg.eigvalsh(beam.M()) > 0)


def test_annular_disc_inertias():
    # thin annulus: Ip = m (Ro^2 + Ri^2)/2, Id = Ip/2 + m w^2/12
    d = RigidDisc.annular(13, 0.05, 0.6, 0.1875, RHO)
    m = RHO * math.pi / 4 * (0.6**2 - 0.1875**2) * 0.05
    assert d.mass == pytest.approx(m, rel=1e-12)
    assert d.polar_inertia == pytest.approx(m * (0.3**2 + 0.09375**2) / 2, rel=1e-12)
    assert d.diametral_inertia == pytest.approx(d.polar_inertia / 2 + m * 0.05**2 / 12, rel=1e-12)
    G = d.G()
    assert G[2, 3] == d.polar_inertia and G[3, 2] == -d.polar_inertia


def test_bad_inputs_raise_input_error():
    with pytest.raises(InputError, match="shape"):
        LinearBearing(6, np.eye(3), np.eye(2))
    with pytest.raises(InputError, match="NaN"):
        LinearBearing(6, [[np.nan, 0], [0, 1]], np.eye(2))
    with pytest.raises(InputError, match="length"):
        TimoshenkoBeam(1, -0.1, 0.05, E, NU, RHO)
    with pytest.raises(InputError, match="bore"):
        RigidDisc.annular(1, 0.05, 0.2, 0.3, RHO)


def test_cowper_s_coefficient_of_a_hollow_circle_runs_from_the_solid_value_to_the_thin_tube_s():
    """Cowper (1966): 6(1+nu)/(7+6nu) for the solid circle, 2(1+nu)/(4+3nu) for a thin-walled tube (m -> 1)."""
    from lubeviz.rotor.elements import cowper_shear_coefficient

    nu = 0.3
    assert cowper_shear_coefficient(nu, 0.0) == pytest.approx(6 * (1 + nu) / (7 + 6 * nu))
    assert cowper_shear_coefficient(nu, 1.0 - 1e-9) == pytest.approx(2 * (1 + nu) / (4 + 3 * nu), rel=1e-6)
    ks = [cowper_shear_coefficient(nu, m) for m in (0.0, 0.3, 0.6, 0.9)]
    assert all(a > b for a, b in zip(ks, ks[1:]))  # a thinner wall carries shear less evenly


def test_a_hollow_element_has_the_annulus_area_and_inertia_and_refuses_a_bore_as_wide_as_the_shaft():
    import math

    from lubeviz.errors import InputError
    from lubeviz.rotor.elements import TimoshenkoBeam

    solid = TimoshenkoBeam(1, 0.1, 0.08, 2.1e11, 0.3, 7850.0)
    tube = TimoshenkoBeam(1, 0.1, 0.08, 2.1e11, 0.3, 7850.0, inner_diameter=0.05)
    assert tube.area == pytest.approx(solid.area - math.pi * 0.05**2 / 4)
    assert tube.inertia == pytest.approx(solid.inertia - math.pi * 0.05**4 / 64)
    with pytest.raises(InputError, match="inner diameter"):
        TimoshenkoBeam(1, 0.1, 0.08, 2.1e11, 0.3, 7850.0, inner_diameter=0.08)
