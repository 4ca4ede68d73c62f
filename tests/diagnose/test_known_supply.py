"""A diagnosis on a machine whose model file gives one bearing's supply (SPEC §8 `supply_mlmin`): the held flow is
no parameter of the fit, so a start carried from one fit to the next (a node scan's neighbour, the winner's
refinement) holds the free parameters only. Until session 50 such a start was read as the whole parameter vector
and the diagnosis stopped with an IndexError in the second fit."""

import numpy as np
import pytest

from lubeviz.diagnose.pipeline import run_diagnosis
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification.independent import IndependentSpec, make_record, thresholds_mlmin

PUMP = str(MODELS_DIR / "overhung_pump.toml")


def pump_with_q1_known(effect: str):
    """(the pump with bearing 1's supply given, an independent record of it with `effect` at 0.9 and 0.8 of the
    bearings' Q_T, those flows in ml/min)."""
    pump = load_machine(PUMP)
    q = np.array((0.9, 0.8)) * thresholds_mlmin(pump.operating_speed, PUMP)
    planes = pump.measurement_planes
    spec = IndependentSpec(speed_hz=pump.operating_speed, q1_mlmin=float(q[0]), q2_mlmin=float(q[1]),
                           nodes=tuple(p.node for p in planes),
                           probe_angles_deg=tuple(tuple(p.probe_angles_deg) for p in planes), machine=PUMP, seed=3,
                           effects=(effect,))
    rec = make_record(spec).record
    pump.bearings[0] = pump.bearings[0].copy(supply="known", supply_flow=float(q[0]) / MLMIN_PER_M3S)
    return pump, rec, q


def test_a_gain_is_named_with_one_supply_known_and_the_known_flow_held():
    pump, rec, q = pump_with_q1_known("probe_gain:channel=x1,gain=1.15")
    d = run_diagnosis([rec], pump).diagnosis
    assert d.outcome == "effect added" and d.added.label == "probe_gain[channel=x1]"
    gain = next(p for p in d.after.params if p.name == "gain")
    assert gain.value == pytest.approx(1.15, abs=3 * gain.std) and gain.std < 0.03
    assert "q1" not in d.after.names and d.after.flow_values()[0] * MLMIN_PER_M3S == pytest.approx(q[0], rel=1e-9)
    lo, hi = (v * MLMIN_PER_M3S for v in d.after.intervals["q2"])
    assert lo <= q[1] <= hi
