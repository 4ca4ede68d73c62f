"""Oil viscosity different from the declared one (hotter or colder oil, another grade)."""

from __future__ import annotations

import param

from ..model.quantity import Quantity
from .base import BEARING_CHOICES, Effect, as_array, check_bearing_choice, every_bearing_word, on_bearing, register


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
    kind_words = "oil viscosity"
    title_words = "the oil's viscosity in {bearing}"
    stage = "bearings"
    continuous = ("factor",)
    placement = ("bearing",)
    neutral = {"factor": 1.0}
    step = {"factor": 1e-3}
    search = {"factor": (0.7, 1.4)}  # oil 30 % thinner, 40 % thicker: the flows mimic either from 1
    diagnose_free = ("factor",)
    oil_viscosity = True
    separated_by = "the static shaft position, a record at a second speed, or an oil temperature reading"

    bearing = param.Selector(default="both", objects=BEARING_CHOICES,
                             doc="Bearing(s) whose oil differs: one (1..N) or every one (both, all)")
    factor = Quantity(1.0, bounds=(0.4, 2.5), unit="", doc="True / declared viscosity")

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        if not on_bearing(self.bearing, k):
            return {}
        return {"viscosity_factor": as_array(values, self, "factor", shape)}

    def bind(self, machine) -> "Viscosity":
        check_bearing_choice(self.bearing, machine, self.effect_name)
        return self

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(bearing=b) for b in (every_bearing_word(n_bearings), *range(1, n_bearings + 1))]

    def demo(self, machine) -> "Viscosity":
        return self.shown(factor=0.7).bind(machine)  # oil 30 % thinner: what a hot day does
