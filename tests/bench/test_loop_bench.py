"""`lubeviz bench loop` (issue 36, "Build" 7): the cases it draws, how it judges a diagnosis, and a short run.

The draw and the judging are fast; the run makes and diagnoses 6 independent cases (~10-60 s each: one is a
set of three speeds), once for the module, and is marked slow."""

from types import SimpleNamespace

import numpy as np
import pytest

from lubeviz.bench.loop import KINDS, ROW_KEYS, bench_loop, draw_cases, judge, rates
from lubeviz.diagnose.loop import OUTCOMES
from lubeviz.units import MLMIN_PER_M3S


def _key(case):
    return (case["kind"], case["group"], tuple(case["effects"]), tuple(case["speeds_hz"]), tuple(case["q_mlmin"]),
            case["static"], case["seed"])


@pytest.fixture(scope="module")
def cases():
    return draw_cases()


def _params(text):
    return dict(kv.split("=") for kv in text.split(":", 1)[1].split(","))


# --- the draw (fast) --------------------------------------------------------------------------------------------

def test_the_defaults_draw_at_least_150_cases_of_every_kind(cases):
    assert len(cases) >= 150
    kinds = [c["kind"] for c in cases]
    # the six horizontal side loads drawn among the out-of-library cases are library effects now (a side load has a
    # direction): the same draws, judged as the library's
    assert {k: kinds.count(k) for k in KINDS} == {"clean": 40, "effect": 86, "set": 6, "pair": 12, "out": 6}
    assert [c["id"] for c in cases] == list(range(1, len(cases) + 1))


def test_the_cases_do_not_depend_on_the_limit(cases):
    six, twelve = draw_cases(limit=6), draw_cases(limit=12)
    assert [_key(c) for c in six] == [_key(c) for c in twelve[:6]] == [_key(c) for c in cases[:6]]
    assert {c["kind"] for c in six} == set(KINDS)  # round-robin: a small limit still holds every kind
    assert [_key(c) for c in draw_cases(seed=7, limit=6)] != [_key(c) for c in six]


def test_clean_cases_have_no_truth_and_a_third_read_the_static_position(cases):
    clean = [c for c in cases if c["kind"] == "clean"]
    assert all(c["truth"] == [] and c["effects"] == [] for c in clean)
    assert sum(c["static"] for c in clean) == 14  # every third of 40
    for c in clean:
        assert 50.0 <= c["speeds_hz"][0] <= 100.0
        ratio = np.array(c["q_mlmin"]) / np.array(c["qt_mlmin"])
        assert np.all((ratio >= 0.3) & (ratio <= 1.8))
    assert len({round(c["speeds_hz"][0], 3) for c in clean}) > 30  # speeds drawn, not a few grid points


def test_pairs_have_two_effects_and_out_of_library_cases_none_in_the_library(cases):
    pairs = [c for c in cases if c["kind"] == "pair"]
    assert all(len(c["effects"]) == 2 and len(set(c["truth"])) == 2 for c in pairs)
    assert all([e.split(":")[0] for e in c["effects"]] == c["truth"] for c in pairs)
    out = [c for c in cases if c["kind"] == "out"]
    assert all(c["truth"] == [] for c in out)
    assert {c["group"] for c in out} == {"seal"}
    across = [c for c in cases if c["group"] == "side_load horizontal"]
    assert len(across) == 6 and all(c["kind"] == "effect" and c["truth"] == ["side_load"] for c in across)
    for c in across:
        assert 60.0 <= float(_params(c["effects"][0])["angle_deg"]) <= 90.0


def test_each_library_effect_has_two_strengths_and_placements_spread_over_the_rotor(cases):
    effects = [c for c in cases if c["kind"] == "effect"]
    for name in ("viscosity", "clearance", "unbalance2", "pedestals", "probe_rotation", "probe_gain", "bow",
                 "side_load"):
        mine = [c for c in effects if c["group"] == name]
        assert len(mine) == 10 and {c["strength"] for c in mine} == {"weak", "strong"}
        assert all(c["truth"] == [name] for c in mine)
    nodes = [int(_params(c["effects"][0])["node"]) for c in effects if c["group"] == "unbalance2"]
    assert len(set(nodes)) > 3 and any(n not in (10, 13, 15) for n in nodes)
    bows = [int(_params(c["effects"][0])["node"]) for c in effects if c["group"] == "bow"]
    assert len(set(bows)) > 3 and all(8 <= n <= 18 for n in bows)
    loads = [_params(c["effects"][0]) for c in effects if c["group"] == "side_load"]
    assert all(float(p["angle_deg"]) == 0.0 for p in loads)
    assert len({p["node"] for p in loads}) > 3
    bearings = {_params(c["effects"][0])["bearing"] for c in effects if c["group"] == "clearance"}
    assert bearings == {"1", "2"}


