"""The Campbell diagram marks each mode's whirl (issue 38: "Campbell modes not marked forward/backward"): its legend
names it and a backward mode is dashed, from the stability map's own whirl per speed (the rotor's forward ratio)."""

from __future__ import annotations

import math

import holoviews as hv
import numpy as np

from lubeviz.app import resources
from lubeviz.app.rotor_page import RotorPage, _mostly
from lubeviz.model.operating import operating_point


def test_a_mode_is_named_by_the_way_it_whirls_at_most_speeds():
    assert _mostly(["forward", "forward", "backward"]) == "forward"
    assert _mostly(["", "backward", "backward", "forward"]) == "backward"
    assert _mostly(["", ""]) == ""


def test_the_campbell_diagram_names_each_mode_s_whirl_and_dashes_the_backward_ones():
    m = resources.machine()
    speeds = 2 * math.pi * np.array([30.0, 60.0, 90.0])
    result = resources.compute_stability(m.source, speeds, (1.0, 1.0))
    page = RotorPage(m, operating_point(m))
    plot = page._campbell(dict(result=result, ratios=(1.0, 1.0), flows=(546e-6 / 60, 556e-6 / 60), speed=75.0))
    modes = [e for e in plot.traverse(lambda x: x, [hv.Curve]) if e.label.startswith("mode ")]
    assert modes, "no mode drawn"
    whirl = result.modes.whirl
    for j, curve in enumerate(modes):
        expected = _mostly([row[j] for row in whirl])
        assert curve.label == f"mode {j + 1}" + (f", {expected}" if expected else "")
        dash = hv.Store.lookup_options("bokeh", curve, "style").kwargs.get("line_dash", "solid")
        assert dash == ("dashed" if expected == "backward" else "solid"), (curve.label, dash)
    kinds = {c.label.rsplit(", ", 1)[-1] for c in modes}
    assert {"forward", "backward"} <= kinds  # the paper's rotor on its films has both below 90 Hz
    assert "Campbell diagram at Q1/Q2 = " in plot.opts.get().kwargs["title"]
