"""Node scans (issue 36, item 2): an effect that acts at a node is fitted at every node where it can act, and the
verdict says where it sits only as far as the record's profile over the nodes does."""

import math

import numpy as np
import pytest

from lubeviz.diagnose import diagnose, diagnosis_dict
from lubeviz.diagnose.scan import SCAN_DCHI2, NodeScan, NodeSweep
from lubeviz.effects import Bow, Unbalance2
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.identify.forward.measured import measure
from lubeviz.rotor import rotor_from_machine
from lubeviz.units import MLMIN_PER_M3S
from lubeviz.verification import IndependentSpec, make_record


def test_a_sharp_profile_locates_and_a_flat_one_says_which_nodes_fit():
    sharp = NodeScan("unbalance2", (1, 2, 3, 4, 5, 6), (90.0, 40.0, 3.0, 1.0, 4.0, 80.0))
    assert sharp.best == 4 and sharp.fitting == (3, 4, 5) and sharp.identifiable
    assert "fits best at node 4" in sharp.words()
    flat = NodeScan("unbalance2", (1, 2, 3, 4, 5, 6, 7), (1.0, 1.2, 1.1, 50.0, 1.5, 1.0 + SCAN_DCHI2, math.inf))
    assert not flat.identifiable and flat.fitting == (1, 2, 3, 5, 6)
    assert "not identifiable" in flat.words() and "nodes 1-3, 5-6" in flat.words()
    d = flat.as_dict()
    assert d["chi2"][-1] is None and d["fitting_nodes"] == [1, 2, 3, 5, 6] and d["identifiable"] is False


def test_every_node_where_an_effect_can_act_is_scanned(machine):
    rotor = rotor_from_machine(machine)
    assert Unbalance2().scan_nodes(rotor) == tuple(range(1, rotor.n_nodes + 1))  # any node, not only a disc
    # a bow is one sine between the bearings whatever its node (the node only says where its amplitude is quoted):
    # every node fits alike, so it is not scanned, and its amplitude is quoted midway
    assert Bow().scan_nodes(rotor) == ()
    z = rotor.node_z
    z1, z2 = (z[n - 1] for n in rotor.bearing_nodes)
    mid = Bow().amplitude_node(rotor)
    assert abs(z[mid - 1] - 0.5 * (z1 + z2)) <= 0.5 * max(np.diff(z))


class _Fake:
    """An effect at a node, as a node scan sees it."""

    def __init__(self, node, name="unbalance2"):
        self.node, self.effect_name = node, name

    def label(self):
        return f"{self.effect_name}[node={self.node}]"

    def title(self):  # what the scan's progress shows
        return f"a second unbalance at node {self.node}"


class _C:
    """A candidate's fit at a node: its chi2, and `tag` as its answer (what a warm start carries)."""

    def __init__(self, node, chi2, tag, name="unbalance2"):
        self.effect, self.fit = _Fake(node, name), type("F", (), {"chi2": chi2, "values": np.array([tag])})()
        self.aic = chi2


def test_the_scan_keeps_the_best_basin_when_a_warm_start_strays():
    """A node whose warm start from one side strays into a poor basin is caught by the sweep from the other side;
    the best node is fitted again from its own starts."""
    calls = []
    good = {1: 5.0, 2: 4.0, 3: 2.0, 4: 6.0}

    def fit_one(e, start, screening=True):
        tags = None if start is None else tuple(float(row[0]) for row in np.atleast_2d(start))
        calls.append((e.node, tags))
        if e.node == 3 and tags == (2.0,):
            return _C(3, 500.0, 3)  # from node 2's answer (its only start) the fit strays
        return _C(e.node, good[e.node], e.node)

    best, profile = NodeSweep([_Fake(n) for n in (1, 2, 3, 4)], fit_one).run()
    assert best.effect.node == 3 and profile.chi2 == (5.0, 4.0, 2.0, 6.0)
    assert (3, (2.0,)) in calls  # first from node 2's side, the only one fitted then
    assert (3, (4.0,)) in calls and (3, None) in calls  # from node 4's side, and from its own starts


