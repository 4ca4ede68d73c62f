"""A second unbalance plane."""

from __future__ import annotations

import numpy as np
import param

from ..rotor.response import Unbalance, unbalance_force
from ..model.quantity import Quantity
from .base import Effect, as_array, register


@register
class Unbalance2(Effect):
    """An unbalance at `node` of `ratio` x the main moment, at `phase_deg` from the main one.

    A coupling, a second disc or a thermal bow of one disc adds an unbalance elsewhere on the rotor. The
    response is no longer one unbalance shape scaled by one complex factor, so the invariants (fb, phi at
    each plane and Zf2/Zf1) change although the bearings have not. Changes the rotor stage (forcing).
    """

    effect_name = "unbalance2"
    title_words = "a second unbalance at {node}"
    kind_words = "a second unbalance"
    stage = "rotor"
    continuous = ("ratio", "phase_deg")
    placement = ("node",)
    neutral = {"ratio": 0.0}
    step = {"ratio": 1e-3, "phase_deg": 0.05}
    diagnose_free = ("ratio", "phase_deg")
    separated_by = "a trial weight run or a record at a second speed (the mode shapes change the mix)"
    forcing = True

    node = param.Integer(10, bounds=(1, None), doc="Rotor node of the second unbalance (paper numbering)")
    ratio = Quantity(0.3, unit="", bounds=(0.0, 5.0), doc="Its moment over the main unbalance's")
    phase_deg = Quantity(0.0, unit="deg", bounds=(-360.0, 360.0), doc="Its phase relative to the main unbalance (deg)")

    def forcing_shapes(self, rotor, omega: float, machine) -> list[np.ndarray]:
        """The force of an unbalance equal to the main one, moved to `node`: weight 1 reproduces it."""
        return [unbalance_force(rotor, omega, [Unbalance(rotor.check_node(self.node, "unbalance2 node"),
                                                         machine.unbalance_moment, machine.unbalance_phase)])]

    def forcing_weights(self, values: dict, shape) -> np.ndarray:
        r = as_array(values, self, "ratio", shape)
        ph = np.radians(as_array(values, self, "phase_deg", shape))
        return (r * np.exp(1j * ph))[..., None]

    def scan_nodes(self, rotor) -> tuple[int, ...]:
        """Every node: a coupling half, a fan, a loose part or a bow of one section can sit anywhere."""
        return tuple(range(1, rotor.n_nodes + 1))
