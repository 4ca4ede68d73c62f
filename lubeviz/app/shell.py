"""The dashboard shell. The bearing, rotor, maps and identification pages land with their issues;
until then the page says what the headless package and the CLI already do."""

from __future__ import annotations

import panel as pn

from ..model.machine import load_machine
from ..model.quantity import describe

INTRO = """
# lubeviz

Identify how well each hydrodynamic bearing of a machine is lubricated from the shaft's vibration.

**Available now** (headless API and command line): the mass-conserving p-θ film model of the paper's
bearing with a prescribed oil supply, flooded or plain feed; static equilibrium; the eight dynamic
coefficients; the flooded threshold Q_T. Try `lubeviz bearing --q-mlmin 400 --json`.

**Coming next**: the bearing page (pressure and oil-fraction fields under a supply slider), the rotor
page (orbits, full spectra, Campbell diagram), the Q1 × Q2 maps and the identification of uploaded records.
"""


def build() -> pn.template.FastListTemplate:
    machine = load_machine()
    bearing = machine.bearings[0]
    details = pn.pane.Markdown(
        "### The paper's bearing\n```\n" + describe(bearing) + "\n```\n"
        f"Machine file: `{machine.source}`", sizing_mode="stretch_width")
    return pn.template.FastListTemplate(
        title="lubeviz", main=[pn.pane.Markdown(INTRO, sizing_mode="stretch_width"), details])