def test_a_node_starts_from_its_neighbours_on_both_sides_and_its_own_screening_answer():
    """The full pass over every node starts each from its nearest fitted neighbour on each side and from its own and
    its neighbours' screening answers: `fit` refines the one the model fits best (a force's size carried one node on
    can sit far down a flat valley)."""
    calls = []

    def fit_one(e, start, screening=True):
        tags = None if start is None else tuple(sorted(float(row[0]) for row in np.atleast_2d(start)))
        calls.append((e.node, screening, tags))
        return _C(e.node, 1.0 + e.node, 100 * screening + e.node, "side_load")

    sweep = NodeSweep([_Fake(n, "side_load") for n in (1, 2, 3, 4, 5)], fit_one)
    sweep.run(2)  # screening at nodes 1, 3, 5
    sweep.run(1, screening=False)
    full = {}
    for n, s, t in calls:
        if not s:
            full.setdefault(n, t)  # each node's first full fit
    assert full[1] == (101.0,)  # the best screening node first, from its own screening answer
    assert full[2] == (1.0, 101.0, 103.0)  # node 1's full answer; nodes 1 and 3's screening ones
    assert full[3] == (2.0, 103.0)  # node 2's full answer, its own screening one (node 4 has none)


def test_a_node_the_linear_picture_ranks_best_is_fitted_from_its_own_starts():
    """Warm starts carried from node to node can all stay in a poorer basin, and the nodes between those screened
    are never fitted: the node the linear picture ranks best, by more than SCAN_DCHI2 below the best found, is
    fitted from its own starts and joins the profile (the fan's loop, case 96: a second unbalance at node 4 scanned
    to node 1 at chi2 21.6, 2.0 at node 4). A picture that promises nothing better fits nothing more."""
    own = {1: 21.6, 2: 30.0, 3: 32.8, 4: 1.95, 5: 5.2, 6: 40.0, 7: 45.0, 8: 50.0, 9: 55.0, 10: 60.0, 11: 65.0}

    def fit_one(e, start, screening=True):
        if start is None:  # its own starts: the node's best basin
            return _C(e.node, own[e.node], e.node)
        return _C(e.node, max(own[e.node], 21.6 + e.node), e.node)  # warm starts stay in node 1's basin

    def run(picture):
        calls = []

        def counted(e, start, screening=True):
            calls.append((e.node, start is None))
            return fit_one(e, start, screening)

        sweep = NodeSweep([_Fake(n) for n in own], counted, picture=picture)
        return sweep.run(2), calls

    picture = [40.0, 35.0, 30.0, 2.5, 6.0, 50.0, 60.0, 70.0, 80.0, 90.0, 17.0]
    (best, profile), calls = run(lambda effects: picture)
    assert best.effect.node == 4 and 4 in profile.nodes and profile.chi2[profile.nodes.index(4)] == 1.95
    assert (4, True) in calls and (5, True) in calls  # the PICTURED best two, each promising a better fit ...
    assert (11, True) not in calls  # ... and not the third (17.0 promised): PICTURED nodes at most
    (best, profile), calls = run(lambda effects: [30.0] * len(own))  # nothing better promised: as before
    assert 4 not in profile.nodes and not any(own_start and n == 4 for n, own_start in calls)
    (best, profile), calls = run(None)
    assert 4 not in profile.nodes


@pytest.mark.slow
def test_a_second_unbalance_off_the_discs_is_in_the_set_with_its_node_among_those_that_fit(machine):
    """A second unbalance at node 4 (outboard of bearing 1, no disc there), on the independent source's record:
    at one speed a 1X force at most nodes explains it, so the node is not claimed; the truth's node is among those
    that fit, the flows come back within 1 % and the JSON carries the profile."""
    q = (500.0, 580.0)
    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=q[0], q2_mlmin=q[1], effects=("unbalance2:node=4,ratio=0.6,phase_deg=200",),
                           seed=4, total_s=8.0)
    chain = ForwardChain(machine, 75.0, tuple(machine.center_nodes))
    d = diagnose(chain, measure(make_record(spec).record), truth={"q_mlmin": list(q)})
    profile = next(s for s in d.scans if s.effect_name == "unbalance2")
    assert 4 in profile.fitting
    assert not profile.identifiable and "not identifiable" in d.verdict
    assert np.abs(d.final.values[:2] * MLMIN_PER_M3S / np.array(q) - 1).max() < 0.01
    scans = diagnosis_dict(d)["node_scans"]
    assert {s["effect"] for s in scans} == {"unbalance2"}


