"""The Rotor page's drawing numbers nodes without running them into one another (issue 38: "node numbers collide"),
and its orbit's legend sits outside the frame (issue 38: "legends cover the orbit")."""

from __future__ import annotations

import numpy as np

from lubeviz.app import resources
from lubeviz.app.rotor_page import NODE_LABEL_GAP, RotorPage, node_labels
from lubeviz.model.operating import operating_point


def test_node_numbers_keep_their_distance_and_the_machine_s_own_places_first():
    xs = np.array([0.0, 1.0, 2.0, 10.0, 11.0, 20.0, 30.0, 31.0, 40.0])
    shown = node_labels(xs, first=[5, 8], gap_mm=5.0)
    assert {5, 8} <= set(shown)  # a bearing's and a plane's node, though their neighbours are as near
    gaps = np.diff(np.sort(xs[np.array(shown) - 1]))
    assert gaps.min() >= 5.0
    assert 1 in shown and 9 in shown  # the shaft's ends
    assert node_labels(xs, first=[], gap_mm=0.0) == list(range(1, 10))  # room for all: all


def test_on_each_shipped_machine_the_drawing_s_numbers_are_apart_and_name_its_bearings_and_planes():
    for name in ("paper_machine", "overhung_pump", "three_bearing_fan"):
        m = resources.machine(None if name == "paper_machine" else f"models/{name}.toml")
        page = RotorPage(m, operating_point(m))
        drawing = page._drawing(None)
        labels = [e for e in drawing if type(e).__name__ == "Labels"][0]
        x = np.sort(labels.dimension_values(0))
        xs = np.concatenate([[0.0], np.cumsum([e.length for e in m.elements])]) * 1e3
        assert np.diff(x).min() >= NODE_LABEL_GAP * (xs[-1] - xs[0]) - 1e-9, name
        numbered = {int(t) for t in labels.dimension_values(2)}
        assert {b.node for b in m.bearings} <= numbered, name
        gap = NODE_LABEL_GAP * (xs[-1] - xs[0])
        for n in m.center_nodes:  # a plane is numbered, or stands within a label's gap of a numbered bearing
            assert n in numbered or min(abs(xs[n - 1] - xs[b.node - 1]) for b in m.bearings) < gap, (name, n)


def test_the_orbit_s_legend_is_outside_its_frame():
    m = resources.machine()
    page = RotorPage(m, operating_point(m))
    opts = page._orbit(None).opts.get().kwargs
    assert opts["legend_position"] == "bottom_left" and opts.get("hooks")  # moved below the frame by the hook
