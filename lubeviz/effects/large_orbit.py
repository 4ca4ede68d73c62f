"""Large orbits: the film force taken along the orbit instead of its linearization."""

from __future__ import annotations

from typing import ClassVar

from .base import Effect


class LargeOrbit(Effect):
    """The films' force along the orbit (nonlinear), not their tangent K, C at the static equilibrium.

    The linear model holds for orbits small against the clearance. At the paper's unbalance the journal
    orbits reach a third to a half of the clearance (eccentricity 0.3-0.55 at Q_T); the cavitated region
    then breathes with the orbit and the film force is far from linear in the motion. The steady orbit
    stays periodic at the shaft speed but gains 2X and 3X lines, a static shift of the journals (here
    several um downward) and a 1X that differs from the linear one by 10-25 % in size and 5-20 deg in
    phase (harmonic balance of `rotor.orbit_balance`, 0X-3X, the p-theta film re-solved at 16 points of
    each revolution with the journal's squeeze velocity and the bearing's supply flow).

    A modelling assumption to know: at each instant the film is solved quasi-statically and consumes the
    supply flow exactly (as the linearized C assumes); the film's own oil storage over a revolution (the
    transient Elrod term) is not modelled. Sub-synchronous whirl is not periodic at the shaft speed and is
    outside this effect: the linear stability at the equilibrium tells whether to expect it.

    It changes the whole response, not one stage of the chain: `simulate` uses it (`--effect
    large_orbit`); an identification cannot yet (every evaluation would cost 32 film solves per
    iteration of the balance). A record's 2X line (`identify`'s `lines_beyond_1x`) is how it shows.
    """

    effect_name = "large_orbit"
    stage = "response"
    separated_by = ("the 2X line of the record (film nonlinearity grows it with the orbit), or a record at a "
                    "smaller unbalance")
    harmonics: ClassVar[int] = 3
    points: ClassVar[int] = 16

    def spec(self) -> str:
        return self.effect_name
