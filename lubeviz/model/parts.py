"""The machine's parts (SI): rotor description, discs, unbalances, bearings, supports, measurement planes, operating
data. Read from a model file by `lubeviz.model.files`; `lubeviz.model.machine` gathers both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import param

from ..errors import ModelFileError
from .bearing import Bearing, Pedestal
from .oil import Oil
from .quantity import Quantity, positive

MODELS_DIR = Path(__file__).resolve().parents[2] / "models"
DEFAULT_MACHINE = MODELS_DIR / "paper_machine.toml"


@dataclass(frozen=True)
class ShaftElement:
    """A uniform circular shaft segment between two consecutive nodes (SI); hollow when inner_diameter > 0."""

    length: float
    diameter: float
    inner_diameter: float = 0.0


@dataclass(frozen=True)
class Disc:
    """A rigid disc at a node (SI): annular by geometry (bore = local shaft diameter), or lumped (an impeller, a
    coupling hub) by its mass and inertias, the geometry then 0."""

    node: int
    width: float = 0.0
    outer_diameter: float = 0.0
    bore_diameter: float = 0.0
    mass: float | None = None
    polar_inertia: float | None = None
    diametral_inertia: float | None = None
    name: str = ""

    @property
    def lumped(self) -> bool:
        return self.mass is not None


@dataclass(frozen=True)
class UnbalanceMass:
    """An unbalance besides the machine's main one (SPEC §8 [[unbalances]]): node, moment (kg m), phase (rad)."""

    node: int
    moment: float
    phase: float = 0.0
    name: str = ""


@dataclass(frozen=True)
class Support:
    """A support with constant coefficients (a rolling-element bearing, a seal, a coupling's support), SI, Lund's
    sign: stiffness and damping as ((XX, XY), (YX, YY)); an optional pedestal under it."""

    name: str
    node: int
    stiffness: tuple
    damping: tuple
    pedestal: Pedestal | None = None


@dataclass(frozen=True)
class Plane:
    """A measurement plane: its node and its two probes' directions from +X (deg), in record order."""

    node: int
    probe_angles_deg: tuple = (0.0, 90.0)
    name: str = ""


