"""Oil viscosity different from the declared one (hotter or colder oil, another grade)."""

from __future__ import annotations

import numpy as np
import param

from ..model.quantity import Quantity
from .base import Effect, as_array

BEARINGS = ["both", 1, 2]


class Viscosity(Effect):
    """The oil in the film is `factor` x as viscous as the model file declares.

    Oil hotter than declared thins (a VG 68 oil loses about half its viscosity from 40 to 60 °C), so the
    film is less stiff, the journal runs more eccentric and, at the same supply, the bearing starves
    less (the flooded threshold Q_T moves). From one record's 1X alone this mimics a change of both
    supply flows almost exactly; the static shaft position, a second speed or an oil temperature tell
    them apart. Changes the bearings stage: the film's Sommerfeld number scales with the viscosity.
    """

    effect_name = "viscosity"
    stage = "bearings"
    continuous = ("factor",)
    placement = ("bearing",)
    neutral = {"factor": 1.0}
    step = {"factor": 1e-3}
    diagnose_free = ("factor",)
    separated_by = "the static shaft position, a record at a second speed, or an oil temperature reading"

    bearing = param.Selector(default="both", objects=BEARINGS, doc="Bearing(s) whose oil differs: both, 1 or 2")
    factor = Quantity(1.0, bounds=(0.4, 2.5), unit="", doc="True / declared viscosity")

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        if self.bearing != "both" and self.bearing != k + 1:
            return {}
        return {"viscosity_factor": as_array(values, self, "factor", shape)}

    def placements(self):
        return [self.copy(bearing=b) for b in BEARINGS]


def walther_viscosity_ratio(t_c, t_ref_c, nu40_cst: float, nu100_cst: float) -> np.ndarray:
    """Kinematic viscosity at t_c over that at t_ref_c by the Walther / ASTM D341 law.

    log10(log10(nu + 0.7)) = A - B log10(T), T in kelvin, fitted through nu(40 °C) and nu(100 °C).
    (The dynamic viscosity ratio also carries the density's ~0.07 %/K, neglected here.)
    """
    def loglog(nu):
        return np.log10(np.log10(nu + 0.7))

    t40, t100 = np.log10(313.15), np.log10(373.15)
    b = (loglog(nu40_cst) - loglog(nu100_cst)) / (t100 - t40)
    a = loglog(nu40_cst) + b * t40

    def nu(t):
        return 10.0 ** (10.0 ** (a - b * np.log10(np.asarray(t, dtype=float) + 273.15))) - 0.7

    return nu(t_c) / nu(t_ref_c)
