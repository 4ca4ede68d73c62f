"""Oil at another temperature than declared: the viscosity through the oil's Walther law."""

from __future__ import annotations

import numpy as np
import param

from ..errors import InputError
from ..model.oil import Oil
from ..model.quantity import Quantity
from .base import BEARING_CHOICES, Effect, as_array, every_bearing_word, on_bearing, register


@register
class OilTemperature(Effect):
    """The oil in the film is at `temperature_c` instead of the model file's declared temperature.

    The same physics as `viscosity`, told in the unit an operator reads on the machine: the model file's
    `[oil]` (ISO VG grade, or its viscosities at 40 and 100 °C) gives the viscosity at any temperature by
    the Walther law of ASTM D341 (a VG 100 oil loses about a third of its viscosity from 40 to 50 °C and
    about 60 % from 40 to 60 °C). Needs a model file with an `[oil]` table. A diagnosis
    fits the `viscosity` factor and states the temperature it means; this effect is for declaring a
    measured or assumed oil temperature (`simulate`, `identify --effect oil_temperature:temperature_c=55`)
    and for the Rotor page.
    """

    effect_name = "oil_temperature"
    kind_words = "oil temperature"
    title_words = "the oil's temperature in {bearing}"
    stage = "bearings"
    continuous = ("temperature_c",)
    placement = ("bearing",)
    step = {"temperature_c": 0.01}
    diagnose_free = ()
    diagnosed = False  # a diagnosis fits `viscosity` (the same effect) and converts
    oil_viscosity = True
    separated_by = Effect.separated_by

    bearing = param.Selector(default="both", objects=BEARING_CHOICES,
                             doc="Bearing(s) whose oil is at this temperature: one (1..N) or every one (both, all)")
    temperature_c = Quantity(None, unit="°C", allow_None=True, bounds=(-20.0, 150.0),
                                 doc="Oil temperature in the film (°C); None: the model file's declared one")
    oil = param.ClassSelector(class_=Oil, default=None, allow_None=True, precedence=-1,
                              doc="The machine's oil (set when the effect is bound to a machine)")

    def bind(self, machine) -> "OilTemperature":
        if self.oil is not None:
            return self
        if getattr(machine, "oil", None) is None:
            raise InputError(f"effect oil_temperature: the model file {machine.source or machine.name} declares no "
                             "oil; add an [oil] table (iso_vg, temperature_c) or use viscosity:factor=…")
        return self.copy(oil=machine.oil)

    def declared(self, pname: str, machine) -> float:
        oil = self.oil or getattr(machine, "oil", None)
        if pname == "temperature_c" and oil is not None:
            return float(oil.temperature_c)
        return super().declared(pname, machine)

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        if not on_bearing(self.bearing, k):
            return {}
        if self.temperature_c is None and "temperature_c" not in values:
            return {}
        if self.oil is None:
            raise InputError("effect oil_temperature is not bound to a machine with an [oil] table")
        t = as_array(values, self, "temperature_c", shape)
        return {"viscosity_factor": np.asarray(self.oil.factor(t), dtype=float)}


    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(bearing=b) for b in (every_bearing_word(n_bearings), *range(1, n_bearings + 1))]

    def demo(self, machine) -> "OilTemperature":
        bound = self.bind(machine)  # raises for a machine without an [oil]
        return bound.shown(temperature_c=round(bound.oil.temperature_c + 15.0, 1))  # oil 15 °C hotter
