"""The Rotor page's numbers, headless (`identify.forward.explore.rotor_state`): what the page draws comes from
here, so its physics is tested without a browser."""

import math

import numpy as np
import pytest

from lubeviz.effects import parse_effects
from lubeviz.identify.forward.explore import rotor_state
from lubeviz.identify.tables.cache import machine_tables
from lubeviz.rotor.assembly import rotor_from_machine
from lubeviz.units import M3S_PER_MLMIN


@pytest.fixture(scope="module")
def setup(machine):
    return machine_tables(machine, 2 * math.pi * 75.0), rotor_from_machine(machine)


def state(machine, setup, node, effect=None):
    tables, rotor = setup
    flows = (450 * M3S_PER_MLMIN, 620 * M3S_PER_MLMIN)
    return rotor_state(machine, tables, rotor, flows, node, effect, snr_db=20.0, seed=1)


def test_a_rotated_probe_pair_turns_the_orbit_and_changes_no_size(machine, setup):
    """Probes turned by a: the forward and backward components both turn by -a (z = x + iy seen in axes turned
    by a is z e^{-ia}, the whole orbit turned back), their sizes stay; the other plane's probes read the same static position."""
    node = machine.bearings[0].node
    a = 7.0
    s = state(machine, setup, node, *parse_effects([f"probe_rotation:plane=1,angle_deg={a}"]))
    assert abs(s["zf"]) == pytest.approx(abs(s["zf0"]), rel=1e-9)
    assert abs(s["zb"]) == pytest.approx(abs(s["zb0"]), rel=1e-9)
    turns = np.degrees(np.angle([s["zf"] / s["zf0"], s["zb"] / s["zb0"]]))
    assert turns == pytest.approx([-a, -a], abs=1e-6)
    np.testing.assert_allclose(s["static"][1], s["static0"][1], rtol=0, atol=1e-15)
    assert not np.allclose(s["static"][0], s["static0"][0])  # plane 1's probes read the DC gap turned too


def test_away_from_the_probes_a_probe_error_shows_the_shaft_itself(machine, setup):
    s = state(machine, setup, 10, *parse_effects(["probe_gain:channel=x1,gain=1.3"]))
    assert s["zf"] == pytest.approx(s["zf0"], rel=1e-9) and s["zb"] == pytest.approx(s["zb0"], rel=1e-9)


def test_the_spectrum_s_1x_line_is_the_orbit_s_forward_component(machine, setup):
    """The page's noisy record at 20 dB: its full spectrum's +1X line has the forward component's size (within
    the noise), and the static position sits inside the clearance circle."""
    s = state(machine, setup, machine.bearings[1].node)
    assert abs(s["spectrum"].line(1.0)) == pytest.approx(abs(s["zf"]), rel=0.1)
    assert abs(s["spectrum"].line(-1.0)) == pytest.approx(abs(s["zb"]), rel=0.3)
    e = np.hypot(*np.asarray(s["static0"]).T) / np.asarray(s["clearance"])
    assert np.all(e < 1.0)


def test_a_worn_bearing_s_flows_are_judged_against_its_own_threshold(machine, setup):
    """The Rotor page's Q/Q_T with a worn bearing switched on uses that bearing's own flooded threshold."""
    s = state(machine, setup, machine.bearings[0].node, *parse_effects(["clearance:bearing=1,clearance_um=150"]))
    assert s["q_threshold"][0] > 1.1 * s["q_threshold_declared"][0]
    assert s["q_threshold"][1] == s["q_threshold_declared"][1]
