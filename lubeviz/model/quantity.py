"""`Quantity`: a param.Number that also knows its SI unit and how it is displayed.

Every physical parameter of lubeviz is declared once, in SI, with its bounds and doc; the CLI and
the app read `display_unit` and `display_scale` from the same declaration to show and accept values
in engineering units (ml/min, mm, um), so no parameter is declared twice.
"""

from __future__ import annotations

import math

import param


class Quantity(param.Number):
    """A real number in SI `unit`, displayed as value * `display_scale` in `display_unit`."""

    __slots__ = ["unit", "display_unit", "display_scale"]

    _slot_defaults = dict(param.Number._slot_defaults, unit="", display_unit=None, display_scale=1.0)

    def __init__(
        self,
        default=param.Undefined,
        *,
        unit=param.Undefined,
        display_unit=param.Undefined,
        display_scale=param.Undefined,
        **params,
    ):
        super().__init__(default=default, **params)
        self.unit = unit
        self.display_unit = display_unit
        self.display_scale = display_scale

    def _validate_value(self, value, allow_None):
        super()._validate_value(value, allow_None)
        if value is not None and not math.isfinite(value):
            raise ValueError(f"{self.name!r} must be a finite number, not {value!r}")


def positive(default, unit, doc, *, display_unit=None, display_scale=1.0, **params):
    """A strictly positive Quantity (lengths, viscosities, speeds)."""
    return Quantity(
        default,
        bounds=params.pop("bounds", (0.0, None)),
        inclusive_bounds=(False, True),
        unit=unit,
        display_unit=display_unit or unit,
        display_scale=display_scale,
        doc=doc,
        **params,
    )


def describe(obj: param.Parameterized) -> str:
    """One line per Quantity of `obj`, in display units: 'radius = 45 mm'."""
    lines = []
    for name, p in obj.param.objects("existing").items():
        if isinstance(p, Quantity):
            lines.append(f"{name} = {getattr(obj, name) * p.display_scale:g} {p.display_unit}")
    return "\n".join(lines)
