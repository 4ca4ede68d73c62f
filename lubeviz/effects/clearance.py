"""Bearing wear: a radial clearance different from the declared one."""

from __future__ import annotations

import param

from ..model.quantity import Quantity
from .base import BEARING_CHOICES, check_bearing_choice, first_bearing, on_bearing, Effect, as_array, register


WORN_SEARCH = 1.35  # x the declared clearance: where a fit's search also looks (a worn bearing)


@register
class Clearance(Effect):
    """Bearing `bearing` has radial clearance `clearance_um` instead of the declared one.

    A worn bearing has a larger clearance: a lower Sommerfeld number (S ~ 1/c^2), a softer and less
    damped film, a higher flooded threshold (Q_T ~ c), and a static journal position lower in a larger
    circle; the rest position of SPEC §6 ((0, -c) from the bearing centre) moves down with it. Changes
    the bearings stage. `clearance_um` given as None means the declared clearance (a fit starts there).
    """

    effect_name = "clearance"
    kind_words = "bearing clearance (wear)"
    title_words = "the clearance of {bearing} (wear)"
    stage = "bearings"
    continuous = ("clearance_um",)
    placement = ("bearing",)
    step = {"clearance_um": 0.05}
    diagnose_free = ("clearance_um",)
    separated_by = "the static shaft position (a worn bearing sits lower), or a record at a second speed"

    bearing = param.Selector(default=1, objects=BEARING_CHOICES,
                             doc="Bearing whose clearance differs: one (1..N) or every one (both, all)")
    clearance_um = Quantity(None, unit="um", allow_None=True, bounds=(20.0, 1000.0),
                                doc="True radial clearance (um); None: the declared one")

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        if not on_bearing(self.bearing, k):
            return {}
        if self.clearance_um is None and "clearance_um" not in values:
            return {}
        return {"clearance": 1e-6 * as_array(values, self, "clearance_um", shape)}

    def declared(self, pname: str, machine) -> float:
        return machine.bearings[first_bearing(self.bearing)].clearance * 1e6

    def search_values(self, pname: str, machine) -> tuple[float, ...]:
        return (WORN_SEARCH * self.declared(pname, machine),)  # worn: a starved film mimics a larger clearance


    def bind(self, machine) -> "Clearance":
        check_bearing_choice(self.bearing, machine, self.effect_name)
        return self

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(bearing=b) for b in range(1, n_bearings + 1)]

    def demo(self, machine) -> "Clearance":
        k = first_bearing(self.bearing)
        return self.shown(clearance_um=round(1.25 * machine.bearings[k].clearance * 1e6, 1))  # worn by 25 %
