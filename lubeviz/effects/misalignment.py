"""A misaligned bearing: its centre moved from where the model file puts it."""

from __future__ import annotations

import numpy as np
import param

from ..model.quantity import Quantity
from .base import BEARING_CHOICES, Effect, as_array, check_bearing_choice, register

# bearing numbers only: one bearing moves (moving every one together moves the shaft, not its loads)
MISALIGNMENT_CHOICES = [c for c in BEARING_CHOICES if isinstance(c, int)]


@register
class Misalignment(Effect):
    """Bearing `bearing`'s centre sits `dx_um` sideways and `dy_um` up from its declared place (the model file's
    offset plus these): settled foundations, thermal growth, a shimmed housing.

    On three or more supports the shaft held at the journals' new places shares its weight otherwise: a bearing
    lowered by 10 um on the uniform three-bearing test machine sheds a quarter of its load onto its neighbours
    (tests/verification/test_independent_any_machine.py). The loads move the films as a change of flow does, so
    the flows alone would take it up. The probes ride the moved housing: what they read of the journal is its film's
    position, not the move. Changes the bearings stage (the static loads, through `rotor.load_shift`). A machine on
    two supports does not notice: refused there.
    """

    effect_name = "misalignment"
    kind_words = "a bearing out of line"
    title_words = "{bearing} out of line"
    stage = "bearings"
    continuous = ("dx_um", "dy_um")
    placement = ("bearing",)
    neutral = {"dx_um": 0.0, "dy_um": 0.0}
    step = {"dx_um": 0.2, "dy_um": 0.2}
    diagnose_free = ("dy_um",)  # settling and thermal growth: vertical first
    static_load = True
    separated_by = ("an alignment survey (optical or laser) of the bearing centres, or records at several speeds "
                    "(the loads a move sheds do not change with speed, a flow's effect does)")

    bearing = param.Selector(default=1, objects=MISALIGNMENT_CHOICES, doc="Bearing whose centre moved (1..N)")
    dx_um = Quantity(0.0, unit="um", bounds=(-300.0, 300.0), doc="Its centre's move along X from the declared place")
    dy_um = Quantity(0.0, unit="um", bounds=(-300.0, 300.0),
                     doc="Its centre's move along Y (up) from the declared place; < 0: lowered")

    def bearing_offset(self, k: int, values: dict, shape):
        if k != int(self.bearing) - 1:
            return None
        return 1e-6 * np.stack([as_array(values, self, "dx_um", shape), as_array(values, self, "dy_um", shape)], -1)

    def search_values(self, pname: str, machine) -> tuple[float, ...]:
        """Up and down by a quarter of the bearing's clearance: a settled or grown bearing (vertical moves only)."""
        if pname != "dy_um":
            return ()
        c = machine.bearings[int(self.bearing) - 1].clearance * 1e6
        return (-0.25 * c, 0.25 * c)

    def bind(self, machine) -> "Misalignment":
        from ..errors import InputError
        from ..rotor.statics import statically_determinate

        check_bearing_choice(self.bearing, machine, self.effect_name)
        if statically_determinate(machine):
            raise InputError(f"effect {self.label()}: {machine.source or machine.name} stands on two supports, whose "
                             "loads do not depend on where its bearings sit; a misaligned bearing changes nothing "
                             "the probes read there")
        return self

    def placeable(self, rotor) -> bool:
        return len(rotor.bearing_nodes) + len(rotor.supports) >= 3 and int(self.bearing) <= len(rotor.bearing_nodes)

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(bearing=b) for b in range(1, n_bearings + 1)]

    def demo(self, machine) -> "Misalignment":
        return self.bind(machine).shown(dy_um=-10.0)
