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


def support_nodes(rotor) -> tuple[int, ...]:
    """The nodes where the shaft is held, along it: its fluid-film bearings and constant supports."""
    return tuple(sorted({*rotor.bearing_nodes, *(int(s[0]) for s in rotor.supports)}))


def span_nodes(rotor, span: int | None) -> tuple[int, int]:
    """The end nodes of a bow's `span`: None, between the outermost fluid-film bearings; k, between the k-th and
    (k+1)-th of `support_nodes` (bearings and constant supports along the shaft)."""
    if span is None:
        nodes = rotor.bearing_nodes
        return min(nodes), max(nodes)
    held = support_nodes(rotor)
    if not 1 <= span < len(held):
        raise InputError(f"bow span {span}: expected 1-{len(held) - 1}, the spans between the {len(held)} places "
                         f"the shaft is held (nodes {', '.join(map(str, held))})")
    return held[span - 1], held[span]


def bow_shape(rotor, node: int, span: int | None = None) -> np.ndarray:
    """Complex nodal shape (n_dof) of a unit bow turning with the shaft, 1 m at `node`.

    The unstressed centreline is bent as s(z) = sin(pi (z - z1)/(z2 - z1)) over the `span` from z1 to z2
    (`span_nodes`; zero outside): x = s cos(Omega t), y = s sin(Omega t), so X = s, Y = -i s, and the section
    rotations theta_y = dx/dz = s', theta_x = -dy/dz = i s'.
    """
    z = rotor.node_z
    z1, z2 = (z[n - 1] for n in span_nodes(rotor, span))
    span = z2 - z1
    inside = (z >= z1 - 1e-12) & (z <= z2 + 1e-12)
    s = np.where(inside, np.sin(math.pi * (z - z1) / span), 0.0)
    ds = np.where(inside, math.pi / span * np.cos(math.pi * (z - z1) / span), 0.0)
    s_node = s[node - 1]
    if abs(s_node) < BOW_REACH:
        raise InputError(f"bow amplitude node {node} lies at or outside the ends of its span (the bow there is "
                         f"{s_node:.3f} of its peak); expected a node between them")
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
    unbalance's, which a second speed shows. Changes the rotor stage (forcing). Shape: `bow_shape`, one sine over
    its `span`: on a shaft held at three or more places a bow may sit in any one span (a thermal bow where a wheel
    rubbed) or run over the whole shaft, and those shapes load the bearings differently, so a diagnosis tries each.
    """

    effect_name = "bow"
    kind_words = "a bowed shaft"
    stage = "rotor"
    continuous = ("amplitude_um", "phase_deg")
    placement = ("node", "span")
    neutral = {"amplitude_um": 0.0}
    step = {"amplitude_um": 0.01, "phase_deg": 0.05}
    diagnose_free = ("amplitude_um", "phase_deg")
    separated_by = "a slow-roll record (a bow reads at low speed, an unbalance does not) or a second speed"
    forcing = True

    node = param.Integer(None, allow_None=True, bounds=(1, None),
                         doc="Node where the bow's amplitude is given (inside its span); None: the node nearest "
                             "midway along the span")
    span = param.Integer(None, allow_None=True, bounds=(1, None),
                         doc="Where the shaft is bent: None, one sine between the outermost fluid-film bearings; k, "
                             "one sine between the k-th and (k+1)-th place the shaft is held (bearings and constant "
                             "supports, from node 1)")
    amplitude_um = Quantity(10.0, unit="um", bounds=(0.0, 1000.0), doc="Bow at `node` (um)")
    phase_deg = Quantity(0.0, unit="deg", bounds=(-360.0, 360.0), doc="Its angle relative to the main unbalance (deg)")

    def forcing_shapes(self, rotor, omega: float, machine) -> list[np.ndarray]:
        q = bow_shape(rotor, self.amplitude_node(rotor), self.span) * np.exp(1j * machine.unbalance_phase)
        return [rotor.K @ q]  # the shaft's elastic force towards the bent line (bearings excluded)

    def forcing_weights(self, values: dict, shape) -> np.ndarray:
        a = 1e-6 * as_array(values, self, "amplitude_um", shape)
        ph = np.radians(as_array(values, self, "phase_deg", shape))
        return (a * np.exp(1j * ph))[..., None]

    def amplitude_node(self, rotor) -> int:
        """`node`, or the node nearest midway along the span. The bow's shape is one sine over its span whatever the
        node: the node only says where its amplitude is quoted, so a diagnosis does not scan it (every node would
        fit alike) and quotes it midway."""
        if self.node is not None:
            return int(self.node)
        z = rotor.node_z
        z1, z2 = (z[n - 1] for n in span_nodes(rotor, self.span))
        return int(np.argmin(np.abs(z - 0.5 * (z1 + z2)))) + 1

    def label(self) -> str:
        """'bow[node=None]' for the one span between the outermost bearings (the paper's), 'bow[span=2]' for the
        second span of a shaft held at three or more places."""
        return f"bow[node={self.node}]" if self.span is None else f"bow[span={self.span}]"

    def title(self) -> str:
        if self.span is not None:
            return f"a bowed shaft in span {self.span}"
        return "a bowed shaft" + ("" if self.node is None else f" (quoted at node {self.node})")

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0) -> list["Bow"]:
        """Between the outermost bearings, and in each span between two places the shaft is held where there are
        more than two (a shaft on two bearings has the one span)."""
        held = n_bearings + n_supports
        return [self] + ([self.copy(span=k) for k in range(1, held)] if held > 2 else [])

    def placeable(self, rotor) -> bool:
        """A span must be one of the rotor's, and a span between the outermost bearings that is the whole of the
        outer span (two bearings and nothing else) is not tried twice."""
        held = support_nodes(rotor)
        if self.span is None:
            return True
        if not 1 <= self.span < len(held):
            return False
        return span_nodes(rotor, self.span) != span_nodes(rotor, None)

    def values(self) -> dict:
        v = super().values()
        if v["node"] is None:  # not given: quoted midway, not written back as None
            del v["node"]
        return v

    def told(self, std: dict | None = None, machine=None) -> str:
        text = super().told(std, machine).replace(" at node None", " midway between the bearings")
        if self.span is None:
            return text
        a, b = self._span_words(machine)
        return text.replace(" midway between the bearings", f" midway between {a} and {b}")

    def _span_words(self, machine) -> tuple[str, str]:
        """The span's ends in words: the bearing or support at each end."""
        if machine is None:
            return (f"the {self.span}-th place the shaft is held", "the next")
        held = sorted([(b.node, f"bearing {k + 1} (node {b.node})") for k, b in enumerate(machine.bearings)] +
                      [(s.node, f"support {j + 1} (node {s.node})") for j, s in enumerate(machine.supports)])
        if not 1 <= self.span < len(held):
            return (f"span {self.span}", "")
        return held[self.span - 1][1], held[self.span][1]