class Machine(param.Parameterized):
    """Rotor, discs, unbalance, bearings and operating data of one machine (SI inside)."""

    gravity = positive(9.81, "m/s^2", "Gravitational acceleration, acting along -Y")
    operating_speed = positive(75.0, "Hz", "Operating shaft speed")
    speed_min = positive(5.0, "Hz", "Lowest speed the model is meant for")
    speed_max = positive(150.0, "Hz", "Highest speed the model is meant for")
    young_modulus = positive(210e9, "Pa", "Young's modulus of shaft and discs")
    poisson_ratio = Quantity(0.3, bounds=(0.0, 0.5), inclusive_bounds=(True, False), unit="",
                             doc="Poisson's ratio of shaft and discs")
    density = positive(7850.0, "kg/m^3", "Density of shaft and discs")
    shaft_damping_beta = Quantity(2e-5, bounds=(0.0, None), unit="s",
                                  doc="Stiffness-proportional shaft damping: C_shaft = beta * K_shaft")
    unbalance_node = param.Integer(13, bounds=(1, None), doc="Node carrying the unbalance")
    unbalance_moment = Quantity(1.24e-2, bounds=(0.0, None), unit="kg*m",
                                doc="Unbalance moment m_u (Eq. 9)")
    unbalance_phase = Quantity(0.0, unit="rad", display_unit="deg", display_scale=180.0 / math.pi,
                               doc="Phase of the unbalance force at t = 0")
    other_unbalances = param.List([], item_type=UnbalanceMass,
                                  doc="Unbalances besides the main one (SPEC §8 [[unbalances]] after the first)")
    supports = param.List([], item_type=Support,
                          doc="Supports with constant coefficients (rolling-element bearings, seals)")
    planes = param.List([], item_type=Plane,
                        doc="Measurement planes in record order (none declared: one at each bearing, X and Y)")
    elements = param.List([], item_type=ShaftElement, doc="Shaft elements from node 1 onwards")
    discs = param.List([], item_type=Disc, doc="Rigid discs")
    bearings = param.List([], item_type=Bearing, doc="Journal bearings (bearing 1 first)")
    center_nodes = param.List([], item_type=int,
                              doc="Measurement nodes at the bearing centres (the paper's [measurement]; else the "
                                  "measurement planes' nodes)")
    outside_nodes = param.List([], item_type=int, doc="Measurement nodes outside the bearings (the paper's "
                                                      "[measurement]; none declared: empty)")
    oil = param.ClassSelector(class_=Oil, default=None, allow_None=True,
                              doc="The oil's grade and viscosity-temperature law (optional [oil] of the model file)")
    reference = param.Dict({}, doc="Figures the source publication reports (for checks)")
    source = param.String("", doc="File the machine was loaded from")

    def not_yet_modelled(self) -> list[str]:
        """What the model file declares that the numerics do not take yet (issue 37 lands them one by one): each
        as the file's table and index and what is missing. Empty for the paper's machine."""
        out = []
        if len(self.bearings) + len(self.supports) < 2:
            out.append(f"{len(self.bearings)} [[bearings]] and {len(self.supports)} [[supports]]: a shaft needs two "
                       "supports at least to stand")
        return out

    def require_modelled(self, what: str) -> None:
        """Raise ModelFileError naming the file and every declared part `what` cannot take yet."""
        gaps = self.not_yet_modelled()
        if gaps:
            raise ModelFileError(f"{self.source or self.name}: {what} cannot take this machine yet: "
                                 + "; ".join(gaps) + ". The file itself is valid (SPEC §8).")

    def record_defaults(self) -> dict:
        """What a record of this machine that names no planes is taken to hold (SPEC §8): its measurement planes'
        nodes and probe angles, as `read_record`'s keywords."""
        planes = self.measurement_planes
        return {"default_nodes": tuple(p.node for p in planes),
                "default_probe_angles": tuple(tuple(float(a) for a in p.probe_angles_deg) for p in planes)}

    def part_number(self, kind: str, given, what: str, words=()) -> str:
        """A bearing, plane or support (`kind`) of this machine given by its number (1..N, file order) or by its name
        in the model file (case aside), as its number; a word of `words` (e.g. "all") as given. A number out of
        range, a name no part has or two parts share: InputError naming `what`, the file and the parts."""
        from ..errors import InputError

        parts = {"bearing": self.bearings, "plane": self.measurement_planes, "support": self.supports}[kind]
        text = str(given).strip()
        if text in words:
            return text
        if text.isdigit() and 1 <= int(text) <= len(parts):
            return text
        hits = [] if text.isdigit() else [k for k, part in enumerate(parts, start=1)
                                          if getattr(part, "name", "").strip().casefold() == text.casefold()]
        if len(hits) == 1:
            return str(hits[0])
        where = self.source or self.name
        if hits:
            raise InputError(f"{what} {text!r} names {kind}s {', '.join(map(str, hits))} of {where}; give the "
                             f"number (1..{len(parts)})")
        listed = ", ".join(f"{k} ({part.name})" if getattr(part, "name", "") else str(k)
                           for k, part in enumerate(parts, start=1))
        raise InputError(f"{what} {text!r}: expected the number (1..{len(parts)}) or the name of a {kind} of "
                         f"{where}: {listed or 'none declared'}")

    @property
    def measurement_planes(self) -> list[Plane]:
        """The declared planes, or one at each bearing's node with probes along X and Y (SPEC §8)."""
        return list(self.planes) or [Plane(b.node, (0.0, 90.0), b.name) for b in self.bearings]

    @property
    def n_nodes(self) -> int:
        return len(self.elements) + 1

    @property
    def rotor_length(self) -> float:
        return sum(e.length for e in self.elements)

    @property
    def shear_modulus(self) -> float:
        return self.young_modulus / (2.0 * (1.0 + self.poisson_ratio))


OIL_CONSISTENCY = 0.10  # the bearings' viscosity_pa_s and the [oil] law at temperature_c: ISO 3448's +-10 %