def test_sets_are_three_speeds_of_hot_oil_or_a_worn_bearing(cases):
    sets = [c for c in cases if c["kind"] == "set"]
    assert sorted(c["group"] for c in sets) == ["hot oil"] * 3 + ["worn bearing"] * 3
    assert all(len(c["speeds_hz"]) == 3 == len(set(c["speeds_hz"])) for c in sets)
    assert all(c["speeds_hz"] == [60.0, 75.0, 90.0] for c in sets if c["group"] == "hot oil")
    assert {c["effects"][0] for c in sets if c["group"] == "hot oil"} == {"viscosity:factor=0.8"}


def test_a_set_s_speeds_stay_within_the_machine_s_speed_range():
    """The pump runs at 59.5 Hz and is declared up to 65 Hz: the paper's hot-oil set (60, 75, 90 Hz over 75) would
    put its third record at 71.4 Hz, past the model file's range (every such case failed, session 52). Its speeds are
    drawn closer to the operating speed, evenly, and stay in order; the paper's and the fan's are as before."""
    from lubeviz.bench.loop import _scales, set_conditions
    from lubeviz.model.machine import MODELS_DIR

    for name in ("overhung_pump.toml", "three_bearing_fan.toml", "paper_machine.toml"):
        sc = _scales(str(MODELS_DIR / name))
        for group, _, speeds, _ in set_conditions(sc):
            assert sc.speeds[0] - 1e-9 <= min(speeds) and max(speeds) <= sc.speeds[1] + 1e-9, (name, group, speeds)
            assert list(speeds) == sorted(speeds) and len(set(speeds)) == 3
            assert min(speeds) < sc.op <= max(speeds)
    pump = _scales(str(MODELS_DIR / "overhung_pump.toml"))
    hot = next(s for g, _, s, _ in set_conditions(pump) if g == "hot oil")
    assert max(hot) == pytest.approx(65.0) and hot[1] == pytest.approx(59.5)
    assert hot[1] - hot[0] == pytest.approx(hot[2] - hot[1])  # the paper's even steps, shorter


def test_another_machine_draws_over_its_own_parts_speeds_and_sizes():
    """The fan (three bearings, three planes, 24.75 Hz, declared up to 30 Hz): every bearing's flow, all three planes
    or two of them per record, its speeds (16.5-30 Hz; sets at 0.8, 1, 1.2 of its speed), its bearings by number, a worn
    bearing 1 at 165/120 of its clearance, forces scaled by its weight over the paper's."""
    from lubeviz.bench.loop import _scales
    from lubeviz.model.machine import MODELS_DIR, load_machine

    fan = str(MODELS_DIR / "three_bearing_fan.toml")
    m = load_machine(fan)
    cs = draw_cases(fan, n_clean=6, per_strength=2, n_sets=2, n_pairs=2, n_out=2, seed=3)
    planes = {p.node for p in m.measurement_planes}
    for c in cs:
        assert len(c["q_mlmin"]) == 3 == len(c["qt_mlmin"])
        assert len(c["nodes"]) in (2, 3) and set(c["nodes"]) <= planes and c["nodes"] == sorted(c["nodes"])
        assert all(16.5 - 1e-9 <= v <= 30.0 + 1e-9 for v in c["speeds_hz"])
    assert {len(c["nodes"]) for c in cs} == {2, 3} and len({tuple(c["nodes"]) for c in cs if len(c["nodes"]) == 2}) > 1
    sets = [c for c in cs if c["kind"] == "set"]
    hot = next(c for c in sets if c["group"] == "hot oil")
    np.testing.assert_allclose(hot["speeds_hz"], [0.8 * 24.75, 24.75, 1.2 * 24.75])
    worn = next(c for c in sets if c["group"] == "worn bearing")
    assert worn["effects"] == [f"clearance:bearing=1,clearance_um={1e6 * m.bearings[0].clearance * 165 / 120:.4g}"]
    sc = _scales(fan)
    assert 1.0 < sc.force < 1.5  # 7.8 kN against the paper's 6.5 kN
    bearings = {int(_params(c["effects"][0])["bearing"]) for c in draw_cases(fan, n_clean=0, per_strength=8,
                                                                                n_sets=0, n_pairs=0, n_out=0)
                if c["group"] in ("clearance", "pedestals")}
    assert bearings == {1, 2, 3}


