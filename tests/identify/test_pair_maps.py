"""Maps over two of a machine's flows, the others held (`identify.fit.maps`, the Maps page of a machine of any
number of bearings): on a record the model itself made, chi^2 is smallest at the true flows of whichever pair is
drawn; swapping the axes transposes the map; the features drawn are the chain's own at each point; the Diagnose
page's map (`diagnose.loop.cost_map`) is the same map."""

from __future__ import annotations

import numpy as np
import pytest

from lubeviz.diagnose.loop import cost_map
from lubeviz.errors import InputError
from lubeviz.identify.fit.maps import pair_grid, pair_map
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.identify.forward.measured import measure
from lubeviz.model.machine import MODELS_DIR, load_machine

N = 21
S = np.linspace(np.sqrt(0.25), np.sqrt(2.0), N) ** 2  # the grid's fractions of Q_T


@pytest.fixture(scope="module")
def fan():
    m = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    chain = ForwardChain(m, m.operating_speed, [p.node for p in m.measurement_planes])
    truth = chain.start()
    at = (6, 13, 9)  # grid indices: 0.48, 1.20, 0.77 Q_T
    truth[:3] = [S[i] * q for i, q in zip(at, chain.q_threshold)]
    record = simulate(chain, truth, snr_db=40.0, rng=np.random.default_rng(5))
    return chain, truth, at, measure(record)


@pytest.mark.parametrize("pair", [(0, 1), (0, 2), (2, 1)])
def test_chi2_is_least_at_the_true_flows_of_the_pair_drawn(fan, pair):
    chain, truth, at, measured = fan
    pm = pair_map(chain, pair, truth, measured=measured, n=N)
    i, j = np.unravel_index(np.argmin(pm.chi2), pm.chi2.shape)
    assert (i, j) == (at[pair[0]], at[pair[1]])
    assert pm.qx[i] == pytest.approx(truth[pair[0]]) and pm.qy[j] == pytest.approx(truth[pair[1]])
    assert pm.chi2[i, j] < 0.05 * np.median(pm.chi2)


def test_swapping_the_axes_transposes_the_map_and_the_features_are_the_chain_s(fan):
    chain, truth, at, measured = fan
    names = ("fb1", "phi3")
    a = pair_map(chain, (0, 2), truth, measured=measured, features=names, n=N)
    b = pair_map(chain, (2, 0), truth, measured=measured, features=names, n=N)
    np.testing.assert_allclose(a.chi2, b.chi2.T, rtol=1e-12)
    point = truth.copy()
    point[0], point[2] = a.qx[3], a.qy[17]
    np.testing.assert_allclose(a.features[3, 17], chain.features(point, names), rtol=1e-12)
    assert a.held[1] == truth[1]  # the third flow held where it was given


def test_the_diagnose_map_is_the_same_map(fan):
    chain, truth, at, measured = fan
    q1, q2, chi2 = cost_map(chain, measured, n=N, flows=truth[:3])
    pm = pair_map(chain, (0, 1), truth, measured=measured, n=N)
    np.testing.assert_allclose(chi2, pm.chi2, rtol=1e-12)
    np.testing.assert_allclose(q1, pm.qx)


def test_a_pair_the_chain_lacks_or_a_held_vector_of_the_wrong_length_is_refused(fan):
    chain, truth, *_ = fan
    with pytest.raises(InputError, match="two different flows among 0..2"):
        pair_grid(chain, (1, 1), truth)
    with pytest.raises(InputError, match="two different flows"):
        pair_grid(chain, (0, 3), truth)
    with pytest.raises(InputError, match="held values"):
        pair_grid(chain, (0, 1), truth[:2])


def test_a_diagnosis_maps_the_unknown_flows_when_one_supply_is_known(fan, tmp_path):
    """A machine whose first bearing's supply is known (SPEC §8 `supply_mlmin`): the diagnosis's map is drawn
    over the two unknown flows, Q2 x Q3 (Q1 is held, not searched), the search path on it ends at the fit's Q2 and
    Q3, and the report names those axes (it drew Q1 x Q2, the held flow against one unknown, before)."""
    from lubeviz.diagnose.pipeline import run_diagnosis
    from lubeviz.diagnose.report import report_html, report_maps
    from lubeviz.diagnose.settings import DiagnosisSettings
    from lubeviz.effects import EFFECTS
    from lubeviz.units import MLMIN_PER_M3S

    chain, truth, at, _ = fan
    text = (MODELS_DIR / "three_bearing_fan.toml").read_text(encoding="utf-8")
    known = f'supply = "known"\nsupply_mlmin = {truth[0] * MLMIN_PER_M3S:.6f}\n'
    path = tmp_path / "fan_known_q1.toml"
    path.write_text(text.replace("[[bearings]]\n", "[[bearings]]\n" + known, 1), encoding="utf-8")
    m = load_machine(path)
    assert m.bearings[0].supply == "known" and m.bearings[1].supply == "unknown"
    record = simulate(ForwardChain(m, m.operating_speed), truth, snr_db=40.0, rng=np.random.default_rng(6))
    run = run_diagnosis([record], m, DiagnosisSettings(map_points=7), candidates=[EFFECTS["probe_gain"]])
    (title, (qi, qj, chi2), fit, pair), *_ = run.maps
    assert pair == (1, 2) and chi2.shape == (7, 7)
    assert qi[0] < truth[1] < qi[-1] and qj[0] < truth[2] < qj[-1]
    assert fit.flow_values()[0] == pytest.approx(truth[0], rel=1e-5)  # held
    np.testing.assert_allclose(fit.paths[-1][-1][[1, 2]], fit.flow_values()[[1, 2]], rtol=1e-9)
    html = report_html(run.diagnosis, maps=report_maps(run.maps, run.diagnosis))
    assert "The search over Q2 × Q3" in html and "Q3 (ml/min)" in html and "Q1 (ml/min)" not in html
