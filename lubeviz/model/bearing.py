"""The journal bearing as a model object: geometry, groove, oil and the finite-volume mesh.

SI inside (m, Pa*s); display units for the app and the CLI come from each Quantity.
The groove sits at angle `groove_angle` measured like alpha in Eq. 1 (from +Y towards -X, in the
direction of rotation), centred axially.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import param

from ..errors import InputError
from ..units import MLMIN_PER_M3S
from .quantity import Quantity, positive


@dataclass(frozen=True)
class Groove:
    """An axial supply groove (SI): centre angle (rad, as alpha in Eq. 1), circumferential length, axial width."""

    angle: float
    length: float
    width: float


@dataclass(frozen=True)
class Pedestal:
    """A bearing housing or support on a spring and damper to ground (SI): isotropic mass, stiffness, damping."""

    mass: float
    stiffness: float
    damping: float


SUPPLIES = ("unknown", "flooded", "known")


class Bearing(param.Parameterized):
    """A plain cylindrical journal bearing fed through one or more axial grooves (paper Table 3: one)."""

    radius = positive(0.045, "m", "Journal radius R", display_unit="mm", display_scale=1e3)
    length = positive(0.070, "m", "Bearing axial length L", display_unit="mm", display_scale=1e3)
    clearance = positive(120e-6, "m", "Radial clearance c", display_unit="um", display_scale=1e6)
    viscosity = positive(0.094, "Pa*s", "Oil dynamic viscosity mu (isoviscous film)")
    groove_angle = Quantity(
        0.0, bounds=(-math.pi, math.pi), unit="rad", display_unit="deg",
        display_scale=180.0 / math.pi,
        doc="Angular position of the groove centre, from +Y in the direction of rotation (Eq. 1)",
    )
    groove_length = Quantity(
        16.2e-3, bounds=(0.0, None), unit="m", display_unit="mm", display_scale=1e3,
        doc="Circumferential length b of the axial groove (0: no groove)",
    )
    groove_width = Quantity(
        35.0e-3, bounds=(0.0, None), unit="m", display_unit="mm", display_scale=1e3,
        doc="Axial width a of the groove, centred in the bearing",
    )
    n_circumferential = param.Integer(100, bounds=(8, 4000), doc="Finite volumes around the circumference")
    n_axial = param.Integer(100, bounds=(2, 4000), doc="Finite volumes along the bearing length")
    groove_refinement = param.Integer(
        4, bounds=(1, 16),
        doc="Sub-columns each circumferential cell in and next to the groove is split into (1: the paper's "
            "uniform mesh). Smooths the coefficients just above Q_T, where the groove pressurizes")
    node = param.Integer(None, allow_None=True, bounds=(1, None), doc="Rotor node (paper numbering) of the bearing centre")
    other_grooves = param.List([], item_type=Groove,
                               doc="Further axial grooves sharing the bearing's supply (SPEC §8: a two-axial-groove "
                                   "bearing has a second one, usually 180 degrees from the first)")
    supply = param.Selector(objects=list(SUPPLIES), default="unknown",
                            doc="The oil supply: unknown (identified), flooded (fed above its Q_T) or known")
    supply_flow = Quantity(None, allow_None=True, bounds=(0.0, None), unit="m^3/s", display_unit="ml/min",
                           display_scale=MLMIN_PER_M3S, doc="The supply flow when it is known (supply = known)")
    offset = param.NumericTuple((0.0, 0.0), length=2,
                                doc="Offset (m) of the bearing centre from the straight line, (dX, dY): alignment")
    pedestal = param.ClassSelector(class_=Pedestal, default=None, allow_None=True,
                                   doc="The housing on a spring and damper to ground (none: rigid)")

    def __init__(self, **params):
        super().__init__(**params)
        self.validate()

    def validate(self) -> None:
        """Cross-field checks that single-parameter bounds cannot express."""
        if self.groove_width > self.length:
            raise InputError(
                f"groove width {self.groove_width * 1e3:g} mm exceeds bearing length "
                f"{self.length * 1e3:g} mm; expected a groove inside the bearing"
            )
        if self.groove_length >= 2 * math.pi * self.radius:
            raise InputError(
                f"groove length {self.groove_length * 1e3:g} mm is not shorter than the "
                f"circumference {2 * math.pi * self.radius * 1e3:.4g} mm"
            )
        half = [g.length / (2.0 * self.radius) for g in self.grooves]
        for k, g in enumerate(self.other_grooves, start=2):
            if g.width > self.length or g.width < 0 or g.length < 0:
                raise InputError(f"groove {k}: width {g.width * 1e3:g} mm, length {g.length * 1e3:g} mm; expected "
                                 f"non-negative sizes and a width inside the bearing length {self.length * 1e3:g} mm")
        angles = [math.remainder(g.angle, 2 * math.pi) for g in self.grooves]
        for i in range(len(angles)):
            for j in range(i + 1, len(angles)):
                gap = abs(math.remainder(angles[i] - angles[j], 2 * math.pi))
                if gap < half[i] + half[j]:
                    raise InputError(f"grooves {i + 1} and {j + 1} overlap (centres {math.degrees(gap):.3g} deg "
                                     f"apart); expected separate grooves")
        if sum(half) * 2.0 >= 2.0 * math.pi:
            raise InputError("the grooves together are not shorter than the circumference")
        if (self.supply == "known") != (self.supply_flow is not None):
            raise InputError(f"supply = {self.supply!r} with supply_flow {self.supply_flow!r}: a known supply "
                             "needs its flow, and only a known supply has one")
        if self.clearance >= self.radius:
            raise InputError(
                f"clearance {self.clearance * 1e6:g} um is not small against radius "
                f"{self.radius * 1e3:g} mm; the thin-film (Reynolds) model needs c << R"
            )

    @property
    def diameter(self) -> float:
        return 2.0 * self.radius

    @property
    def grooves(self) -> tuple[Groove, ...]:
        """Every axial groove of the bearing, the first (the short-form `groove_*` parameters) first."""
        first = Groove(self.groove_angle, self.groove_length, self.groove_width)
        return (first, *self.other_grooves)

    @property
    def has_groove(self) -> bool:
        return self.groove_length > 0.0 and self.groove_width > 0.0

    def copy(self, **changes) -> "Bearing":
        """A new Bearing with some parameters changed (the original is left as it is; its name stays)."""
        values = {k: getattr(self, k) for k in self.param}
        values.update(changes)
        return Bearing(**values)