def test_a_misaligned_bearing_and_a_loose_support_are_drawn_where_the_machine_has_them(cases):
    """On the fan (3 sleeves and a roller) a bearing moved up or down by 10-40 % of its clearance, and the roller at
    0.3-0.8 of its stiffness, each at two strengths; never on the paper's two bearings, whose loads do not depend on
    where they sit and which has no other support (its 150 cases unchanged)."""
    from lubeviz.model.machine import MODELS_DIR

    assert not any(c["group"] == "misalignment" for c in cases) and len(cases) == 150
    fan = draw_cases(str(MODELS_DIR / "three_bearing_fan.toml"))
    moved = [c for c in fan if c["group"] == "misalignment"]
    assert len(moved) == 10 and len(fan) == 170
    loose = [float(_params(c["effects"][0])["factor"]) for c in fan if c["group"] == "support_stiffness"]
    assert len(loose) == 10 and all(0.3 - 1e-9 <= f <= 0.8 + 1e-9 for f in loose)
    dy = [float(_params(c["effects"][0])["dy_um"]) for c in moved]
    assert all(7.5 - 1e-9 <= abs(v) <= 30.0 + 1e-9 for v in dy) and min(dy) < 0 < max(dy)
    weak = [abs(v) for c, v in zip(moved, dy) if c["strength"] == "weak"]
    assert max(weak) <= 0.25 * 75.0 + 1e-9
    assert {int(_params(c["effects"][0])["bearing"]) for c in moved} == {1, 2, 3}


def test_a_stopped_run_goes_on_from_its_rows_file(tmp_path):
    """Each case's row is appended as it ends; a rerun takes those of the same cases (a line cut short by a stop is
    skipped) and none of another draw's."""
    from lubeviz.bench import loop

    cs = draw_cases(limit=4)
    path = tmp_path / "rows.jsonl"
    loop._append_row(path, cs[1], {"id": cs[1]["id"], "x": np.float64(1.5), "a": np.arange(2)})
    with open(path, "a") as fh:
        fh.write('{"case": "cut')
    got = loop._saved_rows(path, cs)
    assert list(got) == [cs[1]["id"]] and got[cs[1]["id"]]["x"] == 1.5 and got[cs[1]["id"]]["a"] == [0, 1]
    assert loop._saved_rows(path, draw_cases(limit=4, seed=5)) == {}


# --- the judging (fast, on stand-in diagnoses) ------------------------------------------------------------------

def _fit(q_mlmin, half_width_pct, dof=4):
    q = np.asarray(q_mlmin) / MLMIN_PER_M3S
    w = half_width_pct / 100
    return SimpleNamespace(values=np.concatenate([q, [1.0]]), dof=dof, flow_values=lambda: q.copy(),
                           intervals={f"q{k + 1}": (q[k] * (1 - w), q[k] * (1 + w)) for k in range(len(q))})


def _diagnosis(outcome, *, added=None, ambiguous=(), explained=True, q=(500.0, 500.0), width=1.0, dof=4):
    f = _fit(q, width, dof)
    return SimpleNamespace(before=f, final=f, added=None if added is None else SimpleNamespace(label=added),
                           ambiguous=tuple(ambiguous), explained=explained, outcome=outcome, set_intervals=None,
                           scans=(), seconds=1.0, verdict="...")


