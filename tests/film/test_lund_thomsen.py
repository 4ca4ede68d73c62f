"""Two-axial-groove bearings (SPEC §8, issue 37) against Lund & Thomsen (1978).

Lund, J. W. & Thomsen, K. K. (1978), "A calculation method and data for the dynamic coefficients of
oil-lubricated journal bearings", in Topics in Fluid Film Bearing and Rotor Bearing System Design and Optimization,
ASME, pp. 1-28: isoviscous finite-length films with two 20-degree axial grooves on the horizontal split (160-degree
pads), load vertical, for L/D = 0.5 and 1. The rows below are theirs as ROSS's literature tests print them
(`ross/tests/test_fluid_film_literature.py`, read for the numbers only; the L/D = 1 row at S = 0.358 is the one
ROSS leaves out as a scanning outlier).

Their frame puts x along the (downward) load and y horizontal, in the direction of rotation from x; ours has X
horizontal and Y up, the load along -Y and the rotation from +Y towards -X (SPEC §1), so x = -Y and y = X:
Kxx = K_YY, Kxy = -K_YX, Kyx = -K_XY, Kyy = K_XX (the same for damping). Their groups: S = mu N L D (R / c)^2 / W
(N in rev/s), K c / W, B c omega / W, eps = e / c.

The films differ in one respect: they hold the Swift-Stieber (Reynolds) condition, the p-theta film is mass
conserving with the grooves held full at ambient pressure (flooded). Their grooves span the whole length (split
pads); ours are axial grooves of the stated width. The tolerances are those the comparison supports, as ROSS states
them for its engine: eps within 0.01, the attitude angle within 0.6 deg, each coefficient within 6 % or 0.06.
"""

import math

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.feed import Feed, make_mesh, setup_problem
from lubeviz.model.bearing import Bearing, Groove

DIAMETER, VISCOSITY, RPM = 0.1, 0.02, 3000.0
CLEARANCE = 100e-6
# (S, eps, phi deg, Kxx, Kxy, Kyx, Kyy, Bxx, Bxy, Byy)
TABLE = {
    0.5: [
        (1.656, 0.244, 65.85, 1.69, 5.06, -2.20, 1.95, 9.93, 2.15, 4.80),
        (0.917, 0.372, 57.45, 2.12, 4.01, -1.30, 1.85, 7.70, 2.06, 3.23),
        (0.580, 0.477, 51.01, 2.67, 3.70, -0.78, 1.75, 6.96, 1.94, 2.40),
        (0.379, 0.570, 45.43, 3.33, 3.64, -0.43, 1.68, 6.76, 1.87, 1.89),
        (0.244, 0.655, 40.25, 4.21, 3.74, -0.13, 1.64, 6.87, 1.82, 1.54),
    ],
    1.0: [
        (0.991, 0.150, 70.58, 1.56, 7.29, -2.16, 1.52, 14.66, 1.58, 4.49),
        (0.635, 0.224, 63.54, 1.62, 5.33, -1.57, 1.56, 10.80, 1.70, 3.41),
        (0.235, 0.460, 49.27, 2.19, 3.57, -0.80, 1.55, 7.36, 1.89, 2.19),
        (0.159, 0.559, 44.33, 2.73, 3.36, -0.48, 1.48, 6.94, 1.78, 1.74),
        (0.108, 0.650, 39.72, 3.45, 3.34, -0.23, 1.44, 6.89, 1.72, 1.43),
    ],
}
NAMES = ("Kxx", "Kxy", "Kyx", "Kyy", "Bxx", "Bxy", "Byy")


def two_groove_bearing(length_over_diameter: float, *, n: int = 100, width: float = 1.0) -> Bearing:
    radius, length = DIAMETER / 2, length_over_diameter * DIAMETER
    arc = radius * math.radians(20.0)
    return Bearing(radius=radius, length=length, clearance=CLEARANCE, viscosity=VISCOSITY,
                   groove_angle=math.pi / 2, groove_length=arc, groove_width=width * length,
                   other_grooves=[Groove(3 * math.pi / 2, arc, width * length)],
                   n_circumferential=n, n_axial=n, groove_refinement=1)