def test_a_sweep_s_family_is_its_label_without_the_node():
    """One effect scanned in two forms (a side load along the weight, and one whose direction is fitted) makes two
    sweeps; the verdict completes and quotes the one it names (`diagnose.loop._named_families`)."""
    from lubeviz.diagnose.loop import _complete_scans, _named_families
    from lubeviz.diagnose.scan import family

    assert family("side_load[node=5,direction=fitted]") == "side_load[direction=fitted]"
    assert family("side_load[node=None]") == family("side_load[node=12]") == "side_load"
    assert family("bow[span=2]") == "bow[span=2]" and family("unbalance2[node=3]") == "unbalance2"

    class _Named:
        label = "side_load[node=7,direction=fitted]"

    assert _named_families(_Named(), ("unbalance2[node=3] + probe_gain[channel=x1]",)) == {
        "side_load[direction=fitted]", "unbalance2", "probe_gain[channel=x1]"}

    class _Sweep:
        def __init__(self, fam):
            self.fam, self.completed = fam, False

        def run(self, stride, screening=True):
            self.completed = True
            return None, NodeScan("side_load", (1, 2), (0.0, 1.0), self.fam)

    along, across = _Sweep("side_load"), _Sweep("side_load[direction=fitted]")
    scans = [(along, NodeScan("side_load", (1,), (0.0,), "side_load")),
             (across, NodeScan("side_load", (1,), (0.0,), "side_load[direction=fitted]"))]
    _complete_scans(scans, _Named(), ())
    assert across.completed and not along.completed


def test_a_node_far_worse_than_both_neighbours_is_fitted_from_its_own_starts():
    """A spike in the profile (the fan loop's case 168: nodes 17, 19, 21 at chi2 305, 4596, 82 from warm starts) is a
    node in a basin of its own; from its own starts it fits (5.0 there, the truth beside it). A profile without
    spikes costs no extra fits."""
    def sweep_of(profile, own):
        def fit_one(e, start, screening=True):
            return _C(e.node, own[e.node] if start is None else profile[e.node], float(e.node))
        return NodeSweep([_Fake(n) for n in sorted(profile)], fit_one)

    warm = {1: 300.0, 2: 305.0, 3: 4596.0, 4: 82.0, 5: 90.0}
    own = {1: 300.0, 2: 305.0, 3: 5.0, 4: 82.0, 5: 90.0}
    best, scan = sweep_of(warm, own).run(1)
    assert scan.best == 3 and best.fit.chi2 == 5.0

    smooth = {1: 300.0, 2: 200.0, 3: 150.0, 4: 82.0, 5: 90.0}
    fitted = []
    sweep = sweep_of(smooth, smooth)
    inner = sweep.fit_one
    sweep.fit_one = lambda e, start, screening=True: fitted.append((e.node, start is None)) or inner(e, start, screening)
    sweep.run(1)
    # node 3 between 200 and 82 at 150 is no spike: fitted from its neighbours only (1 is the first node fitted, 4 the
    # best, 2 and 5 the middles of runs that do not fit, `_reach_gaps`)
    assert sorted(n for n, own_start in fitted if own_start) == [1, 2, 4, 5]


@pytest.mark.slow
def test_a_second_unbalance_the_warm_starts_missed_is_found_where_the_linear_picture_points():
    """The fan loop's case 96 (session 63): a second unbalance at node 4 (0.52 of the main one), one record at 19.5 Hz
    of the fan's three planes. The scan's warm starts all stayed in node 1's basin (chi2 21.6) and the record was
    named a bowed shaft (7.7), the truth outside the set. From its own starts node 4 fits at chi2 2.0: the linear
    picture ranks it first, the scan fits it there, and the second unbalance at node 4 leads the ranking with its
    flows holding."""
    from lubeviz.diagnose.pipeline import run_diagnosis
    from lubeviz.model.machine import MODELS_DIR, load_machine

    fan = str(MODELS_DIR / "three_bearing_fan.toml")
    q = (91.67709994392324, 552.3176195595626, 164.97066293398353)
    spec = IndependentSpec(speed_hz=19.50445405545562, q_mlmin=q, seed=70674107, machine=fan, nodes=(7, 15, 23),
                           effects=("unbalance2:node=4,ratio=0.5238,phase_deg=263.3",))
    d = run_diagnosis([make_record(spec).record], load_machine(fan)).diagnosis
    scan = next(s for s in d.scans if s.effect_name == "unbalance2")
    assert 4 in scan.nodes and scan.best in (3, 4, 5) and 4 in scan.fitting
    # within a node of the truth (issue 36's measure of a node-placed effect): node 4 until session 68, node 5 since
    # the films of the leaning loads are corrected (4 still among the nodes that fit)
    near = {f"unbalance2[node={n}]" for n in (3, 4, 5)}
    best = min((c for c in d.candidates if c.fit is not None and not c.partners), key=lambda c: c.aic)
    assert best.label in near and best.passes
    named = {getattr(c, "label", c) for c in ([d.added] if d.added is not None else []) + list(d.ambiguous)}
    assert named & near, d.verdict
    lo_hi = [d.final.intervals[f"q{k + 1}"] for k in range(3)]
    assert all(lo <= v / MLMIN_PER_M3S <= hi for (lo, hi), v in zip(lo_hi, q)), (lo_hi, q)
