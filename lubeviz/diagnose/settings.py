"""How a diagnosis is run, declared once with its docs (the CLI's flags and the page's widgets read it)."""

from __future__ import annotations

import param

from ..model.quantity import Quantity


class DiagnosisSettings(param.Parameterized):
    """The residual loop's test and what it draws. Defaults: what `lubeviz diagnose` does."""

    level = Quantity(0.01, bounds=(1e-6, 0.5), inclusive_bounds=(True, False), unit="",
                     doc="Significance level of the chi-square test: a fit explains the record when p > level")
    map_points = param.Integer(0, bounds=(0, 400),
                               doc="Points a side of the chi^2 maps over Q1 x Q2 (the plain model's, and the one "
                                   "with the effect added); 0: no maps")


REPORT_MAP_POINTS = 50  # the report's and the page's chi^2 maps, points a side