def test_an_explained_answer_whose_interval_misses_the_truth_is_silent_wrong():
    case = {"truth": [], "effects": []}
    wrong = judge(case, _diagnosis("explained", q=(520.0, 500.0)), [500.0, 500.0])
    assert wrong["silent_wrong"] and not wrong["held"]
    right = judge(case, _diagnosis("explained", q=(503.0, 500.0)), [500.0, 500.0])
    assert right["held"] and not right["silent_wrong"]
    flagged = judge(case, _diagnosis("unexplained", explained=False, q=(520.0, 500.0)), [500.0, 500.0])
    assert not flagged["silent_wrong"]  # the user was warned


def test_a_pair_is_right_only_with_both_names_and_a_single_confident_name_counts_against_it():
    case = {"kind": "pair", "truth": ["viscosity", "probe_rotation"],
            "effects": ["viscosity:factor=0.8", "probe_rotation:plane=1,angle_deg=5"]}
    single = judge(case, _diagnosis("effect added", added="viscosity[bearing=both]"), [500.0, 500.0])
    assert single["named"] == "viscosity" and not single["right_first"] and not single["right_in_set"]
    both = judge(case, _diagnosis("ambiguous", added="viscosity[bearing=both]",
                                  ambiguous=["probe_rotation[plane=1]"]), [500.0, 500.0])
    assert both["named"] is None and both["right_in_set"] and both["placement_right"]
    pair = judge(case, _diagnosis("effect added", added="viscosity[bearing=both]+probe_rotation[plane=1]"),
                 [500.0, 500.0])
    assert pair["right_first"] and pair["named"] == "probe_rotation+viscosity"
    rows = [dict(r, kind="pair", failed=None, node=None) for r in (single, both, pair)]
    r = rates(rows)
    assert (r["pairs_right"]["k"], r["pairs_right"]["n"]) == (2, 3)
    assert (r["pairs_never_single_confident"]["k"], r["pairs_never_single_confident"]["n"]) == (2, 3)


def test_a_pair_whose_verdict_says_it_could_not_test_a_second_fault_is_told_wrong_not_silent():
    """A pair read as one fault on a record that leaves no degree of freedom for a second: the verdict says two faults
    are not ruled out and that the flows hold only if the named one is alone (`pair_untested`). A miss there is told,
    counted apart; the same words on a single fault do not excuse a miss (there is no second fault to blame)."""
    pair = {"kind": "pair", "truth": ["clearance", "unbalance2"],
            "effects": ["clearance:bearing=2,clearance_um=100", "unbalance2:node=16,ratio=0.46,phase_deg=82"]}
    single = {"kind": "effect", "truth": ["pedestals"],
              "effects": ["pedestals:bearing=2,mass_kg=50,stiffness_n_m=1e8,damping_ns_m=1e4"]}
    rows = []
    for case in (pair, single):
        d = _diagnosis("effect added", added="pedestals[bearing=3]", q=(520.0, 500.0))
        d.pair_untested = True
        rows.append(judge(case, d, [500.0, 500.0]))
    told, silent = rows
    assert told["told_wrong"] and not told["silent_wrong"] and not told["held"]
    assert silent["silent_wrong"] and not silent["told_wrong"]
    held = judge(pair, SimpleNamespace(**{**vars(_diagnosis("effect added", added="pedestals[bearing=3]")),
                                          "pair_untested": True}), [500.0, 500.0])
    assert held["held"] and not held["told_wrong"] and not held["silent_wrong"]


def test_a_pair_the_record_cannot_determine_is_counted_apart():
    """Two flows and a second unbalance (ratio, phase) with a gain: 2 + 3 parameters. One record of two planes without
    the DC gap (6 features, the plain fit's dof 4) leaves 1 for the pair, below PAIR_DOF; with the DC gap (dof 8), 5."""
    from lubeviz.diagnose.loop import PAIR_DOF

    case = {"kind": "pair", "truth": ["unbalance2", "probe_gain"],
            "effects": ["unbalance2:node=10,ratio=0.3,phase_deg=40", "probe_gain:channel=x1,gain=1.1"]}
    thin = judge(case, _diagnosis("unexplained", explained=False, dof=4), [500.0, 500.0])
    rich = judge(case, _diagnosis("effect added", added="unbalance2[node=10]+probe_gain[channel=x1]", dof=8),
                 [500.0, 500.0])
    assert (thin["truth_dof"], rich["truth_dof"]) == (1, 5) and thin["truth_dof"] < PAIR_DOF <= rich["truth_dof"]
    r = rates([dict(x, kind="pair", failed=None, node=None) for x in (thin, rich)])
    assert (r["pairs_right"]["k"], r["pairs_right"]["n"]) == (1, 2)
    assert (r["pairs_right_where_determinable"]["k"], r["pairs_right_where_determinable"]["n"]) == (1, 1)


