"""The operating point of a machine: shaft speed and the oil supply flow of each bearing."""

from __future__ import annotations

import param

from ..units import M3S_PER_MLMIN
from .quantity import Quantity, positive

_FLOW = dict(unit="m^3/s", display_unit="ml/min", display_scale=1.0 / M3S_PER_MLMIN)


class OperatingPoint(param.Parameterized):
    """Shaft speed and supply flows (SI inside; flows are shown in ml/min, SPEC §1)."""

    speed = positive(75.0, "Hz", "Shaft speed (rev/s)")
    q1 = Quantity(546.0 * M3S_PER_MLMIN, bounds=(0.0, None), inclusive_bounds=(False, True),
                  doc="Oil supply flow of bearing 1", **_FLOW)
    q2 = Quantity(546.0 * M3S_PER_MLMIN, bounds=(0.0, None), inclusive_bounds=(False, True),
                  doc="Oil supply flow of bearing 2", **_FLOW)

    @property
    def omega(self) -> float:
        """Shaft speed in rad/s."""
        import math

        return 2.0 * math.pi * self.speed

    @property
    def flows(self) -> tuple[float, float]:
        return (self.q1, self.q2)
