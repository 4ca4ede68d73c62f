"""A probe whose sensitivity differs from its calibration."""

from __future__ import annotations

import numpy as np
import param

from ..model.quantity import Quantity
from .base import CHANNEL_CHOICES, Effect, as_array, register

CHANNELS = CHANNEL_CHOICES


@register
class ProbeGain(Effect):
    """Probe `channel` reads `gain` x the displacement along its direction.

    A proximity probe calibrated for another shaft material, or with a drifting driver, reads 5-20 %
    off. Its plane's orbit is stretched along that probe, so fb and phi change. With the probes at
    angles a, b (rows u(a), u(b) of P), the resolved reading is P^-1 G P d. Changes the probes stage.
    """

    effect_name = "probe_gain"
    kind_words = "a probe's gain"
    title_words = "the gain of probe {channel}"
    stage = "probes"
    continuous = ("gain",)
    placement = ("channel",)
    neutral = {"gain": 1.0}
    step = {"gain": 1e-4}
    search = {"gain": (0.88, 1.15)}
    diagnose_free = ("gain",)
    separated_by = "a probe calibration check, or a record at a second speed (a probe error does not move with the machine)"

    channel = param.Selector(default="x1", objects=CHANNELS, doc="Probe channel: x1, y1, ... xP, yP (P planes)")
    gain = Quantity(1.1, unit="", bounds=(0.3, 3.0), doc="Actual over declared sensitivity")

    def probe_matrix(self, plane: int, angles_deg, values: dict, shape):
        idx = CHANNELS.index(self.channel)
        if idx // 2 != plane:
            return None
        a = np.radians(np.asarray(angles_deg, dtype=float))
        P = np.array([[np.cos(a[0]), np.sin(a[0])], [np.cos(a[1]), np.sin(a[1])]])
        g = as_array(values, self, "gain", shape)
        G = np.zeros(tuple(shape) + (2, 2))
        G[..., 0, 0] = 1.0
        G[..., 1, 1] = 1.0
        G[..., idx % 2, idx % 2] = g
        return np.linalg.inv(P) @ G @ P

    def placements(self, *, n_planes: int, n_bearings: int, n_supports: int = 0):
        return [self.copy(channel=c) for c in CHANNELS[:2 * n_planes]]
