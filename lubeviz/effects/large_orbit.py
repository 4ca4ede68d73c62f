"""Large orbits: the film force taken along the orbit instead of its linearization."""

from __future__ import annotations

from typing import ClassVar

from ..rotor.orbit_balance import HARMONICS, POINTS
from .base import Effect, register


@register
class LargeOrbit(Effect):
    """The films' force along the orbit (nonlinear), not their tangent K, C at the static equilibrium.

    The linear model holds for orbits small against the clearance. At the paper's unbalance (75 Hz, flows
    near Q_T) the journals whirl on orbits that are no longer small against the clearance; the cavitated
    region breathes with the orbit and the film force is already far from linear in the motion. The steady
    orbit stays periodic at the shaft speed but gains 2X and 3X lines, a static shift of the journals and a
    1X that differs from the linear one in size and phase (harmonic balance of `rotor.orbit_balance`,
    0X-5X, the p-theta film re-solved at 24 points of each revolution with the journal's squeeze velocity
    and the bearing's supply flow; how much at the paper's unbalance: docs/notes/large-orbits.md, "What it
    says about the paper's machine").

    A modelling assumption to know: at each instant the film is solved quasi-statically and consumes the
    supply flow exactly (as the linearized C assumes); the film's own oil storage over a revolution (the
    transient Elrod term) is not modelled. Sub-synchronous whirl is not periodic at the shaft speed and is
    outside this effect: the linear stability at the equilibrium tells whether to expect it.

    It changes the whole response, not one stage of the chain: `simulate` uses it alone (`--effect
    large_orbit`); `identify --effect large_orbit` fits the flows with it (`identify.fit.large_orbit`: the linear
    chain plus the balance's correction and its slope, a few balances, tens of seconds), with probe effects
    only; a diagnosis tries it when a single record shows a 2X line the plain model cannot explain. A
    record's 2X line (`identify`'s `lines_beyond_1x`) is how it shows.
    """

    effect_name = "large_orbit"
    kind_words = "large orbits (the film's nonlinear force)"
    title_words = "orbits too large for the linear film model"
    stage = "response"
    separated_by = ("the 2X line of the record (film nonlinearity grows it with the orbit), or a record at a "
                    "smaller unbalance")
    harmonics: ClassVar[int] = HARMONICS
    points: ClassVar[int] = POINTS

    def spec(self) -> str:
        return self.effect_name
