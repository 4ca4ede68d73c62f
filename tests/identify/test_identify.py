"""Identification: the fast forward model is exact, and records made by `lubeviz simulate` are identified."""

import dataclasses
import math

import numpy as np
import pytest

from lubeviz.cli.main import main
from lubeviz.errors import InputError
from lubeviz.identify.tables.cache import machine_tables
from lubeviz.identify.forward.model import ALL_FEATURES, ForwardModel, wrap_difference
from lubeviz.identify.forward.measured import measure
from lubeviz.identify.paper.newton import identify
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.rotor import machine_unbalance, rotor_from_machine, unbalance_response
from lubeviz.units import MLMIN_PER_M3S
from tests.records import read_record, record_from_arrays


@pytest.fixture(scope="session")
def tables():
    """The shipped machine's tables and the cache they come from: the suite's (its slices are seeds; a cache of this
    session's own built them cold, 17 s of a worker)."""
    from lubeviz.identify.tables.cache import cache_dir
    from lubeviz.model.machine import load_machine

    return machine_tables(load_machine()), cache_dir()


@pytest.fixture(scope="session")
def model(tables):
    from lubeviz.model.machine import load_machine

    return ForwardModel(load_machine(), tables[0], (6, 20))


@pytest.mark.parametrize("nodes", [(6, 20), (5, 21)])
def test_rank_4_update_equals_the_direct_solve(machine, tables, nodes):
    model = ForwardModel(machine, tables[0], nodes)
    rotor = rotor_from_machine(machine)
    for q1, q2 in ((300 / MLMIN_PER_M3S, 800 / MLMIN_PER_M3S), (546 / MLMIN_PER_M3S, 420 / MLMIN_PER_M3S)):
        r = model.response(q1, q2)
        coeffs = [t.coefficients(q) for t, q in zip(model.tables, (q1, q2))]
        ref = unbalance_response(rotor, model.omega, machine_unbalance(machine), coeffs, nodes=nodes)
        assert np.allclose(r.x, ref.x, rtol=0, atol=1e-10 * np.abs(ref.x).max())
        assert np.allclose(r.y, ref.y, rtol=0, atol=1e-10 * np.abs(ref.y).max())


def test_feature_jacobian_matches_finite_differences(model):
    q1, q2 = 450 / MLMIN_PER_M3S, 600 / MLMIN_PER_M3S
    g, J = model.features_jacobian(q1, q2, ALL_FEATURES)
    h = 1e-3 * model.q_threshold
    for k in range(2):
        dq = np.eye(2)[k] * h[k]
        fd = wrap_difference(model.features(q1 + dq[0], q2 + dq[1], ALL_FEATURES)
                             - model.features(q1 - dq[0], q2 - dq[1], ALL_FEATURES), ALL_FEATURES) / (2 * h[k])
        assert np.allclose(J[:, k], fd, rtol=2e-3, atol=1e-3 * np.abs(J).max())
    assert np.allclose(g, model.features(q1, q2, ALL_FEATURES))


@pytest.mark.parametrize("q", [(300.0, 800.0), (500.0, 450.0), (650.0, 380.0)])
def test_simulated_records_off_the_paper_grid_are_identified_within_their_uncertainty(
        capsys, tmp_path, tables, q, monkeypatch):
    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tables[1]))
    path = tmp_path / "rec.csv"
    assert main(["simulate", "--q1-mlmin", str(q[0]), "--q2-mlmin", str(q[1]), "--seed", "11", "-o", str(path)]) == 0
    capsys.readouterr()
    assert main(["identify", str(path), "--json"]) == 0
    import json

    out = json.loads(capsys.readouterr().out)
    for k in (1, 2):
        err = abs(out[f"q{k}_mlmin"] - q[k - 1])
        assert err < 3 * out[f"q{k}_std_mlmin"], (k, out[f"q{k}_mlmin"], out[f"q{k}_std_mlmin"])
        assert err < 0.01 * q[k - 1]
    assert out["converged"]
    for k in (0, 1):  # the verdict follows the true flow's ratio to Q_T (none of these sits near 0.95 or 1.05)
        ratio = q[k] / out["q_threshold_mlmin"][k]
        assert out["verdict"][k] == ("starved" if ratio < 0.95 else "over-supplied" if ratio > 1.05 else "normal")


def test_paper_mode_converges_from_the_start_grid_and_keeps_every_path(model):
    from lubeviz.signals.synthesize import synthesize_record

    rec = synthesize_record(model.machine, (448.5 / MLMIN_PER_M3S, 604.5 / MLMIN_PER_M3S), rng=np.random.default_rng(0),
                            method="steady")
    res = identify(model, measure(rec), IdentificationSettings.paper())
    assert res.converged and res.starts_tried >= 1
    assert np.allclose(res.q * MLMIN_PER_M3S, (448.5, 604.5), rtol=0.01)
    start = res.paths[0][0] / model.q_threshold
    assert np.all(np.isin(np.round(start, 6), [0.7, 1.0, 1.3]))  # each path begins on the 3x3 grid
    assert sum(len(p) - 1 for p in res.paths) == res.iterations


def _record(x, y, speed=75.0, fs=1e4, n=50_000):
    t = np.arange(n) / fs
    e = np.exp(2j * math.pi * speed * t)
    xs = [(a * e).real for a in x]
    ys = [(b * e).real for b in y]
    return record_from_arrays(xs[0], ys[0], xs[1], ys[1], speed_hz=speed, sample_rate_hz=fs)


