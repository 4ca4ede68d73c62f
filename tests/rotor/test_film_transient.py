"""Time integration on the p-theta films: tends to the linear response as the orbit shrinks."""

import math

import numpy as np
import pytest

from lubeviz.errors import ConvergenceError
from lubeviz.rotor import Unbalance, rotor_from_machine, unbalance_response
from lubeviz.rotor.film_bearings import film_bearings
from lubeviz.rotor.film_transient import amplitude_ratio, film_time_response

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def coarse(machine):
    """The paper's machine with 60 x 40 film meshes (the limit checked here does not need 100 x 100).

    Fixed-pattern coefficients, not the sub-cell default: as the orbit shrinks, the integration on the
    discrete film tends to the derivative of that film with its cavitation pattern held, which is the
    fixed-pattern tangent exactly. The sub-cell tangent places the fronts inside the cells (smooth in Q,
    closer to the mesh limit) and differs from it by ~1 % on this mesh: the linear response on it misses
    the integrated orbit by 0.4 % / 0.3 deg, several times what this test allows.
    """
    from lubeviz.model.machine import load_machine

    m = load_machine()
    m.bearings = [b.copy(n_circumferential=60, n_axial=40) for b in m.bearings]
    bearings = film_bearings(m, (450 / 6e7, 450 / 6e7), coefficients="fixed-pattern")
    return m, rotor_from_machine(m), bearings


def test_small_orbits_on_the_p_theta_film_match_the_linear_response(coarse):
    machine, rotor, bearings = coarse
    ub = (Unbalance(machine.unbalance_node, 0.01 * machine.unbalance_moment, 0.0),)
    lin = unbalance_response(rotor, bearings.omega, ub, bearings.coefficients, nodes=(6, 20))
    res = film_time_response(rotor, bearings, ub, duration=0.06, nodes=(6, 20))
    late = res.t > 0.03
    for k, node in enumerate((6, 20)):
        x, y = res.node_xy(node)
        for sig, ref in ((x, lin.x[k]), (y, lin.y[k])):
            ratio = amplitude_ratio(res.t[late], sig[late], bearings.omega, ref)
            # measured: 0.07 % / 0.06 deg against fixed-pattern K, C; 0.4 % / 0.32 deg against sub-cell
            assert abs(abs(ratio) - 1) < 2e-3 and abs(np.angle(ratio)) < math.radians(0.2)
    # the film force is the equilibrium force plus a small oscillation, and the residual is tiny
    f0 = bearings.equilibria[0].film.force
    assert np.allclose(res.film_force[0].mean(axis=1), f0, rtol=0, atol=1e-3 * np.hypot(*f0))


def test_large_orbits_stop_with_a_clear_message_instead_of_a_wrong_orbit(coarse):
    machine, rotor, bearings = coarse
    ub = (Unbalance(machine.unbalance_node, machine.unbalance_moment, 0.0),)
    with pytest.raises(ConvergenceError, match="linearization"):
        film_time_response(rotor, bearings, ub, duration=0.01, nodes=(6, 20))
