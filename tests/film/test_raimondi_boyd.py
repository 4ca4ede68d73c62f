"""The plain full bearing against Raimondi & Boyd (1958), SPEC §3 table (p-theta = Reynolds BC)."""

import math

import numpy as np
import pytest

from lubeviz.film.feed import Feed, setup_problem
from lubeviz.film.solver import solve
from tests.conftest import plain_bearing

# SPEC §3: L/D = 1 and 1/2, eps -> (S, attitude deg)
RB_LD1 = {0.2: (0.631, 74.0), 0.4: (0.264, 63.1), 0.6: (0.121, 50.6), 0.8: (0.0446, 36.2), 0.9: (0.0188, 26.5)}
RB_LD05 = {0.2: 2.03, 0.4: 0.779, 0.6: 0.319, 0.8: 0.0923, 0.9: 0.0313}
MESH = (120, 40)  # circumferential x axial cells over the whole bearing
OMEGA = 2 * math.pi * 50.0


def sommerfeld_and_attitude(l_over_d, eps):
    b = plain_bearing(l_over_d, *MESH)
    position = (0.0, -eps * b.clearance)  # journal displaced straight down
    sol = solve(setup_problem(b, OMEGA, position, Feed.plain())).raise_if_failed()
    w = float(np.hypot(*sol.force))
    s = b.viscosity * OMEGA / (2 * math.pi) * b.length * b.diameter / w * (b.radius / b.clearance) ** 2
    # attitude: from the load line (-F) to the line of centres (0, -1), in the direction of rotation
    att = math.degrees(math.atan2(-1.0, 0.0) - math.atan2(-sol.force[1], -sol.force[0]))
    return s, (att + 180.0) % 360.0 - 180.0


@pytest.mark.parametrize("eps", sorted(RB_LD1))
def test_matches_raimondi_boyd_ld1(eps):
    s, att = sommerfeld_and_attitude(1.0, eps)
    s_ref, att_ref = RB_LD1[eps]
    assert s == pytest.approx(s_ref, rel=0.02)
    assert att == pytest.approx(att_ref, abs=1.0)


@pytest.mark.parametrize("eps", sorted(RB_LD05))
def test_matches_raimondi_boyd_ld_half(eps):
    s, _ = sommerfeld_and_attitude(0.5, eps)
    assert s == pytest.approx(RB_LD05[eps], rel=0.02)