def test_an_effect_the_record_does_not_show_is_counted_apart_when_its_flows_hold():
    """An effect case explained by the plain model with flows that hold is neither right nor silent: counted as unseen
    (a loose roller far from every plane), per effect beside the named ones; with a flow missed it stays silent."""
    from lubeviz.bench.loop import summarize

    case = {"kind": "effect", "group": "support_stiffness", "truth": ["support_stiffness"],
            "effects": ["support_stiffness:support=1,factor=0.6"]}
    unseen = judge(case, _diagnosis("explained", q=(503.0, 500.0)), [500.0, 500.0])
    missed = judge(case, _diagnosis("explained", q=(520.0, 500.0)), [500.0, 500.0])
    named = judge(case, _diagnosis("effect added", added="support_stiffness[support=1]"), [500.0, 500.0])
    rows = [dict(r, id=k, kind="effect", group="support_stiffness", failed=None, node=None, seconds=1.0,
                 case_seconds=1.0, speeds_hz=[25.0], redraws=0, static=False, q_mlmin=[500.0, 500.0],
                 truth={"effects": case["truth"], "specs": case["effects"]})
            for k, r in enumerate((unseen, missed, named), start=1)]
    r = rates(rows)
    assert (r["library_unseen_and_held"]["k"], r["library_unseen_and_held"]["n"]) == (1, 3)
    assert (r["library_right_first_or_in_set"]["k"], r["silent_wrong_all"]["k"]) == (1, 1)
    assert summarize(rows)["summary"]["library_by_effect"] == {"support_stiffness": [1, 1, 3]}


def test_the_placement_is_judged_for_bearings_planes_and_channels():
    case = {"truth": ["clearance"], "effects": ["clearance:bearing=2,clearance_um=150"]}
    wrong = judge(case, _diagnosis("effect added", added="clearance[bearing=1]"), [500.0, 500.0])
    assert wrong["right_first"] and wrong["placement_right"] is False
    right = judge(case, _diagnosis("effect added", added="clearance[bearing=2]"), [500.0, 500.0])
    assert right["placement_right"] is True


# --- a short run (slow) -----------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def run():
    return bench_loop(limit=6, processes=1)


@pytest.mark.slow
def test_every_row_has_its_keys_and_ran(run):
    rows = run["rows"]
    assert [r["id"] for r in rows] == list(range(1, 7))
    assert {r["kind"] for r in rows} == set(KINDS)
    for r in rows:
        assert set(ROW_KEYS) <= set(r), set(ROW_KEYS) - set(r)
        assert r["failed"] is None, r["failed"]
        assert r["outcome"] in OUTCOMES
        assert r["silent_wrong"] + r["told_wrong"] == (r["explained"] and not r["held"])
        assert len(r["flow_error_pct_before"]) == len(r["flow_error_pct_after"]) == 2
        assert 0.0 < r["seconds"] <= r["case_seconds"]
        if r["kind"] == "clean":
            assert r["truth"]["effects"] == [] and not r["right_in_set"]
        if r["kind"] == "pair":
            assert len(r["truth"]["effects"]) == 2
        if r["named"] is not None:
            assert r["outcome"] != "ambiguous" and r["added"] is not None
    assert run["summary"]["cases"] == 6 and run["summary"]["records"] == 8  # one set of three speeds


@pytest.mark.slow
def test_the_rates_are_counts_with_their_wilson_interval(run):
    assert run["rates"]["silent_wrong_all"]["n"] == 6
    assert run["rates"]["clean_explained"]["n"] == 2
    for name, r in run["rates"].items():
        assert 0 <= r["k"] <= r["n"], name
        lo, hi = r["wilson95"]
        assert 0.0 <= lo <= hi <= 1.0, name
        if r["n"]:
            assert r["rate"] == pytest.approx(r["k"] / r["n"]) and lo <= r["rate"] <= hi, name
        else:
            assert r["rate"] is None


