"""A record's oil temperature reading (`oil_temperature_c`) as a declared effect and a budget term.

With an `[oil]` in the model file, a temperature read on the machine fixes the film's viscosity: the
identification (and a diagnosis) then runs with `oil_temperature:temperature_c=T` held, and the model
budget carries the reading's uncertainty as a viscosity tolerance, |d ln mu / dT| x READING_STD_K (about
4.5 % per kelvin for a VG 100 oil near 50 °C). That is what separates hotter oil from less oil on one
record (issue 12): the oil is no longer a free nuisance. Without an `[oil]`, or when the user declares
the oil with an effect, the reading is not used and a warning says so.
"""

from __future__ import annotations

import numpy as np

# 1 sigma of "the oil temperature in the film" from a reading: an RTD in the drain reads the film's
# mean temperature to about +-2 K (95 %); the film's effective temperature is a modelling choice.
READING_STD_K = 1.0


def oil_reading(record, machine, effects=()) -> tuple[tuple, float, tuple[str, ...]]:
    """(effects to add, viscosity tolerance for the budget (relative, 1 sigma), warnings) of `record`."""
    t = getattr(record, "oil_temperature_c", None)
    if t is None:
        return (), 0.0, ()
    where = str(getattr(record, "source", None) or "record")
    if any(e.oil_viscosity for e in effects):
        return (), 0.0, (f"{where}: oil_temperature_c = {t:g} °C not used: an effect declares the oil",)
    oil = getattr(machine, "oil", None)
    if oil is None:
        return (), 0.0, (f"{where}: oil_temperature_c = {t:g} °C not used: the model file "
                         f"{machine.source or machine.name} declares no [oil] (grade and temperature), so a "
                         "temperature cannot be turned into a viscosity",)
    from ...effects import OilTemperature

    h = 0.5
    slope = abs(float(np.log(oil.factor(t + h) / oil.factor(t - h)))) / (2 * h)  # |d ln mu / dT|, 1/K
    effect = OilTemperature(bearing="both", temperature_c=float(t)).bind(machine)
    return (effect,), slope * READING_STD_K, ()


def budget_with_reading(budget, tolerance: float):
    """`budget` (None: the default) with its viscosity tolerance at least `tolerance`."""
    from ..forward.budget import ModelBudget

    budget = ModelBudget() if budget is None else budget
    if tolerance > budget.viscosity:
        budget = ModelBudget(**{**budget.param.values(), "name": None, "viscosity": float(tolerance)})
    return budget
