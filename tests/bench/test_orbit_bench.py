"""`lubeviz bench coverage --large-orbit` on any machine (`bench.records.bench_orbit`, `orbit_jobs`): the draws, a
record the source cannot make counted apart, a stopped run going on from its rows file. The identifications
themselves are the large-orbit fit's tests' subject (tests/identify/test_orbit_fit*.py); here they are stood in for."""

import numpy as np
import pytest

from lubeviz.bench import records
from lubeviz.verification.independent import thresholds_mlmin

FAN = "models/three_bearing_fan.toml"


def test_the_paper_machine_s_draws_are_those_of_every_session_before():
    """Two flows drawn as (Q1, Q2) over Q_T at 75 Hz and a scale, seeded seed * 1000 + i, the spec folded into q1 / q2
    as the two-bearing records always were (so their cached orbits keep their keys)."""
    jobs = records.orbit_jobs(None, n=4, seed=7)
    qt = thresholds_mlmin(75.0, None)
    rng = np.random.default_rng(7)
    for i, (spec, scale) in enumerate(jobs):
        q = qt * rng.uniform(0.75, 1.25, 2)
        assert scale == rng.uniform(0.5, 1.0)
        assert spec.speed_hz == 75.0 and spec.seed == 7000 + i
        assert spec.q_mlmin is None and (spec.q1_mlmin, spec.q2_mlmin) == pytest.approx(tuple(q), rel=1e-15)


def test_another_machine_s_draws_hold_every_flow_at_its_own_speed_and_ranges():
    jobs = records.orbit_jobs(FAN, n=30, seed=3, flows=(0.6, 1.4), scales=(2.5, 4.0))
    qt = thresholds_mlmin(24.75, FAN)  # the fan's operating speed
    q = np.array([spec.flows_mlmin for spec, _ in jobs])
    assert q.shape == (30, 3)
    assert np.all(q >= 0.6 * qt) and np.all(q <= 1.4 * qt)
    assert (q / qt).min() < 0.7 and (q / qt).max() > 1.3  # the whole range is drawn, each bearing on its own
    assert np.all(np.std(q / qt, axis=0) > 0.15)
    assert all(2.5 <= s <= 4.0 for _, s in jobs) and all(spec.machine == FAN for spec, _ in jobs)
    assert {spec.speed_hz for spec, _ in jobs} == {24.75}
    assert len({spec.seed for spec, _ in jobs}) == 30


def _fake_rows(calls):
    def fake(machine_path, spec, scale, source, harmonics, time_rounds, pooled=False):
        calls.append(spec.seed)
        q = list(spec.flows_mlmin)
        if spec.seed % 1000 == 1:  # the source found no periodic orbit for this draw
            return {"not_made": "no periodic orbit near the linear one", "q_mlmin": q, "unbalance_scale": scale}
        row = {"max_abs_error_pct": 0.5 + spec.seed % 1000, "holds": [True] * len(q), "above_qt": [False] * len(q),
               "explained": True, "truth_in_alt": False, "seconds": 30.0, "sigma_pct": [3.0] * len(q)}
        return {str(h): row for h in harmonics}
    return fake


def test_a_record_not_made_is_counted_apart_and_a_stopped_run_goes_on_from_its_rows(monkeypatch, tmp_path):
    calls = []
    monkeypatch.setattr(records, "_orbit_rows", _fake_rows(calls))
    rows = tmp_path / "rows.jsonl"
    kw = dict(n=4, seed=5, source="balance", harmonics=(5,), workers=1, flows=(0.6, 1.4), scales=(2.5, 4.0),
              rows_path=rows)
    out = records.bench_orbit(FAN, **kw)
    assert sorted(calls) == [5000, 5001, 5002, 5003]
    assert out["drawn"] == 4 and out["records"] == 3  # the one not made is not a miss of the identification
    assert [m["error"] for m in out["not_made"]] == ["no periodic orbit near the linear one"]
    s = out["harmonics 5"]
    assert s["records"] == 3 and s["error_pct_max"] == 3.5 and s["failed"]["k"] == 0
    assert (s["coverage_q3"]["k"], s["coverage_q3"]["n"]) == (3, 3)  # every flow of the machine
    # a run stopped after its rows were written goes on without identifying them again ...
    calls.clear()
    again = records.bench_orbit(FAN, **kw)
    assert calls == [] and again["harmonics 5"] == s
    # ... and one with more records identifies only the new ones; other settings are other rows
    records.bench_orbit(FAN, **{**kw, "n": 6})
    assert sorted(calls) == [5004, 5005]
    calls.clear()
    records.bench_orbit(FAN, **{**kw, "harmonics": (8,)})
    assert len(calls) == 4
    # a line cut short by a stopped run is read past
    with open(rows, "a", encoding="utf-8") as fh:
        fh.write('{"key": "cut sh')
    calls.clear()
    records.bench_orbit(FAN, **kw)
    assert calls == []


def test_the_bench_refuses_a_worker_count_that_is_not_one_or_more():
    with pytest.raises(ValueError, match="workers"):
        records.bench_orbit(FAN, n=1, workers=0)


def test_workers_ask_for_one_thread_each_and_the_environment_is_given_back(monkeypatch):
    import os

    from lubeviz.bench.workers import THREAD_VARS, one_thread_each

    monkeypatch.setenv("OMP_NUM_THREADS", "7")
    monkeypatch.delenv("NUMBA_NUM_THREADS", raising=False)
    with one_thread_each():
        assert all(os.environ[v] == "1" for v in THREAD_VARS)
    assert os.environ["OMP_NUM_THREADS"] == "7" and "NUMBA_NUM_THREADS" not in os.environ
    with pytest.raises(RuntimeError), one_thread_each():
        raise RuntimeError("a stopped bench")
    assert os.environ["OMP_NUM_THREADS"] == "7" and "NUMBA_NUM_THREADS" not in os.environ


def test_a_rows_file_keeps_numpy_values_as_numbers_and_lists(tmp_path):
    import numpy as np

    from lubeviz.bench.workers import append_saved, read_saved

    path = tmp_path / "rows.jsonl"
    append_saved(path, "key", "a", "rows", {"held": np.bool_(True), "chi2": np.float64(1.5), "q": np.arange(3.0)})
    assert read_saved(path, "key", "rows") == {"a": {"held": True, "chi2": 1.5, "q": [0.0, 1.0, 2.0]}}
    with pytest.raises(TypeError, match="set is not JSON"):
        append_saved(path, "key", "b", "rows", {1, 2})
