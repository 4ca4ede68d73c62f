"""Broken measurements of independent records (what `lubeviz bench broken` diagnoses, `bench.broken`).

Each record is the independent source's (`independent.make_record`, flows 75-125 % Q_T, 12 dB), then broken
the way a cable, a channel map or a spreadsheet breaks a measurement: columns exchanged or negated, a column
copied onto another, a plane (or the whole record) in other units than declared, mains pickup added; or left
clean (the control). The breaks are column operations written here by hand, not the effect library's tables.
The bench (`bench.broken`) diagnoses each by `diagnose.run_diagnosis`, the CLI's and the page's one pipeline.

Per kind it counts right (the mix-up named first or in the ambiguity set; a copied channel or a plane in other units
reported as a measurement fault with no effect fitted; a units slip named with the right units; pickup
named as pickup and not read as whirl; the clean record explained with no finding), wrong alone (one effect
named alone that is not the break), and whether the reported flows' 95 % intervals hold the truth (for the
measurement faults no flows are claimed).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np


# column operations on (x1, y1, x2, y2), by hand: what each mix-up does to the columns a record holds
_MIXUPS = {
    "planes_swapped": lambda c: c[[2, 3, 0, 1]],
    "x_y_swapped": lambda c: c[[1, 0, 3, 2]],
    "x1_y1_swapped": lambda c: c[[1, 0, 2, 3]],
    "x2_y2_swapped": lambda c: c[[0, 1, 3, 2]],
    "x1_inverted": lambda c: c * np.array([-1, 1, 1, 1])[:, None],
    "y1_inverted": lambda c: c * np.array([1, -1, 1, 1])[:, None],
    "x2_inverted": lambda c: c * np.array([1, 1, -1, 1])[:, None],
    "y2_inverted": lambda c: c * np.array([1, 1, 1, -1])[:, None],
    "plane1_inverted": lambda c: c * np.array([-1, -1, 1, 1])[:, None],
    "plane2_inverted": lambda c: c * np.array([1, 1, -1, -1])[:, None],
}
# both probes of one plane reversed or of the other: the same to every invariant but the planes' phase, which
# an unbalance's phase does not fix either way: either is right
_SAME = {"plane1_inverted": {"plane1_inverted", "plane2_inverted"},
         "plane2_inverted": {"plane1_inverted", "plane2_inverted"}}
KINDS = (*_MIXUPS, "copied_channel", "plane_units", "units", "mains", "none")
_UNIT_SLIPS = (("m", "um"), ("um", "mils"), ("mm", "um"))  # (written in, declared as)
_CHANNELS = ("x1", "y1", "x2", "y2")


def broken_record(columns, speed_hz, rate_hz, kind: str, rng: np.random.Generator, *, nodes):
    """The record of `columns` ((4, n) metres, x1 y1 x2 y2 at the planes' model `nodes`) broken as `kind`, and what
    a diagnosis should say of it: {'wiring': fault} / {'finding': kind, 'text': ...} / {'pickup': Hz} / {} (clean)."""
    from ..signals.records import record_from_arrays

    cols, units, expect = np.array(columns, dtype=float), "m", {}
    if kind in _MIXUPS:
        cols, expect = _MIXUPS[kind](cols), {"wiring": kind}
    elif kind == "copied_channel":
        i, j = rng.choice(4, size=2, replace=False)
        cols[j] = cols[i]
        expect = {"finding": "copied_channels", "text": f"{_CHANNELS[min(i, j)]} and {_CHANNELS[max(i, j)]}"}
    elif kind == "plane_units":  # one plane written in mm, the file saying um
        k = int(rng.integers(2))
        cols = cols / 1e-6
        cols[2 * k:2 * k + 2] *= 1e-3
        units, expect = "um", {"finding": "plane_scale", "text": f"plane {k + 1}'s columns look like mm declared as um"}
    elif kind == "units":
        real, said = _UNIT_SLIPS[int(rng.integers(len(_UNIT_SLIPS)))]
        from ..units import length_factor

        cols, units = cols / length_factor(real), said
        expect = {"finding": "units", "text": f"look like {real} declared as {said}"}
    elif kind == "mains":
        f = float(rng.choice([50.0, 60.0]))
        t = np.arange(cols.shape[1]) / rate_hz
        size = float(rng.uniform(0.2, 0.6)) * float(np.std(cols[:2]))
        cols = cols + size * (np.sin(2 * math.pi * f * t + rng.uniform(0, 2 * math.pi)) +
                              0.3 * np.sin(4 * math.pi * f * t + rng.uniform(0, 2 * math.pi)))[None, :] \
            * rng.uniform(0.7, 1.3, 4)[:, None]
        expect = {"pickup": f}
    elif kind != "none":
        raise ValueError(f"unknown break {kind!r}; expected one of {', '.join(KINDS)}")
    rec = record_from_arrays(*cols, speed_hz=speed_hz, nodes=nodes, sample_rate_hz=rate_hz, units=units)
    return dataclasses.replace(rec, source=f"{kind}.csv"), expect
