"""HoloViews defaults of the dashboard, imported by every page module before it builds a plot.

Plots are `DynamicMap`s fed by `Pipe` streams, and a page first draws them empty; `framewise=True` on
every element type makes the axes follow each new frame instead of keeping the first (empty) one's range.
"""

from __future__ import annotations

import holoviews as hv
from holoviews import opts

hv.extension("bokeh", logo=False)
hv.opts.defaults(*(getattr(opts, name)(framewise=True) for name in (
    "Curve", "Scatter", "Points", "Spikes", "Image", "Path", "Contours", "Rectangles", "Labels", "Bounds")))

# Reference lines and markers (clearance circles, the 1X line, Q_T, keyphasor): a mid grey that stays
# visible on the light and on the dark theme (black vanishes on dark, white on light).
NEUTRAL = "#8c8c8c"
