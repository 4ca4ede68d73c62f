"""A probe pair mounted at other angles than declared."""

from __future__ import annotations

import numpy as np
import param

from ..model.quantity import Quantity
from .base import PLANE_CHOICES, Effect, as_array, register


def rotation(angle_rad) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


@register
class ProbeRotation(Effect):
    """The probe pair of `plane` sits `angle_deg` (from +X towards +Y) away from its declared angles.

    Each probe reads the displacement along its real direction, declared angle + a; resolving with the
    declared angles gives R(-a) d. The orbit's shape is unchanged but its angle phi is off by -a, which
    the identification otherwise blames on the bearings. Changes the probes stage.
    """

    effect_name = "probe_rotation"
    kind_words = "a turned probe pair"
    title_words = "the probes of {plane} turned"
    stage = "probes"
    continuous = ("angle_deg",)
    placement = ("plane",)
    neutral = {"angle_deg": 0.0}
    step = {"angle_deg": 0.01}
    search = {"angle_deg": (-6.0, 6.0)}
    diagnose_free = ("angle_deg",)
    separated_by = "checking the probes' mounting angles, or a record at a second speed (a probe error does not move with the machine)"

    plane = param.Selector(default=1, objects=PLANE_CHOICES, doc="Measurement plane of the rotated pair (1..P)")
    angle_deg = Quantity(5.0, unit="deg", bounds=(-45.0, 45.0), doc="Rotation of the pair, + from +X towards +Y (deg)")

    def probe_matrix(self, plane: int, angles_deg, values: dict, shape):
        if plane + 1 != self.plane:
            return None
        return rotation(-np.radians(as_array(values, self, "angle_deg", shape)))


    def placements(self, *, n_planes: int, n_bearings: int, n_supports: int = 0):
        return [self.copy(plane=p) for p in range(1, n_planes + 1)]
