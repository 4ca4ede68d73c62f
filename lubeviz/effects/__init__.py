"""The effect library: what a real machine or measurement adds to the model (SPEC §7 names).

Each effect is a small `param.Parameterized` class in its own module (`base.Effect`); the registry
`EFFECTS` parses SPEC §7's `NAME:key=value,...` (`parse_effect`, `parse_effects`) and names the closest
name or key when one is mistyped. The forward chain (`lubeviz.identify.chain.ForwardChain`) applies them
in `response`, `simulate` and the fit, so an effect added here shows up everywhere.
"""

from __future__ import annotations

from typing import Iterable

from .base import STAGES, Effect, Registry
from .bow import Bow, bow_shape
from .clearance import Clearance
from .large_orbit import LargeOrbit
from .oil_temperature import OilTemperature
from .pedestals import Pedestals
from .probe_gain import ProbeGain
from .probe_rotation import ProbeRotation
from .unbalance2 import Unbalance2
from .viscosity import Viscosity
from .wiring import Wiring

EFFECTS = Registry()
for _cls in (Viscosity, OilTemperature, Clearance, Unbalance2, Pedestals, ProbeRotation, ProbeGain, Bow, Wiring, LargeOrbit):
    EFFECTS.register(_cls)


def parse_effect(text: str) -> Effect:
    """One effect from SPEC §7's `NAME:key=value,...`; the parameters given are held, the rest free."""
    return EFFECTS.parse(text)


def parse_effects(texts: Iterable[str]) -> tuple[Effect, ...]:
    return tuple(parse_effect(t) for t in texts)


__all__ = ["EFFECTS", "STAGES", "Bow", "Clearance", "Effect", "LargeOrbit", "OilTemperature", "Pedestals", "ProbeGain", "ProbeRotation",
           "Unbalance2", "Viscosity", "Wiring", "bow_shape", "parse_effect", "parse_effects"]
