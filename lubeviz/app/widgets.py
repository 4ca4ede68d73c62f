"""Widgets made from the model's own parameter declarations (STYLE: a parameter is declared once).

`quantity_slider(obj, "q1")` reads the `Quantity` declaration of `obj.q1` (its SI unit, display unit
and scale, bounds and doc) and returns a slider in display units (ml/min, mm, um) whose label carries
the unit and whose tooltip is the doc; the slider and the parameter are linked both ways, converting
at the edge. Bounds the declaration leaves open (a flow has no upper bound) are given by the page,
in SI, where it knows a sensible range (e.g. 25-200 % of Q_T).
"""

from __future__ import annotations

import panel as pn
import param

from ..model.quantity import Quantity


def _label(p: param.Parameter) -> str:
    unit = getattr(p, "display_unit", None) or getattr(p, "unit", "")
    return f"{p.label} ({unit})" if unit else p.label


def quantity_slider(obj: param.Parameterized, name: str, *, start: float | None = None,
                    end: float | None = None, step: float | None = None, editable: bool = False,
                    label: str | None = None, **kwargs) -> pn.widgets.Widget:
    """A slider for the Quantity `obj.name`. `start`, `end`, `step` in SI override the declaration."""
    p = obj.param[name]
    if not isinstance(p, Quantity):
        raise TypeError(f"{type(obj).__name__}.{name} is not a Quantity")
    scale = p.display_scale
    lo, hi = p.softbounds or (None, None)
    b_lo, b_hi = p.bounds or (None, None)
    lo = start if start is not None else (lo if lo is not None else b_lo)
    hi = end if end is not None else (hi if hi is not None else b_hi)
    if lo is None or hi is None:
        raise ValueError(f"{type(obj).__name__}.{name} has no upper or lower bound; give start and end")
    value = min(max(getattr(obj, name), lo), hi)
    common = dict(name=label or _label(p), start=lo * scale, end=hi * scale,
                  step=(step if step is not None else (hi - lo) / 200.0) * scale, value=value * scale, **kwargs)
    # Panel 1.9 sliders take no `description`; the doc is kept on the widget for the page to show.
    w = (pn.widgets.EditableFloatSlider if editable else pn.widgets.FloatSlider)(**common)
    link(obj, name, w, scale)
    w.doc = p.doc
    return w


def link(obj: param.Parameterized, name: str, widget: pn.widgets.Widget, scale: float = 1.0,
         event: str = "value") -> None:
    """Keep `widget.value` (display units) and `obj.name` (SI) equal, both ways, without echo loops."""
    busy = [False]

    def to_obj(e):
        if busy[0]:
            return
        busy[0] = True
        try:
            setattr(obj, name, e.new / scale)
        finally:
            busy[0] = False

    def to_widget(e):
        if busy[0]:
            return
        busy[0] = True
        try:
            widget.value = e.new * scale
        finally:
            busy[0] = False

    widget.param.watch(to_obj, event)
    obj.param.watch(to_widget, name)


def selector(obj: param.Parameterized, name: str, **kwargs) -> pn.widgets.Widget:
    """A widget for a non-Quantity parameter (Selector, Integer, Boolean), linked to it."""
    return pn.Param(obj.param, parameters=[name], show_name=False, **kwargs)
