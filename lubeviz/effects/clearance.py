"""Bearing wear: a radial clearance different from the declared one."""

from __future__ import annotations

import param

from ..model.quantity import Quantity
from .base import Effect, as_array, register


@register
class Clearance(Effect):
    """Bearing `bearing` has radial clearance `clearance_um` instead of the declared one.

    A worn bearing has a larger clearance: a lower Sommerfeld number (S ~ 1/c^2), a softer and less
    damped film, a higher flooded threshold (Q_T ~ c), and a static journal position lower in a larger
    circle; the rest position of SPEC §6 ((0, -c) from the bearing centre) moves down with it. Changes
    the bearings stage. `clearance_um` given as None means the declared clearance (a fit starts there).
    """

    effect_name = "clearance"
    stage = "bearings"
    continuous = ("clearance_um",)
    placement = ("bearing",)
    step = {"clearance_um": 0.05}
    diagnose_free = ("clearance_um",)
    separated_by = "the static shaft position (a worn bearing sits lower), or a record at a second speed"

    bearing = param.Selector(default=1, objects=[1, 2, "both"], doc="Bearing whose clearance differs: 1, 2 or both")
    clearance_um = Quantity(None, unit="um", allow_None=True, bounds=(20.0, 1000.0),
                                doc="True radial clearance (um); None: the declared one")

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        if self.bearing != "both" and self.bearing != k + 1:
            return {}
        if self.clearance_um is None and "clearance_um" not in values:
            return {}
        return {"clearance": 1e-6 * as_array(values, self, "clearance_um", shape)}

    def declared(self, pname: str, machine) -> float:
        k = 0 if self.bearing in (1, "both") else 1
        return machine.bearings[k].clearance * 1e6


    def placements(self):
        return [self.copy(bearing=b) for b in (1, 2)]

    def demo(self, machine) -> "Clearance":
        k = 0 if self.bearing in (1, "both") else 1
        return self.shown(clearance_um=round(1.25 * machine.bearings[k].clearance * 1e6, 1))  # worn by 25 %
