"""The `misalignment` effect: a bearing's centre moved from where the model file puts it (issue 37, item 5).

On three or more supports it moves the static loads. Checked against the independent source, which takes the move
into its own statics (its films at their supply, the split rotor, its own Newton), and against the same move written
in the model file (`offset_um`, solved by `coupled_statics`): the effect goes through the chain's linearized load
shift (`rotor.load_shift`, two Newton steps from the flooded statics)."""

import warnings

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.errors import InputError
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.model.files import load_machine
from lubeviz.rotor.assembly import rotor_from_machine
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification.independent import static_equilibrium, thresholds_mlmin

from tests.machines import uniform_three_bearing_file

MESH = (80, 40)  # the independent films' mesh here (tests/verification/test_independent_any_machine.py)


def quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kw)


def test_it_parses_places_over_the_bearings_and_is_refused_on_two_supports(machine):
    e = parse_effect("misalignment:bearing=2,dy_um=-10")
    assert e.spec() == "misalignment:bearing=2,dx_um=0,dy_um=-10" and e.label() == "misalignment[bearing=2]"
    assert parse_effect("misalignment:bearing=2").free == ("dx_um", "dy_um")
    with pytest.raises(InputError, match="two supports"):
        parse_effect("misalignment:bearing=1").bind(machine)
    assert not parse_effect("misalignment:bearing=1").placeable(rotor_from_machine(machine))
    fan = load_machine("models/three_bearing_fan.toml")
    placed = [p for p in parse_effect("misalignment").placements(n_bearings=3, n_planes=3)
              if p.placeable(rotor_from_machine(fan))]
    assert [p.bearing for p in placed] == [1, 2, 3]
    assert parse_effect("misalignment").candidate().free == ("dy_um",)


FAN = "models/three_bearing_fan.toml"


def test_a_lowered_middle_bearing_sheds_load_as_the_independent_statics_say():
    """The fan's middle bearing B lowered by 20 um, every bearing at its Q_T. The chain takes the move through its
    linearized load shift (two Newton steps from the flooded statics, the films from its tables), the independent
    source through its own statics (its films at their supply, 80 x 40 here, the split rotor). Measured: B's load
    4048.6 -> 3835.9 N (chain), 4048.4 -> 3835.6 N (independent); A's 2016.1 -> 2276.3 N (2016.4 -> 2276.9 N), its
    lean from 5.1 to 6.2 deg; C's 1356.7 -> 1442.6 N (1356.8 -> 1442.7 N)."""
    m = load_machine(FAN)
    qt = quiet(thresholds_mlmin, m.operating_speed, FAN)
    effect = parse_effect("misalignment:bearing=2,dy_um=-20").hold()
    chain = quiet(ForwardChain, m, m.operating_speed, None, (effect,))
    plain = quiet(ForwardChain, m, m.operating_speed)
    theta = chain.start()
    theta[:3] = qt / MLMIN_PER_M3S
    ours, ours_level = chain.static_loads(theta), plain.static_loads(theta[:3])
    theirs = quiet(static_equilibrium, FAN, None, tuple(qt), effects=("misalignment:bearing=2,dy_um=-20",),
                   mesh=MESH).loads
    level = quiet(static_equilibrium, FAN, None, tuple(qt), mesh=MESH).loads
    print("\nB lowered 20 um: chain", ours.round(1).tolist(), "level", ours_level.round(1).tolist(),
          "| independent", theirs.round(1).tolist(), "level", level.round(1).tolist())
    shed, shed_ind = ours - ours_level, theirs - level
    assert shed_ind[1, 1] > 0.05 * -level[1, 1]  # B sheds a twentieth of its load and more (loads point down)
    np.testing.assert_allclose(shed, shed_ind, rtol=0, atol=0.01 * np.abs(shed_ind).max())
    # the films see it: B's journal sits higher in its bearing under the smaller load
    assert chain.bearing_states(theta)[1][1][2][1] > plain.bearing_states(theta[:3])[1][1][2][1] + 0.2e-6


def test_a_diagnosis_of_an_independent_record_puts_the_moved_bearing_first_and_its_flows_hold():
    """An independent record of the fan (planes at A and B) with B lowered 20 um, flows 0.9, 1.2, 1.0 Q_T. Each
    bearing's move, a second unbalance, a bow and a pedestal all fit one record's four 1X invariants: the diagnosis
    may not name it alone, but the moved bearing must rank first, inside the set, and the set's flow intervals must
    hold the truth. Measured (seed 5): ambiguous, misalignment[bearing=2] first (chi2 0.55), then bearings 1 and 3;
    Q1 in [157, 210] (truth 192.3), Q2 in [413, 491] (448.5), Q3 in [102, 223] (146.4) ml/min."""
    from lubeviz.diagnose.pipeline import run_diagnosis
    from lubeviz.verification.independent import IndependentSpec, make_record

    m = load_machine(FAN)
    qt = quiet(thresholds_mlmin, m.operating_speed, FAN)
    q = tuple(float(v) for v in np.round(qt * np.array([0.9, 1.2, 1.0]), 1))
    spec = IndependentSpec(speed_hz=m.operating_speed, q_mlmin=q, nodes=(7, 15), machine=FAN, seed=5, total_s=4.0,
                           duration_s=3.0, effects=("misalignment:bearing=2,dy_um=-20",))
    d = quiet(run_diagnosis, [quiet(make_record, spec).record], m).diagnosis
    assert d.candidates[0].label == "misalignment[bearing=2]"
    assert d.candidates[0].effect.dy_um == pytest.approx(-20.0, abs=8.0)
    assert d.ambiguous and d.set_intervals is not None  # its look-alikes fit as well: the set's flows are given
    for (lo, hi), truth in zip(d.set_intervals, q):  # m^3/s
        assert lo * MLMIN_PER_M3S < truth and (hi is None or truth < hi * MLMIN_PER_M3S), (lo, hi, truth)