@pytest.mark.slow
def test_the_confusion_matrix_and_the_silent_wrong_list_agree_with_the_rows(run):
    rows = run["rows"]
    assert sum(sum(v.values()) for v in run["confusion"].values()) == len(rows)
    assert run["confusion"]["clean"] and sum(run["confusion"]["clean"].values()) == 2
    assert [c["id"] for c in run["silent_wrong_cases"]] == [r["id"] for r in rows if r["silent_wrong"]]
    s = run["summary"]
    assert s["silent_wrong"] == len(run["silent_wrong_cases"])
    assert 0.0 < s["diagnose_seconds_median"] <= s["diagnose_seconds_max"]


def test_a_supply_the_model_file_gives_is_drawn_as_given_and_not_judged(tmp_path):
    """A bearing whose file gives its supply (known: `supply_mlmin`; flooded: fed above its Q_T) is drawn at that
    supply, the others as before (the same draws); its flow is no parameter of the fit, so only the identified flows'
    intervals are judged."""
    from lubeviz.bench.loop import FLOODED_OVER_QT
    from lubeviz.model.machine import MODELS_DIR

    pump = (MODELS_DIR / "overhung_pump.toml").read_text()
    anchor = 'name = "bearing 1 (coupling end)"\n'
    path = tmp_path / "pump_known.toml"
    path.write_text(pump.replace(anchor, anchor + 'supply = "known"\nsupply_mlmin = 40.0\n', 1))
    flooded = tmp_path / "pump_flooded.toml"
    flooded.write_text(pump.replace(anchor, anchor + 'supply = "flooded"\n', 1))
    plain = draw_cases(str(MODELS_DIR / "overhung_pump.toml"), n_clean=4, per_strength=0, n_sets=2, n_pairs=0,
                       n_out=0, seed=5)
    for given, first in ((path, lambda c: 40.0), (flooded, lambda c: FLOODED_OVER_QT * c["qt_mlmin"][0])):
        for c, p in zip(draw_cases(str(given), n_clean=4, per_strength=0, n_sets=2, n_pairs=0, n_out=0, seed=5),
                        plain):
            assert c["q_mlmin"][0] == pytest.approx(first(c), rel=1e-12)
            assert c["q_mlmin"][1] == p["q_mlmin"][1]
    d = _diagnosis("explained", q=(500.0, 500.0))
    d.final.names = ("q2",)  # q1 given: the fit holds it
    d.final.intervals = {"q2": d.final.intervals["q2"]}
    assert judge({"truth": [], "effects": []}, d, [40.0, 501.0])["held"]
    assert not judge({"truth": [], "effects": []}, d, [40.0, 520.0])["held"]


def test_a_worn_bearing_set_drawn_again_is_a_little_less_worn_never_below_the_floor():
    """The pump's worn-bearing sets whirled at every flow drawn (session 52): later redraws shrink the wear toward the
    declared clearance (`less_worn`), each keeping WEAR_SHRINK of it, never below WEAR_FLOOR x the declared; any
    other effect is left as it is."""
    from lubeviz.bench.loop import WEAR_FLOOR, WEAR_SHRINK, less_worn
    from lubeviz.model.machine import MODELS_DIR, load_machine

    pump = str(MODELS_DIR / "overhung_pump.toml")
    c0 = 1e6 * load_machine(pump).bearings[0].clearance
    text = f"clearance:bearing=1,clearance_um={1.375 * c0:.4g}"
    seen = []
    for _ in range(12):
        text = less_worn(text, pump)
        seen.append(float(_params(text)["clearance_um"]))
    assert seen[0] == pytest.approx(c0 + WEAR_SHRINK * 0.375 * c0, rel=1e-3)
    assert all(b <= a for a, b in zip(seen, seen[1:])) and min(seen) == pytest.approx(WEAR_FLOOR * c0, rel=1e-3)
    assert _params(text)["bearing"] == "1"
    assert less_worn("viscosity:factor=0.8", pump) == "viscosity:factor=0.8"
