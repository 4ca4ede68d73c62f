"""Global matrices: symmetry, rigid-body modes, bearing placement with Lund's sign."""

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.rotor import (LinearBearing, RigidDisc, TimoshenkoBeam, assemble, bearing_matrices, node_dofs,
                           rotor_from_machine)

E, NU, RHO = 210e9, 0.3, 7850.0


@pytest.fixture(scope="module")
def paper_rotor(machine):
    return rotor_from_machine(machine)


def test_paper_rotor_has_84_dofs_and_2235_mm(paper_rotor):
    assert paper_rotor.n_dof == 84 and paper_rotor.n_nodes == 21
    assert paper_rotor.node_z[-1] == pytest.approx(2.235, rel=1e-12)  # SPEC §2
    assert paper_rotor.bearing_nodes == (6, 20)


def test_global_matrices_are_symmetric_skew_and_definite(paper_rotor):
    r = paper_rotor
    assert np.array_equal(r.M, r.M.T) and np.array_equal(r.K, r.K.T) and np.array_equal(r.G, -r.G.T)
    assert np.all(np.linalg.eigvalsh(r.M) > 0)
    np.testing.assert_allclose(r.C, r.shaft_damping_beta * r.K)


def test_free_free_shaft_has_exactly_four_rigid_body_modes(paper_rotor):
    r = paper_rotor
    z = r.node_z
    modes = np.zeros((4, r.n_dof))
    modes[0, 0::4] = 1.0                         # translation X
    modes[1, 1::4] = 1.0                         # translation Y
    modes[2, 0::4], modes[2, 3::4] = z, 1.0      # rotation about +Y: x = a z, theta_y = a
    modes[3, 1::4], modes[3, 2::4] = -z, 1.0     # rotation about +X: y = -a z, theta_x = a
    scale = np.abs(r.K).max()
    for u in modes:
        assert np.abs(r.K @ u).max() < 1e-9 * scale
    w = np.linalg.eigvalsh(r.K)
    assert np.sum(np.abs(w) < 1e-9 * w.max()) == 4


def test_bearing_coefficients_enter_with_plus_sign_and_xy_couples_force_x_to_y(paper_rotor):
    r = paper_rotor
    K1 = np.array([[1.0e8, 2.0e7], [-3.0e7, 4.0e8]])
    C1 = np.array([[5.0e5, 6.0e4], [7.0e4, 8.0e5]])
    K, C = bearing_matrices(r, [(K1, C1), (2 * K1, 2 * C1)])
    x6, y6 = node_dofs(6)[:2]
    x20, y20 = node_dofs(20)[:2]
    assert K[x6, y6] - r.K[x6, y6] == 2.0e7  # row = force X, column = displacement Y
    assert K[y6, x6] - r.K[y6, x6] == -3.0e7
    assert C[y20, y20] - r.C[y20, y20] == 1.6e6
    dK = K - r.K
    dK[np.ix_([x6, y6], [x6, y6])] -= K1
    dK[np.ix_([x20, y20], [x20, y20])] -= 2 * K1
    assert np.abs(dK).max() == 0.0


def test_stacked_coefficients_give_stacked_matrices(paper_rotor):
    r = paper_rotor
    ks = np.array([k * np.eye(2) for k in (1e7, 1e8, 1e9)])
    K, C = bearing_matrices(r, [(ks, np.zeros((2, 2))), (np.eye(2), np.eye(2))])
    assert K.shape == (3, 84, 84) and C.shape == (3, 84, 84)
    for i in range(3):
        Ki, _ = bearing_matrices(r, [(ks[i], np.zeros((2, 2))), (np.eye(2), np.eye(2))])
        assert np.array_equal(K[i], Ki)


def test_bearing_objects_may_sit_at_any_node(paper_rotor):
    K, _ = bearing_matrices(paper_rotor, [LinearBearing(1, 5 * np.eye(2), np.zeros((2, 2)))])
    assert K[0, 0] - paper_rotor.K[0, 0] == 5.0


def test_assembly_refuses_gaps_and_stray_nodes():
    b = [TimoshenkoBeam(1, 0.1, 0.05, E, NU, RHO), TimoshenkoBeam(3, 0.1, 0.05, E, NU, RHO)]
    with pytest.raises(InputError, match="consecutively"):
        assemble(b)
    with pytest.raises(InputError, match="node"):
        assemble(b[:1], [RigidDisc(3, 1.0, 0.1, 0.2)])
    with pytest.raises(InputError, match="bearing node"):
        assemble(b[:1], bearing_nodes=[5])