def test_refuses_records_it_cannot_use(model):
    rng = np.random.default_rng(2)
    circ = _record([10e-6, 12e-6], [-10e-6j, -12e-6j])  # circular forward orbits: no backward line
    noisy = dataclasses.replace(circ, displacement=circ.displacement + 1e-7 * rng.standard_normal(circ.displacement.shape))
    with pytest.raises(InputError, match="buried in noise"):
        identify(model, measure(noisy))
    silence = dataclasses.replace(circ, displacement=1e-6 * rng.standard_normal(circ.displacement.shape))
    with pytest.raises(InputError, match="no usable 1X"):
        identify(model, measure(silence))
    fast = _record([10e-6, 12e-6], [4e-6, -5e-6j], speed=90.0)
    with pytest.raises(InputError, match="far from the model"):
        identify(model, measure(fast))


def test_batch_reports_each_bad_file_and_exits_2(capsys, tmp_path, tables, monkeypatch):
    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tables[1]))
    good = tmp_path / "good.npz"
    assert main(["simulate", "--q1-mlmin", "450", "--q2-mlmin", "600", "--method", "steady", "-o", str(good)]) == 0
    bad = tmp_path / "bad.csv"
    bad.write_text("# speed_hz: 75\n# units: um\n# sample_rate_hz: 10000\nx1,y1,x2\n1,2,3\n")
    capsys.readouterr()
    code = main(["identify", str(good), str(bad), "--json", "--workers", "1"])
    import json

    out = json.loads(capsys.readouterr().out)
    assert code == 2 and out["failed"] == 1
    assert "q1_mlmin" in out["records"][0] and "bad.csv" in out["records"][1]["error"]
    assert read_record(good).metadata["q1_mlmin"] == "450"


def test_a_record_from_a_different_machine_is_flagged_as_unexplained(model):
    """Oil 30 % more viscous than the model's (a cold machine): the features cannot all be matched."""
    from lubeviz.model.machine import load_machine
    from lubeviz.signals.synthesize import synthesize_record

    other = load_machine()
    other.bearings = [b.copy(viscosity=1.3 * b.viscosity) for b in other.bearings]
    rec = synthesize_record(other, (450 / MLMIN_PER_M3S, 600 / MLMIN_PER_M3S), rng=np.random.default_rng(4), method="steady")
    res = identify(model, measure(rec))
    assert res.model_explains_data is False and "does not explain" in res.message


def test_the_std_shown_is_never_narrower_than_the_profile_interval():
    """`fit.std_within`: a flow whose 95 % profile interval is wider on one side than 1.96 sigma gets that
    side's half-width / 1.96 as its std, its covariance row and column scaled so the correlations stay;
    a narrower or an open interval, or a parameter without one, is left as it is."""
    from lubeviz.identify.fit.least_squares import Z95, std_within

    names = ("q1", "q2", "effect.factor")
    values = np.array([8e-6, 9e-6, 1.1])
    std = np.array([1e-7, 2e-7, 0.05])
    corr = np.array([[1.0, -0.6, 0.3], [-0.6, 1.0, 0.2], [0.3, 0.2, 1.0]])
    cov = corr * np.outer(std, std)
    intervals = {"q1": (values[0] - 1.5e-7, values[0] + 4e-7),  # wider above: 4e-7 / 1.96 > 1e-7
                 "q2": (values[1] - 3e-7, None)}  # open above: the interval says so, the std stays
    s2, c2 = std_within(names, values, std, cov, intervals)
    assert Z95 == pytest.approx(1.959964, abs=1e-6)
    assert s2[0] == pytest.approx(4e-7 / Z95) and s2[1] == std[1] and s2[2] == std[2]
    assert np.allclose(c2 / np.outer(s2, s2), corr)
    assert np.allclose(np.sqrt(np.diag(c2)), s2)
    s3, c3 = std_within(names, values, std, cov, {"q1": (values[0] - 1e-7, values[0] + 1e-7)})
    assert np.array_equal(s3, std) and np.array_equal(c3, cov)


def test_every_plane_s_1x_line_is_checked_not_only_the_first_two():
    """A record of three planes (the fan's) whose third plane holds no 1X line, or no backward one, is refused
    naming that plane; the same record with the line there passes the check."""
    from types import SimpleNamespace

    from lubeviz.identify.fit.result import check_record
    from lubeviz.identify.fit.settings import IdentificationSettings

    model = SimpleNamespace(omega=2 * math.pi * 24.75, nodes=(7, 15, 22))

    def measured(snr):
        return SimpleNamespace(speed_hz=24.75, nodes=(7, 15, 22), line_snr=np.array(snr, float), source="fan.csv",
                               strongest_line_hz=24.75)

    settings = IdentificationSettings()
    check_record(model, measured([[90, 40], [80, 30], [70, 20]]), settings)
    with pytest.raises(InputError, match=r"fan.csv: plane 3 \(node 22\): no usable 1X line"):
        check_record(model, measured([[90, 40], [80, 30], [1.0, 0.5]]), settings)
    with pytest.raises(InputError, match=r"plane 3 \(node 22\): the backward 1X component is buried in noise"):
        check_record(model, measured([[90, 40], [80, 30], [70, 1.0]]), settings)
