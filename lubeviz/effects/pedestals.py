"""Flexible bearing pedestals."""

from __future__ import annotations

import numpy as np
import param

from ..model.quantity import Quantity
from .base import BEARING_CHOICES, Effect, as_array, check_bearing_choice, every_bearing_word, on_bearing, register


@register
class Pedestals(Effect):
    """Each chosen bearing housing is a mass on a spring and damper to ground (isotropic).

    The film acts between journal and housing, so each bearing and its pedestal act in series: at the
    synchronous frequency the journal sees B_eff = B (H + B)^-1 H, with B = K + i Omega C of the film
    and H = (k - Omega^2 m + i Omega c) I of the pedestal, and the housing moves x_h = (H + B)^-1 B x_j.
    Proximity probes are mounted on the housing, so plane k reads the shaft relative to housing k
    (plane 1 with bearing 1, plane 2 with bearing 2). A soft pedestal lowers the critical speed and
    eats damping; the fb and phi it produces look like a change of the film. Changes the rotor stage.
    (ROSS models the same with a point mass on a support linked to the journal by `n_link`.)

    Under a bearing whose model file declares a pedestal (SPEC §8), the effect is that pedestal with another
    stiffness: `stiffness_n_m` replaces the declared one (grout cracked, a bolt loose, a base plate corroded), the
    mass and damping stay as declared (the effect's `mass_kg`, `damping_ns_m` are not used there). The change is a
    spring to ground at the housing's DOFs, which the model already holds (`changes_housing`, `housing_change`).
    On two supports the static loads do not depend on a pedestal. On three or more a softer declared pedestal sags
    further under its load and sheds some of it onto the other supports (`housing_sag`, taken in the flows' load
    shift). A pedestal the file does not declare is a dynamic support only: its static sag is left out, as if the
    machine had been aligned on it.
    """

    effect_name = "pedestals"
    kind_words = "flexible pedestals"
    title_words = "a flexible pedestal under {bearing}"
    stage = "rotor"
    continuous = ("mass_kg", "stiffness_n_m", "damping_ns_m")
    placement = ("bearing",)
    step = {"mass_kg": 0.01, "stiffness_n_m": 1e4, "damping_ns_m": 10.0}
    diagnose_free = ("stiffness_n_m",)
    separated_by = "a housing vibration measurement (seismic probe) or records at several speeds"

    bearing = param.Selector(default="both", objects=BEARING_CHOICES,
                             doc="Bearing(s) on soft pedestals: one (1..N) or every one (both, all)")
    mass_kg = Quantity(50.0, unit="kg", bounds=(0.0, 5000.0), doc="Housing mass (kg)")
    stiffness_n_m = Quantity(2e8, unit="N/m", bounds=(1e5, 1e12),
                             doc="Pedestal stiffness to ground, each direction (N/m)")
    damping_ns_m = Quantity(1e4, unit="N*s/m", bounds=(0.0, 1e8),
                            doc="Pedestal damping to ground, each direction (N*s/m)")

    declared_stiffness = param.Parameter(None, precedence=-1,
                                         doc="Stiffness (N/m) of each pedestal the model file declares, by bearing "
                                             "(0-based); set when bound to a machine")

    def applies(self, k: int) -> bool:
        """Whether this effect puts a pedestal under bearing `k` (one its model file does not declare)."""
        return on_bearing(self.bearing, k) and k not in (self.declared_stiffness or {})

    def changes_housing(self, k: int) -> bool:
        return on_bearing(self.bearing, k) and k in (self.declared_stiffness or {})

    def housing_change(self, k: int, omega: float, values: dict, shape):
        """The declared pedestal's stiffness to ground replaced by `stiffness_n_m` (its mass and damping kept)."""
        if not self.changes_housing(k):
            return None
        s = as_array(values, self, "stiffness_n_m", shape)
        return (s - self.declared_stiffness[k])[..., None, None] * np.eye(2)

    def housing_sag(self, k: int, values: dict, shape):
        """The declared pedestal's compliance change, 1 / `stiffness_n_m` - 1 / declared (m/N)."""
        if not self.changes_housing(k):
            return None
        return 1.0 / as_array(values, self, "stiffness_n_m", shape) - 1.0 / self.declared_stiffness[k]

    def support(self, k: int, B: np.ndarray, omega: float, values: dict, shape):
        """(B_eff, T) for bearing k (0-based), or None: the film B in series with the pedestal."""
        if not self.applies(k):
            return None
        m = as_array(values, self, "mass_kg", shape)
        s = as_array(values, self, "stiffness_n_m", shape)
        c = as_array(values, self, "damping_ns_m", shape)
        h = (s - omega**2 * m + 1j * omega * c)[..., None, None] * np.eye(2)
        inv = np.linalg.inv(h + B)
        return B @ inv @ h, inv @ B

    def housing(self, values: dict) -> tuple[float, float, float]:
        return tuple(float(values.get(p, getattr(self, p))) for p in ("mass_kg", "stiffness_n_m", "damping_ns_m"))

    def typical_values(self, pname: str, chain) -> tuple[float, ...]:
        """A pedestal as stiff as the film it carries (the mean of the declared film's direct stiffnesses at Q_T over
        the bearings it stands under): the two in series halve the support's stiffness."""
        if pname != "stiffness_n_m":
            return ()
        k = [np.trace(src.nominal.coefficients(qt)[0]) / 2 for i, (src, qt) in
             enumerate(zip(chain.sources, chain.q_threshold)) if self.applies(i)]
        k += [0.5 * s for i, s in (self.declared_stiffness or {}).items() if self.changes_housing(i)]  # declared: half
        return (float(np.mean(k)),) if k else ()

    def told(self, std: dict | None = None, machine=None) -> str:
        """On pedestals the model file declares: 'The pedestal under bearing 2 has stiffness 5.1e+07 +- 3e+06 N/m
        (declared 3e+08 N/m): softer than declared.'; elsewhere the story's words."""
        if machine is None:
            return super().told(std, machine)
        effect = self.bind(machine)
        changed = [k for k in range(len(machine.bearings)) if effect.changes_housing(k)]
        if not changed:
            return super().told(std, machine)
        s = (std or {}).get("stiffness_n_m")
        value = f"{self.stiffness_n_m:.3g}{'' if s is None else f' +- {s:.2g}'} N/m"
        declared = " and ".join(f"{effect.declared_stiffness[k]:.3g} N/m" for k in changed)
        where = " and ".join(f"bearing {k + 1}" for k in changed)
        side = "softer" if all(self.stiffness_n_m < effect.declared_stiffness[k] for k in changed) else \
            "stiffer" if all(self.stiffness_n_m > effect.declared_stiffness[k] for k in changed) else "other"
        return (f"The pedestal{'s' if len(changed) > 1 else ''} under {where} {'have' if len(changed) > 1 else 'has'} "
                f"stiffness {value} (declared {declared}): {side} than declared.")

    def bind(self, machine) -> "Pedestals":
        check_bearing_choice(self.bearing, machine, self.effect_name)
        declared = {k: float(b.pedestal.stiffness) for k, b in enumerate(machine.bearings)
                    if getattr(b, "pedestal", None) is not None}
        if declared == (self.declared_stiffness or {}):
            return self
        return self.copy(declared_stiffness=declared or None)

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(bearing=b) for b in (every_bearing_word(n_bearings), *range(1, n_bearings + 1))]
