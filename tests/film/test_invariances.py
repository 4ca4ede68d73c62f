"""Physical invariances of the film model."""

import math

import numpy as np

from lubeviz.film.feed import Feed, make_mesh, setup_problem
from lubeviz.film.solver import solve
from tests.conftest import OMEGA_75HZ, plain_bearing
from lubeviz.units import MLMIN_PER_M3S


def test_pressure_is_mirror_symmetric_about_the_mid_plane(paper_bearing):
    mesh = make_mesh(paper_bearing, half=False)
    sol = solve(setup_problem(paper_bearing, OMEGA_75HZ, (2e-5, -3e-5), Feed.flow(350 / MLMIN_PER_M3S), mesh=mesh))
    p = sol.pressure_field()
    np.testing.assert_allclose(p, p[::-1], rtol=1e-9, atol=1e-9 * p.max())


def test_plain_bearing_force_rotates_with_the_journal():
    b = plain_bearing(1.0)
    e = 0.5 * b.clearance
    forces = []
    for psi in (0.0, 0.7):  # journal direction from -Y in the direction of rotation
        pos = (e * math.sin(psi), -e * math.cos(psi))
        forces.append(solve(setup_problem(b, OMEGA_75HZ, pos, Feed.plain())).force)
    rot = np.array([[math.cos(0.7), -math.sin(0.7)], [math.sin(0.7), math.cos(0.7)]])
    np.testing.assert_allclose(forces[1], rot @ forces[0], rtol=1e-9, atol=1e-9 * np.hypot(*forces[0]))


def test_force_scales_with_viscosity(paper_bearing):
    pos, feed = (1e-5, -2e-5), Feed.flow(400 / MLMIN_PER_M3S)
    f1 = solve(setup_problem(paper_bearing, OMEGA_75HZ, pos, feed)).force
    f2 = solve(setup_problem(paper_bearing.copy(viscosity=2.5 * paper_bearing.viscosity), OMEGA_75HZ, pos, feed)).force
    np.testing.assert_allclose(f2, 2.5 * f1, rtol=1e-10)


def test_force_scales_with_speed_when_supply_scales_too(paper_bearing):
    pos = (1e-5, -2e-5)
    s1 = solve(setup_problem(paper_bearing, OMEGA_75HZ, pos, Feed.flow(400 / MLMIN_PER_M3S)))
    s2 = solve(setup_problem(paper_bearing, 1.6 * OMEGA_75HZ, pos, Feed.flow(1.6 * 400 / MLMIN_PER_M3S)))
    np.testing.assert_allclose(s2.force, 1.6 * s1.force, rtol=1e-10)
    np.testing.assert_allclose(s2.theta, s1.theta, atol=1e-12)


def test_centred_plain_bearing_carries_no_load():
    b = plain_bearing(1.0)
    sol = solve(setup_problem(b, OMEGA_75HZ, (0.0, 0.0), Feed.plain()))
    assert np.hypot(*sol.force) < 1e-9
