"""The non-mass-conserving comparison model: classical results of the Sommerfeld solutions."""

import math

import numpy as np

from lubeviz.film.derived import attitude_from_force
from lubeviz.film.feed import Feed, setup_problem
from lubeviz.film.solver import solve
from lubeviz.film.sommerfeld import sommerfeld_film, sommerfeld_solution
from lubeviz.model.machine import load_machine
from lubeviz.units import MLMIN_PER_M3S

OMEGA = 2 * math.pi * 75.0


def _bearing():
    return load_machine().bearings[0].copy(n_circumferential=120, n_axial=40)


def test_full_sommerfeld_of_a_plain_bearing_pushes_at_right_angles_to_the_line_of_centres():
    # The full-Sommerfeld pressure is antisymmetric about the line of centres (h is symmetric), so the
    # film force has no component along it: attitude angle 90 degrees, the classical result.
    b = _bearing()
    for eps, angle in ((0.3, 0.4), (0.6, 2.0)):
        c = b.clearance
        pos = eps * c * np.array([math.sin(angle), -math.cos(angle)])
        film = sommerfeld_solution(setup_problem(b, OMEGA, pos, Feed.plain()))
        assert abs(abs(math.degrees(attitude_from_force(pos, film.force_full))) - 90.0) < 1.0


def test_half_sommerfeld_does_not_depend_on_the_supply_while_the_p_theta_film_does():
    b = _bearing()
    pos = 0.3 * b.clearance * np.array([0.5, -0.85])
    starved, flooded = (setup_problem(b, OMEGA, pos, Feed.flow(q / MLMIN_PER_M3S)) for q in (250.0, 900.0))
    hs = sommerfeld_film(b, OMEGA, pos)  # no supply among its inputs: one film for both
    p_starved, p_flooded = solve(starved).pressure_field(), solve(flooded).pressure_field()
    assert np.count_nonzero(p_starved > 0) < 0.8 * np.count_nonzero(p_flooded > 0)  # starvation shrinks the zone
    # The flooded p-theta film and the half-Sommerfeld one carry loads of the same order at this position;
    # the starved p-theta film carries much less.
    f_hs = np.hypot(*hs.force_half)
    f_starved, f_flooded = (np.hypot(*solve(pr).force) for pr in (starved, flooded))
    assert f_starved < 0.8 * f_flooded and 0.5 < f_flooded / f_hs < 2.0


def test_half_sommerfeld_is_the_clipped_full_solution():
    b = _bearing()
    pos = 0.5 * b.clearance * np.array([0.6, -0.8])
    film = sommerfeld_film(b, OMEGA, pos)
    assert film.full.min() < 0 < film.full.max()
    np.testing.assert_array_equal(film.half, np.maximum(film.full, 0.0))
