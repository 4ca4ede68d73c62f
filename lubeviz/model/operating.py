"""The operating point of a machine: shaft speed and the oil supply flow of each fluid-film bearing.

A machine has N fluid-film bearings (SPEC §8), so the operating point of a machine has N flow parameters
`q1 ... qN`, each declared once (bounds, units, doc) for the dashboard's sliders: `operating_point(machine)`
(or `OperatingPoint.with_bearings(n)`) makes the class with N flows. The plain `OperatingPoint` has none.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import ClassVar, Sequence

import param

from ..errors import InputError
from ..units import M3S_PER_MLMIN
from .quantity import Quantity, positive

_FLOW = dict(unit="m^3/s", display_unit="ml/min", display_scale=1.0 / M3S_PER_MLMIN)
MAX_BEARINGS = 6  # SPEC §8: 1-6 fluid-film bearings


class OperatingPoint(param.Parameterized):
    """Shaft speed and supply flows (SI inside; flows are shown in ml/min, SPEC §1)."""

    speed = positive(75.0, "Hz", "Shaft speed (rev/s)")
    provisional = param.Boolean(False, precedence=-1, doc="The flows are a first guess (`initial_flows` without a "
                                                        "known Q_T): a page that learns a bearing's Q_T starts it there")
    n_bearings: ClassVar[int] = 0

    @staticmethod
    def with_bearings(n: int) -> type["OperatingPoint"]:
        """The operating-point class of a machine with `n` fluid-film bearings: flows q1 ... qn."""
        return _with_bearings(int(n))

    @property
    def flow_names(self) -> tuple[str, ...]:
        return tuple(f"q{k + 1}" for k in range(self.n_bearings))

    @property
    def omega(self) -> float:
        """Shaft speed in rad/s."""
        return 2.0 * math.pi * self.speed

    @property
    def flows(self) -> tuple[float, ...]:
        return tuple(getattr(self, n) for n in self.flow_names)

    @flows.setter
    def flows(self, values: Sequence[float]) -> None:
        values = [float(v) for v in values]
        if len(values) != self.n_bearings:
            raise InputError(f"{len(values)} flows for an operating point of {self.n_bearings} bearings")
        self.param.update(**dict(zip(self.flow_names, values)))


@lru_cache(maxsize=None)
def _with_bearings(n: int) -> type[OperatingPoint]:
    if not 1 <= n <= MAX_BEARINGS:
        raise InputError(f"an operating point of {n} bearings: expected 1-{MAX_BEARINGS} fluid-film bearings")
    name = f"OperatingPoint{n}"
    flows = {f"q{k + 1}": Quantity(546.0 * M3S_PER_MLMIN, bounds=(0.0, None), inclusive_bounds=(False, True),
                                   doc=f"Oil supply flow of bearing {k + 1}", **_FLOW) for k in range(n)}
    cls = type(OperatingPoint)(name, (OperatingPoint,), {"__module__": __name__, "n_bearings": n, **flows})
    globals()[name] = cls  # picklable by name
    return cls


def initial_flows(machine) -> list[float]:
    """The flows an operating point of `machine` starts at (m^3/s): a known supply as given, else the file's
    reference Q_T (the paper's), else a first guess that the dashboard's pages move into their range once they
    know each bearing's Q_T: a tenth of the Couette flow through the gap, U c L / 2 (0.98 of the paper's Q_T)."""
    ref = machine.reference.get("flooded_threshold_mlmin")
    out = []
    for b in machine.bearings:
        if b.supply_flow is not None:
            out.append(float(b.supply_flow))
        elif ref is not None:
            out.append(float(ref) * M3S_PER_MLMIN)
        else:
            u = 2.0 * math.pi * machine.operating_speed * b.radius
            out.append(0.1 * u * b.clearance * b.length / 2.0)
    return out


def operating_point(machine, *, speed: float | None = None, flows: Sequence[float] | None = None,
                    name: str = "operating point") -> OperatingPoint:
    """An operating point of `machine`: one flow per fluid-film bearing (default `initial_flows`), at `speed`
    (default the machine's operating speed)."""
    n = len(machine.bearings)
    given = flows
    flows = initial_flows(machine) if flows is None else list(flows)
    op = OperatingPoint.with_bearings(n)(speed=machine.operating_speed if speed is None else speed, name=name)
    op.flows = flows
    op.provisional = given is None and any(b.supply_flow is None for b in machine.bearings) \
        and "flooded_threshold_mlmin" not in machine.reference
    return op
