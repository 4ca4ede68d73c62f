"""Weight, reactions and static deflection: the paper's figures and beam theory."""

import math

import numpy as np
import pytest

from lubeviz.rotor import (RigidDisc, TimoshenkoBeam, assemble, cowper_shear_coefficient, gravity_load, isotropic,
                           rotor_from_machine, simple_support_reactions, static_deflection, weight)

E, NU, RHO, G = 210e9, 0.3, 7850.0, 9.81


def test_paper_rotor_weighs_6545_6_n(machine):
    rotor = rotor_from_machine(machine)
    assert weight(rotor, 9.81) == pytest.approx(6545.6, rel=5e-4)  # paper Sec. 3


def test_paper_rotor_reactions_are_equal(machine):
    rotor = rotor_from_machine(machine)
    r = simple_support_reactions(rotor, 9.81)
    assert r.nodes == (6, 20)
    assert r.forces[0] == pytest.approx(r.forces[1], rel=1e-4)  # SPEC §2: equal to 0.01 %
    assert r.forces.sum() == pytest.approx(6545.6, rel=5e-4)


def test_reactions_follow_the_centre_of_mass(machine):
    # Statically determinate: R2 = W (z_cm - z1)/(z2 - z1), z_cm from element and disc masses directly.
    rotor = rotor_from_machine(machine)
    z = np.concatenate([[0.0], np.cumsum([e.length for e in machine.elements])])
    masses, centres = [], []
    for k, e in enumerate(machine.elements):
        masses.append(RHO * math.pi * e.diameter**2 / 4 * e.length)
        centres.append(z[k] + e.length / 2)
    for d in machine.discs:
        masses.append(RHO * math.pi / 4 * (d.outer_diameter**2 - d.bore_diameter**2) * d.width)
        centres.append(z[d.node - 1])
    W = G * sum(masses)
    z_cm = np.dot(masses, centres) / sum(masses)
    z1, z2 = z[5], z[19]
    r = simple_support_reactions(rotor, G)
    assert r.forces[1] == pytest.approx(W * (z_cm - z1) / (z2 - z1), rel=1e-10)
    assert r.forces[0] == pytest.approx(W * (z2 - z_cm) / (z2 - z1), rel=1e-10)


def _uniform_shaft(L, D, n_el, shear=True, density=RHO):
    beams = [TimoshenkoBeam(k, L / n_el, D, E, NU, density, shear=shear) for k in range(1, n_el + 1)]
    return assemble(beams, bearing_nodes=[1, n_el + 1])


@pytest.mark.parametrize("L, D", [(2.0, 0.05), (0.4, 0.1)])  # slender, and stubby (L/D = 4)
def test_simply_supported_beam_sags_5wl4_over_384ei_plus_shear(L, D):
    n_el = 10
    rotor = _uniform_shaft(L, D, n_el)
    A, I = math.pi * D**2 / 4, math.pi * D**4 / 64
    w = RHO * A * G
    kGA = cowper_shear_coefficient(NU) * E / (2 * (1 + NU)) * A
    bending = 5 * w * L**4 / (384 * E * I)
    shear = w * L**2 / (8 * kGA)
    sol = static_deflection(rotor, [isotropic(1e15)] * 2, G)
    mid = n_el // 2  # node n_el//2 + 1 is mid-span
    assert sol.y[mid] == pytest.approx(-(bending + shear), rel=1e-4)
    assert np.allclose(sol.x, 0.0)
    # bearing forces on the journal hold the weight (Lund's sign: f = -K q)
    assert sol.bearing_forces[:, 1].sum() == pytest.approx(w * L, rel=1e-9)
    if L / D < 5:
        assert shear / bending > 0.05  # the stubby case really tests the shear term


def test_gravity_load_is_the_weight_along_minus_y():
    rotor = assemble([TimoshenkoBeam(1, 0.3, 0.05, E, NU, RHO)], [RigidDisc(2, 10.0, 0.1, 0.2)])
    F = gravity_load(rotor, G)
    assert F[1::4].sum() == pytest.approx(-G * (10.0 + RHO * math.pi * 0.05**2 / 4 * 0.3), rel=1e-12)
    assert np.all(F[0::4] == 0.0)


def test_cross_coupled_bearing_moves_the_journal_sideways():
    # A single rigid mass on one bearing: K q = F with F = (0, -W): q = -W K^-1 e_y, so a positive kxy
    # (force X from displacement Y) pushes the journal to +X when it sinks; Lund's sign f = -K q.
    rotor = assemble([TimoshenkoBeam(1, 0.1, 0.1, 1e3 * E, NU, 1e-9)], [RigidDisc(1, 100.0, 0.0, 0.0)],
                     bearing_nodes=[1, 2])
    K1 = np.array([[2e7, 1e7], [0.0, 4e7]])
    sol = static_deflection(rotor, [(K1, np.zeros((2, 2))), isotropic(1e12)], G)
    W = 100.0 * G
    expected = np.linalg.solve(K1, [0.0, -W])
    assert sol.x[0] == pytest.approx(expected[0], rel=1e-3)
    assert sol.y[0] == pytest.approx(expected[1], rel=1e-3)
    assert expected[0] > 0


@pytest.mark.parametrize("spans", [(1.0, 1.0), (0.6, 1.4)])
def test_a_continuous_beam_on_three_supports_carries_the_three_moment_equation_s_reactions(spans):
    """A statically indeterminate rotor (SPEC §8: 3+ supports) in the stiff-support limit: a uniform shaft pinned at
    its ends and at one point between, under its own weight w per metre. Clapeyron's three-moment equation gives the
    hogging moment over the middle support M = w (a^3 + b^3) / (8 (a + b)), so R1 = w a / 2 - M / a,
    R3 = w b / 2 - M / b and R2 = w (a + b) - R1 - R3 (equal spans: 3/8, 10/8, 3/8 of w a)."""
    a, b = spans
    n_a, n_b = 12, 16
    d = 0.06
    beams = [TimoshenkoBeam(k + 1, (a / n_a if k < n_a else b / n_b), d, E, NU, RHO, shear=False)
             for k in range(n_a + n_b)]
    rotor = assemble(beams, [], bearing_nodes=[1, n_a + 1, n_a + n_b + 1])
    w = RHO * math.pi * d**2 / 4 * G
    m = w * (a**3 + b**3) / (8 * (a + b))
    r1, r3 = w * a / 2 - m / a, w * b / 2 - m / b
    expect = [r1, w * (a + b) - r1 - r3, r3]
    got = simple_support_reactions(rotor, G).forces
    np.testing.assert_allclose(got, expect, rtol=1e-9)
    if a == b:
        np.testing.assert_allclose(got / (w * a), [3 / 8, 10 / 8, 3 / 8], rtol=1e-9)
