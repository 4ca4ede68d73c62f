"""A residual shaft bow."""

from __future__ import annotations

import math

import numpy as np
import param

from ..errors import InputError
from ..rotor.elements import THETA_X, THETA_Y, X, Y, node_dofs
from ..model.quantity import Quantity
from .base import Effect, as_array, register


BOW_REACH = 0.05  # a bow's amplitude is given at a node where its shape is at least this share of its peak


def bow_shape(rotor, node: int) -> np.ndarray:
    """Complex nodal shape (n_dof) of a unit bow turning with the shaft, 1 m at `node`.

    The unstressed centreline is bent as s(z) = sin(pi (z - z1)/(z2 - z1)) between the bearing centres
    z1, z2 (zero outside): x = s cos(Omega t), y = s sin(Omega t), so X = s, Y = -i s, and the section
    rotations theta_y = dx/dz = s', theta_x = -dy/dz = i s'.
    """
    z = rotor.node_z
    z1, z2 = (z[n - 1] for n in rotor.bearing_nodes[:2])
    span = z2 - z1
    inside = (z >= z1 - 1e-12) & (z <= z2 + 1e-12)
    s = np.where(inside, np.sin(math.pi * (z - z1) / span), 0.0)
    ds = np.where(inside, math.pi / span * np.cos(math.pi * (z - z1) / span), 0.0)
    s_node = s[node - 1]
    if abs(s_node) < BOW_REACH:
        raise InputError(f"bow amplitude node {node} lies at or outside the bearings (the bow there is "
                         f"{s_node:.3f} of its peak); expected a node between the bearings")
    q = np.zeros(rotor.n_dof, dtype=complex)
    for n in range(1, rotor.n_nodes + 1):
        d = node_dofs(n)
        q[d[X]], q[d[Y]] = s[n - 1], -1j * s[n - 1]
        q[d[THETA_Y]], q[d[THETA_X]] = ds[n - 1], 1j * ds[n - 1]
    return q / s_node


@register
class Bow(Effect):
    """A residual bow of `amplitude_um` at `node`, turning with the shaft at `phase_deg` from the unbalance.

    A shaft bent by a thermal gradient, a rub or storage carries its bent line round with it: the
    shaft's elastic forces K_shaft (q - q_bow) push it towards the bent line, a 1X force whose shape is
    not the unbalance's, so the invariants change. Its effect does not grow with speed squared like an
    unbalance's, which a second speed shows. Changes the rotor stage (forcing). Shape: `bow_shape`.
    """

    effect_name = "bow"
    stage = "rotor"
    continuous = ("amplitude_um", "phase_deg")
    placement = ("node",)
    neutral = {"amplitude_um": 0.0}
    step = {"amplitude_um": 0.01, "phase_deg": 0.05}
    diagnose_free = ("amplitude_um", "phase_deg")
    separated_by = "a slow-roll record (a bow reads at low speed, an unbalance does not) or a second speed"
    forcing = True

    node = param.Integer(None, allow_None=True, bounds=(1, None),
                         doc="Node where the bow's amplitude is given (between the bearings); None: the node nearest "
                             "midway between the first two bearings")
    amplitude_um = Quantity(10.0, unit="um", bounds=(0.0, 1000.0), doc="Bow at `node` (um)")
    phase_deg = Quantity(0.0, unit="deg", bounds=(-360.0, 360.0), doc="Its angle relative to the main unbalance (deg)")

    def forcing_shapes(self, rotor, omega: float, machine) -> list[np.ndarray]:
        q = bow_shape(rotor, self.amplitude_node(rotor)) * np.exp(1j * machine.unbalance_phase)
        return [rotor.K @ q]  # the shaft's elastic force towards the bent line (bearings excluded)

    def forcing_weights(self, values: dict, shape) -> np.ndarray:
        a = 1e-6 * as_array(values, self, "amplitude_um", shape)
        ph = np.radians(as_array(values, self, "phase_deg", shape))
        return (a * np.exp(1j * ph))[..., None]

    def amplitude_node(self, rotor) -> int:
        """`node`, or the node nearest midway between the first two bearings. The bow's shape is one sine between
        them whatever the node: the node only says where its amplitude is quoted, so a diagnosis does not scan it
        (every node would fit alike) and quotes it midway."""
        if self.node is not None:
            return int(self.node)
        z = rotor.node_z
        z1, z2 = (z[n - 1] for n in rotor.bearing_nodes[:2])
        return int(np.argmin(np.abs(z - 0.5 * (z1 + z2)))) + 1

    def values(self) -> dict:
        v = super().values()
        if v["node"] is None:  # not given: quoted midway, not written back as None
            del v["node"]
        return v

    def told(self, std: dict | None = None, machine=None) -> str:
        return super().told(std, machine).replace(" at node None", " midway between the bearings")
