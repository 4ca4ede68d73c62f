"""The effect library: what a real machine or measurement adds to the model (SPEC §7 names).

Each effect is a small `param.Parameterized` class in its own module (`base.Effect`), registered where it is
written by `@register`; the registry `EFFECTS` parses SPEC §7's `NAME:key=value,...` (`parse_effect`,
`parse_effects`) and names the closest name or key when one is mistyped. The forward chain
(`lubeviz.identify.forward.chain.ForwardChain`) calls the hooks of each effect's stage in `response`, `simulate` and
the fit, so an effect added in one module shows up everywhere. The modules are imported below in the order
the library lists its effects (oil and bearings, rotor, probes, the measurement, the response model).
"""

from __future__ import annotations

from typing import Iterable

from .base import EFFECTS, STAGES, Effect, Registry, register
from .viscosity import Viscosity
from .oil_temperature import OilTemperature
from .clearance import Clearance
from .misalignment import Misalignment
from .side_load import SideLoad
from .unbalance2 import Unbalance2
from .pedestals import Pedestals
from .support_stiffness import SupportStiffness
from .probe_rotation import ProbeRotation
from .probe_gain import ProbeGain
from .bow import Bow, bow_shape
from .wiring import Wiring
from .large_orbit import LargeOrbit


def parse_effect(text: str, machine=None) -> Effect:
    """One effect from SPEC §7's `NAME:key=value,...`; the parameters given are held, the rest free. With `machine`,
    a bearing, plane or support may be given by its name in the model file (SPEC §8)."""
    return EFFECTS.parse(text, machine)


def parse_effects(texts: Iterable[str], machine=None) -> tuple[Effect, ...]:
    return tuple(parse_effect(t, machine) for t in texts)


def label_title(label: str) -> str:
    """A candidate's label (`clearance[bearing=1]`, a pair's `a + b`) in an engineer's words (`Effect.title`: 'the
    clearance of bearing 1'); a label that names no effect of the library (a verdict's 'another 1X force') as given."""
    parts = [p.strip() for p in str(label).split(" + ")]
    out = []
    for part in parts:
        name, _, rest = part.partition("[")
        cls = EFFECTS.get(name)
        if cls is None:
            return str(label)
        values = {}
        for item in filter(None, rest.rstrip("]").split(",")):
            key, _, value = item.partition("=")
            if key not in cls.placement:
                return str(label)
            values[key] = None if value == "None" else (int(value) if value.lstrip("-").isdigit() else value)
        try:
            out.append(cls(**values).title())
        except Exception:  # noqa: BLE001 - a placement this class refuses: the label as given
            return str(label)
    return " with ".join(out)


def quantity_words(name: str) -> str:
    """A parameter's name as words, without its unit suffix: clearance_um -> 'clearance', angle_deg -> 'angle',
    force_n -> 'force', dx_um -> 'dx' (the unit is written after the value)."""
    for suffix in ("_um", "_deg", "_nm", "_n", "_c", "_hz", "_kg", "_mlmin", "_ns_m", "_n_m"):
        if name.endswith(suffix) and len(name) > len(suffix):
            name = name[:-len(suffix)]
            break
    return name.replace("_", " ")


__all__ = ["EFFECTS", "STAGES", "Bow", "Clearance", "Effect", "LargeOrbit", "Misalignment", "OilTemperature", "Pedestals", "ProbeGain",
           "ProbeRotation", "Registry", "SideLoad", "SupportStiffness", "Unbalance2", "Viscosity", "Wiring", "bow_shape", "label_title", "parse_effect", "quantity_words",
           "parse_effects", "register"]