def in_their_frame(bearing: Bearing, sommerfeld: float) -> dict:
    omega = RPM * math.pi / 30.0
    w = VISCOSITY * RPM / 60.0 * bearing.length * DIAMETER * (bearing.radius / CLEARANCE) ** 2 / sommerfeld
    eq = find_equilibrium(bearing, omega, np.array([0.0, -w]), Feed.flooded())
    assert eq.converged
    ex, ey = eq.position
    K, C = eq.coefficients.K, eq.coefficients.C
    k, b = CLEARANCE / w, CLEARANCE * omega / w
    return {"eps": math.hypot(ex, ey) / CLEARANCE, "phi": math.degrees(math.atan2(abs(ex), abs(ey))),
            "Kxx": K[1, 1] * k, "Kxy": -K[1, 0] * k, "Kyx": -K[0, 1] * k, "Kyy": K[0, 0] * k,
            "Bxx": C[1, 1] * b, "Bxy": -C[1, 0] * b, "Byy": C[0, 0] * b}


@pytest.mark.parametrize("length_over_diameter, row", [(ld, row) for ld, rows in TABLE.items() for row in rows],
                         ids=[f"L/D={ld}-S={row[0]}" for ld, rows in TABLE.items() for row in rows])
def test_two_axial_groove_bearing_matches_lund_and_thomsen(length_over_diameter, row):
    got = in_their_frame(two_groove_bearing(length_over_diameter), row[0])
    assert got["eps"] == pytest.approx(row[1], abs=0.01)
    assert got["phi"] == pytest.approx(row[2], abs=0.6)
    for name, theirs in zip(NAMES, row[3:]):
        assert abs(got[name] - theirs) <= max(0.06, 0.06 * abs(theirs)), (name, got[name], theirs)


def test_the_grooves_share_the_supply_in_proportion_to_their_area():
    """A prescribed supply is one source spread over every groove volume (Eq. 4 with several grooves): two equal
    grooves get half each, and a groove twice as wide twice the other's share; the whole is the supply."""
    b = two_groove_bearing(0.5, n=60)
    q = 1e-5
    for other_width, share in ((1.0, 0.5), (0.5, 2.0 / 3.0)):
        bb = b.copy(groove_width=0.8 * b.length,
                    other_grooves=[Groove(3 * math.pi / 2, b.groove_length, 0.8 * other_width * b.length)])
        prob = setup_problem(bb, 300.0, (0.0, -0.3 * CLEARANCE), Feed.flow(q))
        src = prob.coef.S
        alpha = np.broadcast_to(prob.mesh.alpha, prob.mesh.shape)
        first = prob.groove & (np.abs(np.angle(np.exp(1j * (alpha - math.pi / 2)))) < 1.0)
        total = src[prob.groove].sum()
        assert np.count_nonzero(src[~prob.groove]) == 0
        assert src[first].sum() / total == pytest.approx(share, rel=0.03)
        assert total * prob.flux_ref * prob.mesh.mirror_factor == pytest.approx(q, rel=1e-9)


def test_a_second_groove_is_meshed_like_the_first():
    """The paper's bearing with a second groove half a turn on: the mesh keeps the first groove where it was and
    refines the second one's columns as it does the first's, and the second groove has as many cells."""
    one = Bearing()
    two = one.copy(other_grooves=[Groove(one.groove_angle + math.pi, one.groove_length, one.groove_width)])
    m1, m2 = make_mesh(one), make_mesh(two)
    assert m2.alpha_offset == m1.alpha_offset
    assert sum(k > 1 for k in m2.split) == 2 * sum(k > 1 for k in m1.split)
    position = (0.0, -0.4 * one.clearance)
    g1 = setup_problem(one, 300.0, position, Feed.flooded()).groove
    g2 = setup_problem(two, 300.0, position, Feed.flooded()).groove
    assert g2.sum() == 2 * g1.sum()
