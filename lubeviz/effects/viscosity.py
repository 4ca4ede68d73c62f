"""Oil viscosity different from the declared one (hotter or colder oil, another grade)."""

from __future__ import annotations

import param

from ..model.quantity import Quantity
from .base import Effect, as_array, register

BEARINGS = ["both", 1, 2]


@register
class Viscosity(Effect):
    """The oil in the film is `factor` x as viscous as the model file declares.

    Oil hotter than declared thins (a VG 68 oil loses about half its viscosity from 40 to 60 °C), so the
    film is less stiff, the journal runs more eccentric and, at the same supply, the bearing starves
    less (the flooded threshold Q_T moves). From one record's 1X alone this mimics a change of both
    supply flows almost exactly; the static shaft position, a second speed or an oil temperature tell
    them apart. Changes the bearings stage: the film's Sommerfeld number scales with the viscosity.
    With an `[oil]` in the model file, a factor is also an oil temperature (`Oil.temperature_for_factor`;
    the `oil_temperature` effect declares one).
    """

    effect_name = "viscosity"
    stage = "bearings"
    continuous = ("factor",)
    placement = ("bearing",)
    neutral = {"factor": 1.0}
    step = {"factor": 1e-3}
    diagnose_free = ("factor",)
    oil_viscosity = True
    separated_by = "the static shaft position, a record at a second speed, or an oil temperature reading"

    bearing = param.Selector(default="both", objects=BEARINGS, doc="Bearing(s) whose oil differs: both, 1 or 2")
    factor = Quantity(1.0, bounds=(0.4, 2.5), unit="", doc="True / declared viscosity")

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        if self.bearing != "both" and self.bearing != k + 1:
            return {}
        return {"viscosity_factor": as_array(values, self, "factor", shape)}

    def placements(self):
        return [self.copy(bearing=b) for b in BEARINGS]

    def demo(self, machine) -> "Viscosity":
        return self.shown(factor=0.7).bind(machine)  # oil 30 % thinner: what a hot day does
