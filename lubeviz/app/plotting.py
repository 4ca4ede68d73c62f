"""HoloViews defaults of the dashboard, imported by every page module before it builds a plot.

Plots are `DynamicMap`s fed by `Pipe` streams, and a page first draws them empty; `framewise=True` on
every element type makes the axes follow each new frame instead of keeping the first (empty) one's range.
"""

from __future__ import annotations

import contextlib

import holoviews as hv
from holoviews import opts

hv.extension("bokeh", logo=False)
hv.opts.defaults(*(getattr(opts, name)(framewise=True) for name in (
    "Curve", "Scatter", "Points", "Spikes", "Image", "Path", "Contours", "Rectangles", "Labels", "Bounds")))

# Reference lines and markers (clearance circles, the 1X line, Q_T, keyphasor): a mid grey that stays
# visible on the light and on the dark theme (black vanishes on dark, white on light).
NEUTRAL = "#8c8c8c"

# An overlay's legend outside its frame, kept there. HoloViews' own outside positions ("top", "right", …) take
# the legend off the figure and add it back on every frame: a change of the document's model graph, after
# which Bokeh walks every model of the session (measured on the Bearing page: 0.33 s of the 0.55 s the
# server spent on the plots of one slider step, and the browser lays the figures out again). Here HoloViews
# keeps the legend "inside" (a location only, the same at every frame) and a hook moves it out once.
_INSIDE = {"above": "top_left", "below": "bottom_left", "right": "top_right", "left": "top_left"}


def outside_legend(side: str, cols: int | None = None) -> dict:
    """Options of an Overlay that draw its legend outside the frame, `side` "above", "below", "right" or
    "left", in `cols` columns (above/below: one row when not given), without re-laying out the figure when
    the overlay's DynamicMap sends a new frame."""
    if side not in _INSIDE:
        raise ValueError(f"legend side {side!r}: expected one of {', '.join(_INSIDE)}")

    def move_out(plot, element):
        from bokeh.models import Legend

        fig = plot.state
        for legend in [m for m in fig.center if isinstance(m, Legend)]:
            fig.center.remove(legend)
            fig.add_layout(legend, side)

    out = dict(legend_position=_INSIDE[side], hooks=[move_out])
    if cols is not None:
        out["legend_cols"] = cols
    elif side in ("above", "below"):
        out["legend_opts"] = {"orientation": "horizontal"}
    return out


def frozen(*panes):
    """A context in which the plot updates of `panes` (Panel panes already drawn) cost one walk of their
    session's model graph, not one per plot: HoloViews freezes the document around each plot's update, and
    Bokeh recomputes every model of the session each time the freeze ends (0.05 s per plot with one page
    built, more with more pages). Outside a served session (nothing drawn yet) it does nothing."""
    for pane in panes:
        for model, _ in getattr(pane, "_models", {}).values():
            doc = getattr(model, "document", None)
            if doc is not None and hasattr(doc, "models"):
                return doc.models.freeze()
    return contextlib.nullcontext()
