"""An effect written in one place shows up everywhere (issue 35's effect protocol): a toy effect defined here,
registered by one decorator, is simulated by `lubeviz simulate --effect`, fitted by `lubeviz identify
--effect`, tried and named by `lubeviz diagnose`, written in the report and offered on the Rotor page, with
no other file touched. The records are the chain's own (this is the plumbing, not the accuracy: the library's
effects are checked against independent records elsewhere)."""

import json

import numpy as np
import param
import pytest

from lubeviz.cli.main import main
from lubeviz.effects import EFFECTS, Effect, register
from lubeviz.effects.base import as_array


@pytest.fixture
def toy():
    @register
    class PlaneGain(Effect):
        """Both probes of plane `plane` read `gain` x the displacement (a driver feeding the pair with the wrong
        supply voltage): the plane's orbit grows, its shape stays. Changes the probes stage."""

        effect_name = "toy_plane_gain"
        stage = "probes"
        continuous = ("gain",)
        placement = ("plane",)
        neutral = {"gain": 1.0}
        step = {"gain": 1e-4}
        diagnose_free = ("gain",)
        separated_by = "a calibration of the plane's probe driver"

        plane = param.Selector(default=1, objects=[1, 2], doc="Plane whose two probes are off")
        gain = param.Number(1.2, bounds=(0.3, 3.0), doc="Actual over declared sensitivity of both probes")

        def probe_matrix(self, plane, angles_deg, values, shape):
            if plane + 1 != self.plane:
                return None
            return as_array(values, self, "gain", shape)[..., None, None] * np.eye(2)

        def placements(self, *, n_bearings, n_planes):
            return [self.copy(plane=p) for p in range(1, n_planes + 1)]

    yield PlaneGain
    del EFFECTS["toy_plane_gain"]


def test_a_toy_effect_shows_up_in_simulate_identify_diagnose_report_and_the_rotor_page(toy, tmp_path, capsys):
    record = tmp_path / "toy.csv"
    assert main(["simulate", "--q1-mlmin", "470", "--q2-mlmin", "590", "--method", "steady", "--snr-db", "30",
                 "--seed", "3", "--duration-s", "4", "--effect", "toy_plane_gain:plane=2,gain=1.3",
                 "-o", str(record)]) == 0
    capsys.readouterr()
    # identify with the effect declared, its gain free: fitted with the flows
    assert main(["identify", str(record), "--json", "--effect", "toy_plane_gain:plane=2"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["effects"]["toy_plane_gain"]["gain"] == pytest.approx(1.3, rel=0.02)
    # diagnose: tried in each placement, and the true one among what explains the record
    report = tmp_path / "toy.html"
    assert main(["diagnose", str(record), "--json", "--report", str(report)]) == 0
    d = json.loads(capsys.readouterr().out)
    labels = [e["label"] for e in d["effects"]]
    assert {"toy_plane_gain[plane=1]", "toy_plane_gain[plane=2]"} <= set(labels)
    assert not d["before"]["model_explains_data"]
    assert "toy_plane_gain[plane=2]" in [d["added"], *d["ambiguous"]]
    assert "toy_plane_gain" in report.read_text()
    # the Rotor page's list of effects to switch on
    from lubeviz.app.rotor_page import effect_choices

    assert effect_choices()["toy plane gain"] == "toy_plane_gain"  # named in words: its name, spaced
