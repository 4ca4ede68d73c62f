"""The Diagnose page tells a pair that fits nearly as well as the named effect (`Diagnosis.rivals`, issue 36) in an
engineer's words, under the flows, the named effect kept. Built without a server (its code, not the browser)."""

from __future__ import annotations

import dataclasses

import numpy as np

from lubeviz.app import resources
from lubeviz.app.session import SessionState
from lubeviz.diagnose import diagnose, diagnosis_dict
from lubeviz.effects import ProbeRotation, parse_effect
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.identify.forward.measured import measure
from lubeviz.units import M3S_PER_MLMIN


def test_a_rival_pair_is_told_in_words_under_the_flows():
    from lubeviz.app.diagnose_page import DiagnosePage
    from lubeviz.app.text import plain

    machine = resources.machine()
    chain = ForwardChain(machine, machine.operating_speed, machine.center_nodes)
    effect = parse_effect("probe_rotation:plane=1,angle_deg=5").hold()
    record = simulate(chain.with_effects((effect,)), np.array([420.0, 600.0]) * M3S_PER_MLMIN, snr_db=12.0,
                      rng=np.random.default_rng(7))
    d = diagnose(chain, measure(record), candidates=(ProbeRotation,))
    page = DiagnosePage(machine, SessionState(name="test"))
    rival = "viscosity[bearing=both] + clearance[bearing=2]"
    told = page._flows_text(dataclasses.replace(d, rivals=(rival,)), diagnosis_dict(d), None, "rec")
    words = plain("the oil's viscosity in every bearing with the clearance of bearing 2")  # as a Markdown pane shows it
    assert f"**Two faults at once** fit nearly as well: {words}" in told and "clearance[" not in told
    assert "Two faults at once" not in page._flows_text(d, diagnosis_dict(d), None, "rec")
