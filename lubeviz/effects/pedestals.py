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

    def applies(self, k: int) -> bool:
        return on_bearing(self.bearing, k)

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
        return (float(np.mean(k)),) if k else ()

    def bind(self, machine) -> "Pedestals":
        check_bearing_choice(self.bearing, machine, self.effect_name)
        return self

    def placeable(self, rotor) -> bool:
        return not any(self.applies(k) and rotor.housing("bearing", k) is not None
                       for k in range(len(rotor.bearing_nodes)))

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(bearing=b) for b in (every_bearing_word(n_bearings), *range(1, n_bearings + 1))]
