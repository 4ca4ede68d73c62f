"""A side load on a shaft held at three or more places: where it acts is a place to find, and the flows are given
over every place that fits.

On two supports a force and a couple at any node load the bearings alike; on the fan they do not (a force between
A and B, one between B and C and one at B load the three films in patterns no force and couple at one node make up),
so `SideLoad.scan_nodes` gives every node there. The fan loop's case 106 (session 48): a couple of 629 N m at the free
end (node 25), planes at B and C with the DC gap. Named at node 17 with Q1 41 % low (bearing A, which no plane
watches), the interval of node 17's fit alone missing it; the places the scan keeps carry the truth."""

import numpy as np
import pytest

from lubeviz.diagnose.pipeline import run_diagnosis
from lubeviz.effects import SideLoad
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.rotor.assembly import rotor_from_machine
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification.independent import IndependentSpec, make_record

FAN = str(MODELS_DIR / "three_bearing_fan.toml")


def test_it_is_scanned_on_three_supports_and_not_on_two(machine):
    assert SideLoad().scan_nodes(rotor_from_machine(load_machine(FAN))) == tuple(range(1, 26))
    assert SideLoad().scan_nodes(rotor_from_machine(machine)) == ()


@pytest.mark.slow
def test_a_couple_at_the_free_end_is_named_and_the_flows_hold_over_the_places_that_fit():
    q = (190.8329352768145, 366.2866403558149, 88.75609823802205)
    spec = IndependentSpec(speed_hz=27.17246554048795, q_mlmin=q, static=True, seed=613706833, machine=FAN,
                           nodes=(15, 23), effects=("side_load:node=25,force_n=0,moment_nm=629.2,angle_deg=0",))
    d = run_diagnosis([make_record(spec).record], load_machine(FAN)).diagnosis
    assert d.explained and d.added is not None and d.added.label.startswith("side_load")
    scan = next(s for s in d.scans if s.effect_name == "side_load")
    assert len(scan.fitting) > 1 and d.set_intervals is not None
    for (lo, hi), t in zip(d.set_intervals, q):
        assert lo * MLMIN_PER_M3S <= t <= (np.inf if hi is None else hi * MLMIN_PER_M3S)
    assert "Over the places that fit, the flows are known only within" in d.verdict
