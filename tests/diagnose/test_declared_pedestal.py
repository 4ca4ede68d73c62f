"""A pedestal the model file declares, softer than declared (grout cracked, a bolt loose): the `pedestals` effect on a
bearing with a declared pedestal is that pedestal at another stiffness (its mass and damping as declared).

A rehearsal on a machine the loop had never seen (a compressor with both bearings on declared pedestals, session 58)
found the loop's pedestal cases could not be made there at all: the effect was refused under a declared pedestal, and
a diagnosis never tried one. The record here is the independent source's (its own system with the housing's DOFs and
the pedestal's sag in its statics, `verification.independent._pedestals_as_found`); the chain's housing change
against assembly is checked in `tests/rotor/test_declared_pedestals.py`."""

from pathlib import Path

import numpy as np
import pytest

from lubeviz.diagnose.pipeline import run_diagnosis
from lubeviz.effects import parse_effect
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification.independent import IndependentSpec, make_record

DECLARED = 3.0e8  # N/m, under the pump's bearing 2 (impeller end), 40 kg, 2e4 N s/m


def _pump_on_a_pedestal(tmp_path) -> Path:
    text = (MODELS_DIR / "overhung_pump.toml").read_text()
    anchor = 'name = "bearing 2 (impeller end)"'
    assert anchor in text
    path = tmp_path / "pump_on_a_pedestal.toml"
    path.write_text(text.replace(anchor, anchor + f"\npedestal_mass_kg = 40.0\npedestal_stiffness_n_m = {DECLARED:g}"
                                                  "\npedestal_damping_ns_m = 2.0e4", 1))
    return path


def test_on_a_declared_pedestal_the_effect_tells_the_stiffness_against_the_declared(tmp_path):
    m = load_machine(_pump_on_a_pedestal(tmp_path))
    e = parse_effect("pedestals:bearing=2,stiffness_n_m=9e7").bind(m)
    assert not e.applies(1) and e.changes_housing(1) and not e.changes_housing(0)
    assert e.told({"stiffness_n_m": 4e6}, m) == ("The pedestal under bearing 2 has stiffness 9e+07 +- 4e+06 N/m "
                                                 "(declared 3e+08 N/m): softer than declared.")
    plain = parse_effect("pedestals:bearing=1,stiffness_n_m=9e7").bind(m)  # bearing 1 has none declared
    assert plain.applies(0) and not plain.changes_housing(0)
    assert plain.told(None, m).startswith("Each chosen bearing housing is a mass on a spring")


@pytest.mark.slow
def test_a_declared_pedestal_at_a_third_of_its_stiffness_is_named_with_the_flows_held(tmp_path):
    """Measured: named with a horizontal side load as its equal (the turned orbit of a soft pedestal's housing), the
    stiffness fitted at 9.6e7 N/m against 9e7, the flows 43 / 149 ml/min against 43.0 / 148.4."""
    path = _pump_on_a_pedestal(tmp_path)
    m = load_machine(path)
    q = (43.0, 148.4)  # 0.9 and 0.8 of the bearings' Q_T at 59.5 Hz
    spec = IndependentSpec(speed_hz=m.operating_speed, q_mlmin=q, nodes=(7, 13), machine=str(path), seed=4,
                           effects=(f"pedestals:bearing=2,mass_kg=40,stiffness_n_m={0.3 * DECLARED:g},"
                                    "damping_ns_m=2e4",))
    d = run_diagnosis([make_record(spec).record], m).diagnosis
    assert d.explained and d.added is not None
    labels = (d.added.label, *d.ambiguous)
    assert "pedestals[bearing=2]" in labels
    if d.added.label == "pedestals[bearing=2]":
        k = next(p for p in d.after.params if p.key == "pedestals.stiffness_n_m").value
        assert abs(k / (0.3 * DECLARED) - 1) < 0.2
    intervals = d.set_intervals or tuple(d.after.intervals[n] for n in ("q1", "q2"))
    for (lo, hi), t in zip(intervals, q):
        assert lo * MLMIN_PER_M3S <= t <= (np.inf if hi is None else hi * MLMIN_PER_M3S)
