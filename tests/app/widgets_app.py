"""A tiny Panel app for the harness's own test (tests/app/test_harness.py): one widget of each kind the
dashboard uses and a plot whose title follows the slider. No lubeviz numerics, so it pins the harness,
not the pages."""

import holoviews as hv
import numpy as np
import panel as pn

hv.extension("bokeh")

supply = pn.widgets.FloatSlider(name="Supply (ml/min)", start=100, end=800, step=10, value=400)
label = pn.widgets.TextInput(name="Label", value="run 1")
bearing = pn.widgets.Select(name="Bearing", options=["Bearing 1", "Bearing 2"])
go = pn.widgets.Button(name="Run", button_type="primary")
status = pn.pane.Markdown("idle")
go.on_click(lambda event: setattr(status, "object", f"ran {label.value} on {bearing.value}"))


def curve(q_mlmin):
    x = np.linspace(0.0, 1.0, 50)
    return hv.Curve((x, np.sin(x * q_mlmin / 100.0))).opts(title=f"Curve at Q = {q_mlmin:.0f} ml/min")


pn.template.FastListTemplate(
    title="harness probe", sidebar=[supply, label, bearing, go],
    main=[pn.pane.HoloViews(pn.bind(curve, supply)), status]).servable()
