"""The oil: its grade and how its viscosity changes with temperature (optional `[oil]` of a model file).

The bearings of a model file declare the viscosity the film sees (`viscosity_pa_s`). When the file also
declares the oil (`[oil]`: an ISO VG grade, or the kinematic viscosities at 40 and 100 °C, and the
temperature at which the declared viscosity holds), a temperature becomes a viscosity: the oil hotter
than declared by so many degrees (the `oil_temperature` effect), or an oil temperature read on the
machine and written in a record (SPEC §6 extension `oil_temperature_c`), which settles the oil's
viscosity and so separates "hotter oil" from "less oil" (issue 12).

Kinematic viscosity by the Walther equation of ASTM D341,

    log10 log10(nu + 0.7) = A - B log10(T),   nu in mm^2/s (cSt), T in kelvin,

fitted through nu(40 °C) and nu(100 °C); density by the usual mineral-oil expansion,
rho(T) = rho15 (1 - 6.5e-4 (T - 15 °C)); dynamic viscosity mu = rho nu.
"""

from __future__ import annotations

import math

import numpy as np
import param

from .quantity import Quantity, positive

# nu(100 °C) in cSt of a mineral oil of viscosity index ~100 for each ISO 3448 grade (nu(40 °C) = grade);
# typical catalogue values, within a few % of what VI = 95-105 gives. A model file may give nu100_cst.
ISO_VG_NU100_CST = {10: 2.6, 15: 3.3, 22: 4.3, 32: 5.4, 46: 6.8, 68: 8.7, 100: 11.3, 150: 14.8, 220: 19.0,
                    320: 24.0, 460: 30.5, 680: 39.0}
EXPANSION_PER_K = 6.5e-4  # relative density change per kelvin, mineral oil


def walther_nu_cst(t_c, nu40_cst: float, nu100_cst: float) -> np.ndarray:
    """Kinematic viscosity (cSt) at t_c (°C) by the Walther / ASTM D341 law through the two points."""
    def loglog(nu):
        return math.log10(math.log10(nu + 0.7))

    t40, t100 = math.log10(313.15), math.log10(373.15)
    b = (loglog(nu40_cst) - loglog(nu100_cst)) / (t100 - t40)
    a = loglog(nu40_cst) + b * t40
    return 10.0 ** (10.0 ** (a - b * np.log10(np.asarray(t_c, dtype=float) + 273.15))) - 0.7


class Oil(param.Parameterized):
    """A lubricating oil: its viscosity-temperature law and the temperature the model file's viscosity is at."""

    grade = param.String("", doc="ISO VG grade as written in the model file (e.g. 'ISO VG 100'), or '' if given by nu40/nu100")
    nu40_cst = positive(100.0, "cSt", "Kinematic viscosity at 40 °C")
    nu100_cst = positive(11.3, "cSt", "Kinematic viscosity at 100 °C")
    density_15c = positive(870.0, "kg/m^3", "Density at 15 °C")
    temperature_c = Quantity(40.0, bounds=(-30.0, 200.0), unit="°C",
                             doc="Oil temperature at which the bearings' declared viscosity holds")

    @param.depends("nu40_cst", "nu100_cst", watch=True, on_init=True)
    def _check(self):
        if not self.nu100_cst < self.nu40_cst:
            raise ValueError(f"nu100_cst = {self.nu100_cst:g} must be below nu40_cst = {self.nu40_cst:g} "
                             "(an oil thins when heated)")

    def kinematic_cst(self, t_c) -> np.ndarray:
        return walther_nu_cst(t_c, self.nu40_cst, self.nu100_cst)

    def density(self, t_c) -> np.ndarray:
        return self.density_15c * (1.0 - EXPANSION_PER_K * (np.asarray(t_c, dtype=float) - 15.0))

    def dynamic_viscosity(self, t_c) -> np.ndarray:
        """mu (Pa s) at t_c (°C)."""
        return self.kinematic_cst(t_c) * 1e-6 * self.density(t_c)

    def factor(self, t_c) -> np.ndarray:
        """mu(t_c) / mu(declared temperature): the viscosity factor of an oil at t_c."""
        return self.dynamic_viscosity(t_c) / self.dynamic_viscosity(self.temperature_c)

    def temperature_for_factor(self, factor) -> np.ndarray:
        """The oil temperature (°C) at which the viscosity is `factor` x the declared one (inverse of `factor`)."""
        f = np.atleast_1d(np.asarray(factor, dtype=float))
        out = np.empty_like(f)
        for i, fi in enumerate(f.flat):  # a monotone 1-D root per value: bisection in ln(mu)
            lo, hi = -30.0, 200.0
            target = math.log(fi)
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if math.log(float(self.factor(mid))) > target:
                    lo = mid
                else:
                    hi = mid
            out.flat[i] = 0.5 * (lo + hi)
        return out.reshape(np.shape(factor)) if np.ndim(factor) else float(out[0])

    def describe(self) -> str:
        name = self.grade or f"oil ({self.nu40_cst:g} cSt at 40 °C, {self.nu100_cst:g} at 100 °C)"
        return f"{name}, declared at {self.temperature_c:g} °C"


def oil_from_table(t: dict, where: str) -> Oil:
    """An Oil from a model file's `[oil]` table (keys already typed): `iso_vg` or `nu40_cst` + `nu100_cst`,
    optional `density_kg_m3`, and `temperature_c`. Raises ValueError with the field named."""
    if "iso_vg" in t:
        if "nu40_cst" in t:
            raise ValueError(f"{where}: give iso_vg or nu40_cst, not both")
        vg = t["iso_vg"]
        if vg not in ISO_VG_NU100_CST:
            raise ValueError(f"{where}: iso_vg: {vg} is not an ISO 3448 grade; expected one of "
                             f"{', '.join(map(str, ISO_VG_NU100_CST))}")
        nu40, nu100, grade = float(vg), t.get("nu100_cst", ISO_VG_NU100_CST[vg]), f"ISO VG {vg}"
    elif "nu40_cst" in t and "nu100_cst" in t:
        nu40, nu100, grade = t["nu40_cst"], t["nu100_cst"], ""
    else:
        raise ValueError(f"{where}: expected iso_vg (with an optional nu100_cst) or nu40_cst and nu100_cst")
    if "temperature_c" not in t:
        raise ValueError(f"{where}: missing key 'temperature_c' (the oil temperature at which the bearings' "
                         "viscosity_pa_s holds)")
    return Oil(grade=grade, nu40_cst=nu40, nu100_cst=nu100, density_15c=t.get("density_kg_m3", 870.0),
               temperature_c=t["temperature_c"])
